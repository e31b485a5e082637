// Runs across hosts, the pure parts (model/hosts.h, docs/hosts.md): host lists, ranks from
// slots, the bus URL's TTL, the launch-command template, the remote command, the [hosts] keys.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "child_process.h"
#include "hosts.h"
#include "minimal_scene.h"
#include "scene.h"
#include "test_helpers.h"

using namespace hemo;

namespace {
std::string temp_dir() {
  char name[] = "/tmp/hemo_hosts_XXXXXX";
  return ::mkdtemp(name);
}

std::string first_problem(const std::string& text) {
  try {
    load_scene(test::write_temp(text));
  } catch (const SceneError& e) {
    return e.problems().front().str("s.toml");
  }
  return "";
}
}  // namespace

TEST(Hosts, ParsesHostsWithAndWithoutSlots) {
  const auto h = parse_host_list(" b:2, c:2 ,d ");
  ASSERT_EQ(h.size(), 3u);
  EXPECT_EQ(h[0].host, "b");
  EXPECT_EQ(h[0].slots, 2);
  EXPECT_EQ(h[2].host, "d");
  EXPECT_EQ(h[2].slots, 1);
  EXPECT_EQ(total_slots(h), 5);
  EXPECT_EQ(host_list_text(h), "b:2,c:2,d:1");
  EXPECT_TRUE(parse_host_list("").empty());
  EXPECT_EQ(parse_host_list("10.77.0.2:1,node-3.lan")[1].host, "node-3.lan");
}

