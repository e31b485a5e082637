// Runs across hosts (docs/hosts.md) on three simulated hosts: network namespaces on a bridge,
// each with its own address, host name and sshd (tests/hosts/netns.sh). The coordinator runs in
// the first, the fluid node is started in the first through ssh, the particle node is a 2-rank
// MPI job across the second and third, started in the second through ssh (Open MPI reaches the
// third with its own ssh). Real sshd, mpirun, LCM multicast with TTL 1, the real nodes.
// Needs root (network namespaces); skips with the reason otherwise.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <future>
#include <set>
#include <sstream>
#include <thread>

#include "run_helpers.h"

using namespace hemo::test;
namespace fs = std::filesystem;

namespace {

std::string g_name, g_dir, g_skip;  // namespaces NAME-1..3, their keys and configs; why skipped

std::string script() { return std::string(HEMO_HOSTS_DIR) + "/netns.sh"; }
std::string ns(int i) { return g_name + "-" + std::to_string(i); }
std::string ip(int i) { return "10.77.0." + std::to_string(i); }

// `hemocosim run` in the first namespace with the fluid there and the particles on hosts 2 and 3.
std::string run_across_hosts(const std::string& scene, const std::string& out, const std::string& more = "") {
  return "ip netns exec " + ns(1) + " " + bin("hemocosim") + " run " + scene + " --out " + out + " --fluid-hosts " +
         ip(1) + " --particle-hosts " + ip(2) + ":1," + ip(3) + ":1 --launch-command '" + g_dir +
         "/ssh {host} {command}'" + more;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Inode of a network namespace: a process is in it when /proc/PID/ns/net has the same.
ino_t netns_inode(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? st.st_ino : 0;
}

struct Process {
  pid_t pid;
  std::string name;
  std::string cmdline;
  ino_t net;
};
std::vector<Process> processes() {
  std::vector<Process> out;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string pid = e.path().filename();
    if (pid.find_first_not_of("0123456789") != std::string::npos) continue;
    Process p{static_cast<pid_t>(std::stol(pid)), read_file("/proc/" + pid + "/comm"),
              read_file("/proc/" + pid + "/cmdline"), netns_inode("/proc/" + pid + "/ns/net")};
    if (!p.name.empty() && p.name.back() == '\n') p.name.pop_back();
    out.push_back(p);
  }
  return out;
}

// Watches the processes while a run goes: which namespaces ran a particle rank, and whether
// any command line held the run's secret (it must travel only as the file).
struct Watch {
  std::atomic<bool> stop{false};
  std::set<std::string> particle_namespaces;
  int processes_seen = 0;
  bool secret_on_a_command_line = false;
  std::thread thread;
  explicit Watch(const std::string& run_dir) {
    thread = std::thread([this, run_dir] {
      std::map<ino_t, std::string> names;
      for (int i = 1; i <= 3; ++i) names[netns_inode("/run/netns/" + ns(i))] = ns(i);
      std::string secret, hex;
      while (!stop) {
        if (secret.empty()) {
          secret = read_file(run_dir + "/secret");
          for (unsigned char c : secret) hex += fmt_hex(c);
        }
        for (const auto& p : processes()) {
          ++processes_seen;
          if (p.name == "hemocosim-parti" && names.count(p.net)) particle_namespaces.insert(names[p.net]);
          if (!secret.empty() &&
              (p.cmdline.find(secret) != std::string::npos || p.cmdline.find(hex) != std::string::npos))
            secret_on_a_command_line = true;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
      }
    });
  }
  static std::string fmt_hex(unsigned char c) {
    char b[3];
    std::snprintf(b, sizeof b, "%02x", c);
    return b;
  }
  void finish() {
    stop = true;
    thread.join();
  }
};

// Exactly the same particles in every snapshot and the same flow every step.
void expect_bit_for_bit(const std::string& a, const std::string& b) {
  const auto names = snapshot_names(a + "/particles.h5");
  ASSERT_EQ(names, snapshot_names(b + "/particles.h5"));
  ASSERT_GE(names.size(), 2u);  // the start and at least one after it
  for (const auto& name : names) {
    const auto sa = read_snapshot(a + "/particles.h5", name), sb = read_snapshot(b + "/particles.h5", name);
    EXPECT_EQ(sa.id, sb.id) << name;
    EXPECT_EQ(sa.position, sb.position) << name;
    EXPECT_EQ(sa.velocity, sb.velocity) << name;
  }
  const auto ma = read_metrics(a), mb = read_metrics(b);
  EXPECT_EQ(ma.at({"fluid", "mean_velocity_m_s"}), mb.at({"fluid", "mean_velocity_m_s"}));
}

std::string scene_file(const std::string& name, long steps, long checkpoint_every, const std::string& run_keys = "") {
  std::string text = small_scene_text(steps, run_keys);
  if (checkpoint_every > 0) {
    const std::string output = "every_steps = 10";
    text.replace(text.find(output), output.size(),
                 output + "\ncheckpoint_every_steps = " + std::to_string(checkpoint_every));
  }
  const std::string path = fresh_run_dir(name) + ".toml";
  std::ofstream(path) << text;
  return path;
}

class AcrossHosts : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (::geteuid() != 0) {
      g_skip = "needs root for network namespaces (CI runs it as root)";
      return;
    }
    for (const char* tool : {"/usr/sbin/sshd", "/usr/sbin/iptables", "/usr/bin/mpirun"})
      if (::access(tool, X_OK) != 0) {
        g_skip = std::string("needs ") + tool + " (deploy/install-deps.sh installs it)";
        return;
      }
    g_name = "hc" + std::to_string(::getpid() % 100000);
    g_dir = fresh_run_dir("hosts-" + g_name);
    const auto up = run(script() + " up " + g_name + " 3 " + g_dir);
    if (up.exit_code != 0) g_skip = "cannot set up the network namespaces: " + up.output;
  }
  static void TearDownTestSuite() {
    if (!g_name.empty()) run(script() + " down " + g_name + " " + g_dir);
  }
  void SetUp() override {
    if (!g_skip.empty()) GTEST_SKIP() << g_skip;
  }
};

}  // namespace

// The quick-start scene (scenes/quickstart.toml) across three hosts ends exactly as on one host
// with the same two particle ranks; the secret is on no command line. Its first 250 of 2,500
// steps (two snapshots): across the namespaces each of the 140 DEM substeps of a step exchanges
// halos between the two particle ranks over TCP (docs/hosts.md), and the whole scene would take
// minutes.
TEST_F(AcrossHosts, TwoRankParticleJobAcrossHostsEqualsTheOneHostRunBitForBit) {
  const std::string scene = std::string(HEMO_SCENES_DIR) + "/quickstart.toml";
  const std::string stop = " --stop-after-step 250";
  const std::string one = fresh_run_dir("hosts-one"), across = fresh_run_dir("hosts-across");
  const auto a = run(bin("hemocosim") + " run " + scene + " --out " + one + " --np-particles 2" + stop);
  ASSERT_EQ(a.exit_code, 0) << a.output;

  Watch watch(across);
  const auto b = run(run_across_hosts(scene, across, stop));
  watch.finish();
  ASSERT_EQ(b.exit_code, 0) << b.output;
  EXPECT_NE(b.output.find("stopped after step 250"), std::string::npos) << b.output;
  expect_bit_for_bit(one, across);

  // Where it ran: the ranks in namespaces 2 and 3, the bus at TTL 1, placement kept for resume.
  EXPECT_EQ(watch.particle_namespaces, (std::set<std::string>{ns(2), ns(3)}));
  EXPECT_GT(watch.processes_seen, 0);
  EXPECT_FALSE(watch.secret_on_a_command_line);
  const std::string info = read_file(across + "/run.toml");
  EXPECT_NE(info.find("?ttl=1'"), std::string::npos) << info;
  EXPECT_NE(info.find("particles = '" + ip(2) + ":1," + ip(3) + ":1'"), std::string::npos) << info;
  EXPECT_NE(info.find("particle_ranks = 2"), std::string::npos) << info;
  EXPECT_NE(read_file(across + "/bus-check/particles").find("host=" + ns(2) + " heard=coordinator,fluid"),
            std::string::npos);
  EXPECT_NE(read_file(across + "/bus-check/fluid").find("host=" + ns(1) + " heard=coordinator,particles"),
            std::string::npos);
  EXPECT_EQ((fs::status(across + "/secret").permissions() & fs::perms::all),
            fs::perms::owner_read | fs::perms::owner_write);
}