TEST(Hosts, RefusesMalformedListsWithOneLineReasons) {
  for (const char* bad :
       {"a,,b", "a:", "a:0", "a:-1", "a:x", "a:99999", "a b", "a;rm -rf", "-oProxyCommand=x", "a,a:2", ","}) {
    try {
      parse_host_list(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
}

TEST(Hosts, HostsDecideTheRanksAndAConflictingCountIsRefused) {
  const auto h = parse_host_list("b:2,c:2");
  EXPECT_EQ(ranks_for_hosts(h, 1, "run.particle_ranks"), 4);  // 1 is the default: the hosts decide
  EXPECT_EQ(ranks_for_hosts(h, 4, "run.particle_ranks"), 4);
  EXPECT_EQ(ranks_for_hosts({}, 3, "run.particle_ranks"), 3);  // no hosts: as asked
  try {
    ranks_for_hosts(h, 3, "--np-particles");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "--np-particles = 3 but the hosts b:2,c:2 give 4 ranks; give one or the other");
  }
}

TEST(Hosts, TheBusLeavesTheHostOnlyWithHostsOrWhenAsked) {
  EXPECT_EQ(bus_ttl(-1, false), 0);
  EXPECT_EQ(bus_ttl(-1, true), 1);
  EXPECT_EQ(bus_ttl(3, false), 3);
  EXPECT_EQ(bus_ttl(0, true), 0);
  EXPECT_EQ(bus_url(1, 2, 30000, 1), "udpm://239.255.1.2:30000?ttl=1");
}

TEST(Hosts, LaunchTemplateFillsPlaceholdersAndKeepsTheCommandOneWord) {
  const auto argv = expand_launch_command("ssh -p 2222 -o BatchMode=yes {host} {command}",
                                          {{"host", "b"}, {"command", "cd '/r' && exec x"}, {"node", "particles"}});
  EXPECT_EQ(argv, (std::vector<std::string>{"ssh", "-p", "2222", "-o", "BatchMode=yes", "b", "cd '/r' && exec x"}));
  EXPECT_EQ(expand_launch_command("run-on {node}@{host}:{run_dir} {command}",
                                  {{"host", "h"}, {"node", "fluid"}, {"run_dir", "/d"}, {"command", "c"}}),
            (std::vector<std::string>{"run-on", "fluid@h:/d", "c"}));
  EXPECT_THROW(check_launch_command("ssh {host}"), std::invalid_argument);            // no {command}
  EXPECT_THROW(check_launch_command("ssh {hots} {command}"), std::invalid_argument);  // unknown
  EXPECT_THROW(check_launch_command("ssh {host {command}"), std::invalid_argument);   // unclosed
  EXPECT_NO_THROW(check_launch_command(kDefaultLaunchCommand));
}

TEST(Hosts, ShellQuotingSurvivesTheShell) {
  const std::string nasty = "it's a $(dangerous) `word` \"here\"";
  std::string out;
  ChildOptions opt;
  opt.on_line = [&out](const std::string& l) { out += l; };
  EXPECT_TRUE(run_child({"sh", "-c", "printf '%s' " + shell_quote(nasty)}, opt).ok());
  EXPECT_EQ(out, nasty);
}

// The remote command runs the node in the run directory with its exit status, and stops it when
// its stdin (the connection) closes.
TEST(Hosts, RemoteCommandRunsInTheRunDirectoryAndEndsWithItsStdin) {
  const std::string dir = temp_dir();
  std::string out;
  ChildOptions opt;
  opt.on_line = [&out](const std::string& l) { out += l; };
  // Its stdin held open (fd 9 of the shell around it) while it runs.
  const auto r = run_child({"sh", "-c",
                            "cd " + shell_quote(dir) + " && mkfifo in || exit 1; { " +
                                remote_node_command(dir, {"sh", "-c", "pwd; exit 7"}) + "; } <in & exec 9>" +
                                shell_quote(dir + "/in") + "; wait $!"},
                           opt);
  EXPECT_EQ(r.exit_code, 7);
  EXPECT_EQ(out, dir);
  // stdin at its end at once: the node (which would sleep a minute) is stopped.
  const auto start = std::chrono::steady_clock::now();
  const auto s = run_child({"sh", "-c", remote_node_command(dir, {"sleep", "60"}) + " </dev/null"});
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
  EXPECT_EQ(s.exit_code, 128 + 15);  // SIGTERM
  EXPECT_EQ(remote_check_command("/r d"), "cat '/r d/hosts-check'");
}

TEST(Hosts, SceneTableIsReadAndValidated) {
  const Scene s = load_scene(test::write_temp(std::string(test::kMinimalScene) + R"(
[hosts]
fluid = "a"
particles = "b:2,c:2"
launcher = "local"
)"));
  EXPECT_EQ(s.hosts.particles, "b:2,c:2");
  EXPECT_EQ(s.run.particle_ranks, 4);
  EXPECT_EQ(s.run.fluid_ranks, 1);
  EXPECT_EQ(s.hosts.launcher, Launcher::local);
  EXPECT_EQ(s.hosts.launch_command, kDefaultLaunchCommand);
  EXPECT_EQ(s.run.bus_ttl, -1);

  EXPECT_NE(
      first_problem(std::string(test::kMinimalScene) + "[run]\nparticle_ranks = 3\n[hosts]\nparticles = \"b:2,c:2\"\n")
          .find("run.particle_ranks = 3 but the hosts b:2,c:2 give 4 ranks"),
      std::string::npos);
  EXPECT_NE(first_problem(std::string(test::kMinimalScene) + "[hosts]\nparticles = \"b:0\"\n").find("hosts.particles"),
            std::string::npos);
  EXPECT_NE(first_problem(std::string(test::kMinimalScene) + "[hosts]\nlauncher = \"pbs\"\n").find("hosts.launcher"),
            std::string::npos);
  EXPECT_EQ(first_problem(std::string(test::kMinimalScene) + "[hosts]\nlauncher = \"slurm\"\n"), "");
  EXPECT_NE(
      first_problem(std::string(test::kMinimalScene) + "[hosts]\nlaunch_command = \"ssh {host}\"\n").find("{command}"),
      std::string::npos);
  EXPECT_NE(first_problem(std::string(test::kMinimalScene) + "[run]\nbus_ttl = 300\n").find("run.bus_ttl"),
            std::string::npos);
  EXPECT_NE(first_problem(std::string(test::kMinimalScene) + "[run]\nbus_check_s = 0\n").find("run.bus_check_s"),
            std::string::npos);
}

TEST(Hosts, TransportKeysAreReadAndValidated) {
  const Scene m = load_scene(test::write_temp(std::string(test::kMinimalScene)));
  EXPECT_EQ(m.hosts.transport, Transport::multicast);
  EXPECT_FALSE(m.hosts.tcp());
  EXPECT_EQ(m.hosts.relay_address, "auto");
  EXPECT_EQ(m.hosts.relay_port, 0);
  const Scene t = load_scene(test::write_temp(std::string(test::kMinimalScene) +
                                              "[hosts]\ntransport = \"tcp\"\nrelay_address = \"10.1.2.3\"\n"
                                              "relay_port = 7700\n"));
  EXPECT_TRUE(t.hosts.tcp());
  EXPECT_EQ(t.hosts.relay_address, "10.1.2.3");
  EXPECT_EQ(t.hosts.relay_port, 7700);
  // One line each, naming the key.
  for (const auto& [text, key] :
       {std::pair{"[hosts]\ntransport = \"udp\"\n", "unknown name 'udp' (known: multicast, tcp)"},
        {"[hosts]\nrelay_address = \"coordinator.example\"\n", "hosts.relay_address"},
        {"[hosts]\nrelay_port = 70000\n", "hosts.relay_port"},
        {"[hosts]\nrelay_port = -1\n", "hosts.relay_port"}}) {
    const std::string problem = first_problem(std::string(test::kMinimalScene) + text);
    EXPECT_NE(problem.find(key), std::string::npos) << problem;
    EXPECT_EQ(problem.find('\n'), std::string::npos) << problem;
  }
}

// The bus check's evidence: a heartbeat thread hears the run's other processes (and only those
// that hold the secret) and reports them in the run directory.
TEST(Hosts, HeartbeatsReportWhomTheyHearInTheRunDirectory) {
  auto ctx = test::make_context("heard");
  const std::string dir = temp_dir();
  ctx.secret_file = dir + "/secret";
  const std::string file = heard_report_file(ctx, "fluid");
  EXPECT_EQ(file, dir + "/bus-check/fluid");
  auto forger_ctx = ctx;
  forger_ctx.secret[0] ^= 1;
  Heartbeat fluid(ctx, "fluid", 0.1, {}, HeardReport{true, file});
  Heartbeat particles(ctx, "particles", 0.1);
  Heartbeat forger(forger_ctx, "coordinator", 0.1);
  std::optional<HeardReportLine> report;
  for (int i = 0; i < 100 && !(report && report->heard.count("particles")); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    report = read_heard_report(file);
  }
  ASSERT_TRUE(report);
  EXPECT_EQ(report->heard, (std::set<std::string>{"particles"}));  // not itself, not the forger
  EXPECT_EQ(fluid.heard(), (std::set<std::string>{"particles"}));
  EXPECT_FALSE(report->host.empty());
  EXPECT_FALSE(read_heard_report(dir + "/bus-check/nobody"));
}

// `hemocosim run --particle-hostfile FILE`: Open MPI's host file format as a host list.
TEST(Hosts, AnOpenMpiHostFileIsReadAsAHostList) {
  const std::string dir = temp_dir();
  std::ofstream(dir + "/hosts") << "# the particle node\nb slots=2\n\n  c   # one slot\nb slots=1\n";
  EXPECT_EQ(read_host_file(dir + "/hosts"), "b:3,c:1");  // b's lines add up
  std::ofstream(dir + "/bad") << "b slots=2\nc max_slots=4\n";
  try {
    read_host_file(dir + "/bad");
    FAIL() << "max_slots accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/bad:2"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/empty") << "# nobody\n";
  EXPECT_THROW(read_host_file(dir + "/empty"), std::invalid_argument);
  std::ofstream(dir + "/inject") << "-oProxyCommand=x\n";
  EXPECT_THROW(read_host_file(dir + "/inject"), std::invalid_argument);
  EXPECT_THROW(read_host_file(dir + "/missing"), std::invalid_argument);
}