// Both nodes on two ranks spread over the three hosts (the fluid's on hosts 1 and 2, the
// particles' on 2 and 3), so that every rank's partitions, feedback and reports cross a host
// boundary: the small scene ends bit for bit as the same 2 x 2 run on one host, and so as the
// one-rank run to the decomposed fluid's round-off (PartitionedRun's bounds: 1e-12 m, 1e-6 of
// the fastest velocity, 1e-7 of the mean flow). The coordinator heard every rank's report of
// every step.
TEST_F(AcrossHosts, TwoByTwoRanksAcrossHostsEqualTheOneHostRuns) {
  const std::string scene = scene_file("hosts-2x2-scene", 40, 0);
  const std::string one = fresh_run_dir("hosts-2x2-1x1"), two = fresh_run_dir("hosts-2x2-one-host"),
                    across = fresh_run_dir("hosts-2x2-across");
  const auto a = run(bin("hemocosim") + " run " + scene + " --out " + one);
  ASSERT_EQ(a.exit_code, 0) << a.output;
  const auto b = run(bin("hemocosim") + " run " + scene + " --out " + two + " --np-fluid 2 --np-particles 2");
  ASSERT_EQ(b.exit_code, 0) << b.output;

  Watch watch(across);
  const auto c = run("ip netns exec " + ns(1) + " " + bin("hemocosim") + " run " + scene + " --out " + across +
                     " --fluid-hosts " + ip(1) + ":1," + ip(2) + ":1 --particle-hosts " + ip(2) + ":1," + ip(3) +
                     ":1 --launch-command '" + g_dir + "/ssh {host} {command}'");
  watch.finish();
  ASSERT_EQ(c.exit_code, 0) << c.output;
  expect_bit_for_bit(two, across);
  EXPECT_EQ(watch.particle_namespaces, (std::set<std::string>{ns(2), ns(3)}));
  const std::string info = read_file(across + "/run.toml");
  EXPECT_NE(info.find("fluid_ranks = 2"), std::string::npos) << info;

  const auto names = snapshot_names(one + "/particles.h5");
  ASSERT_EQ(names, snapshot_names(across + "/particles.h5"));
  const auto sa = read_snapshot(one + "/particles.h5", names.back());
  const auto sb = read_snapshot(across + "/particles.h5", names.back());
  ASSERT_EQ(sa.id, sb.id);
  double fastest = 0, position = 0, velocity = 0;
  for (std::size_t i = 0; i < sa.position.size(); ++i) {
    fastest = std::max(fastest, std::abs(sa.velocity[i]));
    position = std::max(position, std::abs(sa.position[i] - sb.position[i]));
    velocity = std::max(velocity, std::abs(sa.velocity[i] - sb.velocity[i]));
  }
  std::printf("[ info ] 2 x 2 across hosts against 1 x 1 after %s: positions %.3g m, velocities %.3g of the fastest\n",
              names.back().c_str(), position, velocity / fastest);
  EXPECT_LT(position, 1e-12);
  EXPECT_LT(velocity, 1e-6 * fastest);
  const auto ma = read_metrics(one), mc = read_metrics(across);
  const auto &ua = ma.at({"fluid", "mean_velocity_m_s"}), &uc = mc.at({"fluid", "mean_velocity_m_s"});
  ASSERT_EQ(ua.size(), uc.size());
  for (const auto& [step, value] : ua) EXPECT_NEAR(uc.at(step), value, 1e-7 * std::abs(value)) << step;
  for (const char* node : {"fluid", "particles"}) {
    const auto it = mc.find({node, "rank1_compute_s"});
    ASSERT_NE(it, mc.end()) << node;
    EXPECT_EQ(it->second.size(), mc.at({node, "compute_s"}).size()) << node << "'s rank 1 reported every step";
    EXPECT_EQ(it->second.size(), 41u) << node << ": the start-up and 40 steps";
  }
}

// A particle rank killed on the third host (SIGKILL): its MPI job ends, the coordinator restarts
// both nodes from the last checkpoint, on the same hosts, and the run ends as without the fault.
TEST_F(AcrossHosts, RankKilledOnOneHostIsRestartedFromTheCheckpointAndTheRunEnds) {
  const std::string scene = scene_file("hosts-kill-scene", 60, 10);
  const std::string one = fresh_run_dir("hosts-kill-one"), across = fresh_run_dir("hosts-kill-across");
  const auto a = run(bin("hemocosim") + " run " + scene + " --out " + one + " --np-particles 2");
  ASSERT_EQ(a.exit_code, 0) << a.output;

  auto result = std::async(std::launch::async, [&] { return run(run_across_hosts(scene, across)); });
  const ino_t third = netns_inode("/run/netns/" + ns(3));
  pid_t killed = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(3);
  while (!killed && std::chrono::steady_clock::now() < deadline &&
         result.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
    if (!fs::is_directory(across + "/checkpoints/step-20/particles") &&
        !fs::is_directory(across + "/checkpoints/step-30/particles"))
      continue;
    for (const auto& p : processes())
      if (p.name == "hemocosim-parti" && p.net == third && ::kill(p.pid, SIGKILL) == 0) killed = p.pid;
  }
  const auto b = result.get();
  ASSERT_GT(killed, 0) << "no particle rank found in " << ns(3) << "\n" << b.output;
  ASSERT_EQ(b.exit_code, 0) << b.output;
  EXPECT_NE(b.output.find("restarting both nodes from the checkpoint of step"), std::string::npos) << b.output;
  EXPECT_NE(b.output.find("(1 restart)"), std::string::npos) << b.output;
  expect_bit_for_bit(one, across);
}

// Multicast from the first host does not reach the second (a firewall there): the run stops at
// start-up with one line naming who does not hear whom.
TEST_F(AcrossHosts, BlockedMulticastStopsTheRunWithOneLineNamingThePair) {
  const std::string scene = scene_file("hosts-blocked-scene", 40, 0, "bus_check_s = 4\n");
  const std::string across = fresh_run_dir("hosts-blocked");
  ASSERT_EQ(run(script() + " block " + g_name + " 1 2").exit_code, 0);
  const auto b = run(run_across_hosts(scene, across));
  run("ip netns exec " + ns(2) + " iptables -D INPUT -s " + ip(1) + " -d 224.0.0.0/4 -j DROP");
  EXPECT_NE(b.exit_code, 0);
  const std::string line = error_line(b.output);
  std::printf("%s\n", line.c_str());
  EXPECT_EQ(
      line.rfind("hemocosim: error: bus check: the particles node (on " + ns(2) + ") does not hear the coordinator", 0),
      0u)
      << b.output;
  EXPECT_NE(line.find("the particles node (on " + ns(2) + ") does not hear the fluid node (on " + ns(1) + ")"),
            std::string::npos)
      << line;
  EXPECT_NE(line.find("224.0.0.0/4"), std::string::npos) << line;
  std::size_t errors = 0;
  for (std::size_t at = 0; (at = b.output.find("hemocosim: error:", at)) != std::string::npos; ++at) ++errors;
  EXPECT_EQ(errors, 1u) << b.output;
  EXPECT_LT(b.seconds, 90) << "stopped by the bus check, not by a timeout";
}

// A host that does not see the run directory: refused before any node starts.
TEST_F(AcrossHosts, HostThatCannotBeReachedIsNamedBeforeAnyNodeStarts) {
  const std::string scene = scene_file("hosts-unreachable-scene", 40, 0);
  const std::string out = fresh_run_dir("hosts-unreachable");
  const auto b =
      run("ip netns exec " + ns(1) + " " + bin("hemocosim") + " run " + scene + " --out " + out +
          " --particle-hosts 10.77.0.9 --launch-command '" + g_dir + "/ssh -o ConnectTimeout=2 {host} {command}'");
  EXPECT_NE(b.exit_code, 0);
  EXPECT_EQ(error_line(b.output).rfind("hemocosim: error: cannot reach host 10.77.0.9", 0), 0u) << b.output;
  EXPECT_FALSE(fs::exists(out + "/particles.log")) << "no node was started";
}

namespace {
// A network that does not carry multicast between hosts (each namespace drops what arrives for
// 224.0.0.0/4 from the others), or, with `on_each_host`, not even within a host (everything to
// 224.0.0.0/4 dropped, the host's own datagrams too), for as long as this lives.
struct MulticastDropped {
  explicit MulticastDropped(bool on_each_host) {
    for (int i = 1; i <= 3; ++i) {
      rules.push_back(on_each_host ? "INPUT -d 224.0.0.0/4 -j DROP"
                                   : "INPUT -d 224.0.0.0/4 ! -s " + ip(i) + " -j DROP");
      ok &= run("ip netns exec " + ns(i) + " iptables -I " + rules.back()).exit_code == 0;
    }
  }
  ~MulticastDropped() {
    for (int i = 1; i <= 3; ++i)
      run("ip netns exec " + ns(i) + " iptables -D " + rules[static_cast<std::size_t>(i - 1)]);
  }
  std::vector<std::string> rules;
  bool ok = true;
};

std::size_t error_lines(const std::string& output) {
  std::size_t errors = 0;
  for (std::size_t at = 0; (at = output.find("hemocosim: error:", at)) != std::string::npos; ++at) ++errors;
  return errors;
}
}  // namespace

// Where multicast cannot pass between the hosts, the multicast run stops at the bus check in one
// line that names the TCP transport; where it cannot pass even within the coordinator's host,
// the run stops at once in one line (LCM's self test fails; this crashed in LCM's C++ wrapper
// before). The same run with `--transport tcp` (the coordinator's relay in namespace 1, the nodes
// connected to it from namespaces 1, 2 and 3) ends exactly as the one-host run on multicast, also
// across a `hemocosim resume` (which must take the transport from run.toml: over multicast it
// would stop).
TEST_F(AcrossHosts, WithoutMulticastTheTcpTransportRunsAndEqualsTheOneHostRunBitForBit) {
  const std::string scene = scene_file("hosts-tcp-scene", 40, 10, "bus_check_s = 4\n");
  const std::string one = fresh_run_dir("hosts-tcp-one"), tcp = fresh_run_dir("hosts-tcp");
  const auto a = run(bin("hemocosim") + " run " + scene + " --out " + one + " --np-particles 2");
  ASSERT_EQ(a.exit_code, 0) << a.output;

  {
    MulticastDropped between_hosts(false);
    ASSERT_TRUE(between_hosts.ok);
    const auto m = run(run_across_hosts(scene, fresh_run_dir("hosts-tcp-multicast")));
    EXPECT_NE(m.exit_code, 0);
    const std::string line = error_line(m.output);
    std::printf("%s\n", line.c_str());
    // (The coordinator runs in namespace 1 without a host name of its own.)
    EXPECT_EQ(line.rfind("hemocosim: error: bus check: the coordinator (on ", 0), 0u) << m.output;
    EXPECT_NE(line.find("does not hear the particles node (on " + ns(2) + ") within 4 s"), std::string::npos) << line;
    EXPECT_NE(line.find("the particles node (on " + ns(2) + ") does not hear the fluid node (on " + ns(1) + ")"),
              std::string::npos)
        << line;
    EXPECT_NE(line.find("--transport tcp"), std::string::npos) << line;
    EXPECT_EQ(error_lines(m.output), 1u) << m.output;
  }
  MulticastDropped everywhere(true);
  ASSERT_TRUE(everywhere.ok);
  const auto m = run(run_across_hosts(scene, fresh_run_dir("hosts-tcp-multicast-none")));
  EXPECT_NE(m.exit_code, 0);
  const std::string line = error_line(m.output);
  std::printf("%s\n", line.c_str());
  EXPECT_EQ(line.rfind("hemocosim: error: cannot listen on the LCM bus at udpm://", 0), 0u) << m.output;
  EXPECT_NE(line.find("--transport tcp"), std::string::npos) << line;
  EXPECT_EQ(error_lines(m.output), 1u) << m.output;
  EXPECT_EQ(m.output.find("Segmentation fault"), std::string::npos) << m.output;

  Watch watch(tcp);
  const auto t = run(run_across_hosts(scene, tcp, " --transport tcp --stop-after-step 20"));
  ASSERT_EQ(t.exit_code, 0) << t.output;
  EXPECT_NE(t.output.find("hemocosim: bus over TCP: relay at " + ip(1) + ":"), std::string::npos) << t.output;
  const std::string info = read_file(tcp + "/run.toml");
  EXPECT_NE(info.find("lcm_url = 'tcpq://" + ip(1) + ":"), std::string::npos) << info;
  EXPECT_NE(info.find("transport = 'tcp'"), std::string::npos) << info;
  const auto r = run("ip netns exec " + ns(1) + " " + bin("hemocosim") + " resume " + tcp);
  watch.finish();
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("done in"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("hemocosim: bus over TCP"), std::string::npos) << r.output;
  expect_bit_for_bit(one, tcp);

  EXPECT_EQ(watch.particle_namespaces, (std::set<std::string>{ns(2), ns(3)}));
  EXPECT_FALSE(watch.secret_on_a_command_line);
  // The bus check passed over the relay: each node heard both other processes.
  const std::string particles_heard = read_file(tcp + "/bus-check/particles");
  const std::string fluid_heard = read_file(tcp + "/bus-check/fluid");
  EXPECT_NE(particles_heard.find("host=" + ns(2) + " heard=coordinator,fluid"), std::string::npos) << particles_heard;
  EXPECT_NE(fluid_heard.find("host=" + ns(1) + " heard=coordinator,particles"), std::string::npos) << fluid_heard;
}
