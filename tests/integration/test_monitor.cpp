// `hemocosim monitor` on real runs (issue #23): its --json lines parsed and checked against what
// the run wrote, its live page drawn by a real headless browser (Debian's chromium), and a run's
// traffic recorded by lcm-logger and played back at a monitor, which refuses it.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include "bus.h"
#include "run_helpers.h"

using namespace hemo::test;
using nlohmann::json;

namespace {
std::vector<json> json_lines(const std::string& text) {
  std::vector<json> rows;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) rows.push_back(json::parse(line));  // every line must be one JSON object
  return rows;
}

// The run, started in the background; the constructor returns once the nodes have reported a
// step (metrics.csv has rows: about 60 a step), so a monitor started then sees steps at once.
struct LiveRun {
  std::string dir;
  std::future<CommandResult> result;
  explicit LiveRun(const std::string& name, long steps, const std::string& run_keys = "",
                   const std::string& ranks = "")
      : dir(fresh_run_dir(name)) {
    std::ofstream(dir + ".toml") << small_scene_text(steps, run_keys);
    result = std::async(std::launch::async,
                        [d = dir, ranks] { return run(bin("hemocosim") + " run " + d + ".toml --out " + d + ranks); });
    wait_until_stepping(dir);
  }
  // A test that stops early must not leave the run going (nor wait for its 100,000 steps).
  ~LiveRun() {
    if (!result.valid()) return;
    interrupt();
    result.wait();
  }
  void interrupt() const {
    long pid = 0;
    std::ifstream(dir + "/coordinator.pid") >> pid;
    if (pid > 0) kill(static_cast<pid_t>(pid), SIGINT);
  }
};

// The newest step both nodes reported in metrics.csv.
long last_common_step(const Metrics& m) {
  const auto& f = m.at({"fluid", "compute_s"});
  const auto& p = m.at({"particles", "compute_s"});
  return std::min(f.rbegin()->first, p.rbegin()->first);
}

std::string chromium() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (std::filesystem::exists(p)) return p;
  return {};
}

// Chromium without a sandbox (tests may run as root) and with a profile of its own.
std::string chromium_command(const std::string& profile, const std::string& what, const std::string& url) {
  return "timeout 120 " + chromium() +
         " --headless=new --no-sandbox --disable-gpu --no-first-run --user-data-dir=" + profile +
         " --window-size=1400,1250 --virtual-time-budget=6000 " + what + " " + url;
}

long attribute(const std::string& dom, const std::string& pattern) {
  std::smatch m;
  if (!std::regex_search(dom, m, std::regex(pattern))) return -1000;
  return std::stol(m[1]);
}
}  // namespace

// A real run with every 7th received message dropped (the nodes ask again): the monitor's JSON
// lines parse, and carry what the run itself wrote to metrics.csv.
TEST(Monitor, JsonLinesOfARealRunAgreeWithItsMetrics) {
  const long steps = 5000;
  LiveRun r("monitor-json", steps, "drop_every = 7\n");
  ASSERT_TRUE(std::filesystem::exists(r.dir + "/metrics.csv"));
  // stdout only: the JSON lines, nothing else.
  const auto mon = run("(" + bin("hemocosim") + " monitor " + r.dir + " --json --interval 0.5 --duration 8 2> " +
                       r.dir + "-monitor.err)");
  r.interrupt();
  const auto ran = r.result.get();
  ASSERT_EQ(mon.exit_code, 0) << mon.output;
  std::vector<json> rows;
  ASSERT_NO_THROW(rows = json_lines(mon.output)) << mon.output;
  ASSERT_GE(rows.size(), 12u) << mon.output;
  const auto metrics = read_metrics(r.dir);

  long previous = -1, previous_fluid_step = -1, checked_diagnostics = 0, checked_compute = 0, checked_balance = 0;
  double tau_min = 1e300, tau_max = -1e300;
  for (const auto& [step, tau] : metrics.at({"fluid", "wall_shear_stress_Pa"})) {
    tau_min = std::min(tau_min, tau);
    tau_max = std::max(tau_max, tau);
  }
  std::map<std::string, long> latencies;
  bool rate_seen = false, eta_seen = false;
  for (const auto& row : rows) {
    EXPECT_EQ(row["schema"], "hemocosim-monitor/1");
    EXPECT_EQ(row["total_steps"], steps);
    const long k = row["completed_step"];
    EXPECT_GE(k, previous);
    previous = k;
    for (const auto& [channel, l] : row["latency_ms"].items()) {
      if (l["n"].get<long>() == 0) continue;
      latencies[channel] += l["n"].get<long>();
      // One host, one clock: the send stamp is before the receipt, and a loopback datagram
      // takes far less than a second.
      EXPECT_GE(l["mean"].get<double>(), 0) << channel;
      EXPECT_LT(l["max"].get<double>(), 1000) << channel;
    }
    if (row["steps_per_s_smoothed"].is_number() && row["steps_per_s_smoothed"].get<double>() > 0) rate_seen = true;
    if (row["eta_s"].is_number() && row["eta_s"].get<double>() > 0) eta_seen = true;
    // The momentum balance: an interval's mean of the fluid's wall shear stress (the latest when no
    // report came in the interval), over the imposed one. An interval in which the fluid's reported
    // step moved on has samples; how many intervals do depends on the machine's speed, not the code.
    const auto& b = row["balance"];
    const long fluid_step = row["diagnostics"].contains("fluid") ? row["diagnostics"]["fluid"]["step"].get<long>() : -1;
    if (fluid_step > previous_fluid_step) {
      EXPECT_GT(b["samples"].get<long>(), 0) << b;
    } else {
      EXPECT_EQ(b["samples"].get<long>(), 0) << b;
    }
    previous_fluid_step = fluid_step;
    if (b["wall_shear_stress_Pa"].is_number()) {
      EXPECT_GE(b["wall_shear_stress_Pa"].get<double>(), tau_min * (1 - 1e-12)) << b;
      EXPECT_LE(b["wall_shear_stress_Pa"].get<double>(), tau_max * (1 + 1e-12)) << b;
      EXPECT_GT(b["imposed_wall_shear_stress_Pa"].get<double>(), 0) << b;
      EXPECT_NEAR(b["ratio"].get<double>(),
                  b["wall_shear_stress_Pa"].get<double>() / b["imposed_wall_shear_stress_Pa"].get<double>(), 1e-12);
      ++checked_balance;
    }
    // The latest diagnostics are those of metrics.csv for that step, to the last bit.
    for (const char* node : {"fluid", "particles"}) {
      if (!row["diagnostics"].contains(node)) continue;
      const long at = row["diagnostics"][node]["step"];
      const auto& values = row["diagnostics"][node]["values"];
      const char* name = std::string(node) == "fluid" ? "courant_max" : "max_overlap";
      ASSERT_TRUE(values.contains(name)) << row.dump();
      EXPECT_EQ(values[name].get<double>(), metrics.at({node, name}).at(at)) << node << " step " << at;
      ++checked_diagnostics;
      const auto& n = row["nodes"][node];
      EXPECT_EQ(n["step"].get<long>(), at);
      EXPECT_EQ(n["last_compute_s"].get<double>(), metrics.at({node, "compute_s"}).at(at));
      EXPECT_EQ(n["last_wait_s"].get<double>(), metrics.at({node, "wait_s"}).at(at));
      ++checked_compute;
    }
  }
  EXPECT_GT(previous, 0);
  EXPECT_LE(previous, last_common_step(metrics));
  EXPECT_GT(checked_diagnostics, 10);
  EXPECT_GT(checked_compute, 10);
  EXPECT_GT(checked_balance, 10);
  EXPECT_TRUE(rate_seen);
  EXPECT_TRUE(eta_seen);
  for (const char* channel : {"FLUID_STATE", "PARTICLE_FEEDBACK", "STEP", "STEP_DONE"})
    EXPECT_GT(latencies[channel], 0) << channel << " has no latency figure";

  const auto& last = rows.back();
  EXPECT_GT(last["channels"]["FLUID_STATE"]["msgs"].get<long>(), 0);
  EXPECT_GT(last["channels"]["FLUID_STATE"]["bytes_per_msg"].get<double>(), 1000);
  // The dropped messages were asked for again and published again.
  EXPECT_GT(last["resends"]["requests"].get<long>(), 0) << last.dump();
  EXPECT_GT(last["resends"]["repeated_messages"].get<long>(), 0) << last.dump();
  // Every process's counts, from its heartbeat: injected drops are not rejections.
  for (const char* who : {"coordinator", "fluid", "particles"}) {
    ASSERT_TRUE(last["processes"].contains(who)) << who;
    EXPECT_TRUE(last["processes"][who]["counts_known"].get<bool>()) << who;
    EXPECT_GT(last["processes"][who]["accepted"].get<long>(), 0) << who;
    EXPECT_EQ(last["processes"][who]["rejected_total"].get<long>(), 0) << who;
  }
  EXPECT_EQ(last["monitor"]["rejected_total"].get<long>(), 0);
  EXPECT_NE(ran.output.find("interrupted"), std::string::npos) << ran.output;
}

// The live page in Debian's chromium, headless: its script fetched the monitor's rows and drew
// every plot with them, during the run and, once it has ended, up to its very last step.
// A partitioned run (2 x 2) has no whole-mesh FLUID_STATE or PARTICLE_FEEDBACK: a monitor started
// while it runs asks for the nodes' hellos, learns their rank counts, listens to the pairs'
// channels (FLUID_STATE.<f>.<p>, PARTICLE_FEEDBACK.<f>.<p>) and shows their latency in their
// direction's, and the ranks' own reports with their bytes, resends apart.
TEST(Monitor, APartitionedRunsPairsHaveTheirDirectionsLatency) {
  LiveRun r("monitor-pairs", 5000, "", " --np-fluid 2 --np-particles 2");
  const auto mon = run("(" + bin("hemocosim") + " monitor " + r.dir + " --json --interval 0.5 --duration 6 2> " +
                       r.dir + "-monitor.err)");
  r.interrupt();
  r.result.get();
  ASSERT_EQ(mon.exit_code, 0) << mon.output;
  std::vector<json> rows;
  ASSERT_NO_THROW(rows = json_lines(mon.output)) << mon.output;
  std::map<std::string, long> latencies;
  std::set<std::string> pairs;
  bool rank_bytes = false;
  for (const auto& row : rows) {
    for (const auto& [channel, l] : row["latency_ms"].items()) latencies[channel] += l["n"].get<long>();
    for (const auto& [channel, c] : row["channels"].items())
      if (std::count(channel.begin(), channel.end(), '.') == 2) pairs.insert(channel);
    if (row["diagnostics"].contains("particles")) {
      const auto& v = row["diagnostics"]["particles"]["values"];
      rank_bytes |= v.contains("rank1_sent_B") && v.contains("rank1_resent_B") && v.contains("rank1_halo_B");
    }
  }
  EXPECT_GT(latencies["FLUID_STATE"], 0);
  EXPECT_GT(latencies["PARTICLE_FEEDBACK"], 0);
  for (const char* pair : {"FLUID_STATE.0.0", "FLUID_STATE.1.1", "PARTICLE_FEEDBACK.0.1", "PARTICLE_FEEDBACK.1.0"})
    EXPECT_TRUE(pairs.count(pair)) << pair;
  EXPECT_TRUE(rank_bytes);
}

TEST(Monitor, LivePageDrawsTheRunInAHeadlessBrowser) {
  if (chromium().empty()) GTEST_SKIP() << "chromium is not installed (deploy/install-deps.sh installs it)";
  LiveRun r("monitor-page", 100000);
  ASSERT_TRUE(std::filesystem::exists(r.dir + "/metrics.csv"));
  Background mon(bin("hemocosim") + " monitor " + r.dir + " --json --interval 0.5 --http 0", r.dir + "-monitor");
  ASSERT_GT(mon.pid, 0);
  std::string url;
  for (int i = 0; i < 200 && url.empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::smatch m;
    const auto err = file_text(mon.err);
    if (std::regex_search(err, m, std::regex("live page at (http://127\\.0\\.0\\.1:[0-9]+/)"))) url = m[1];
  }
  ASSERT_FALSE(url.empty()) << file_text(mon.err);
  // Some intervals with steps in them first.
  long seen_step = -1;
  for (int i = 0; i < 600 && (json_lines(file_text(mon.out)).size() < 8 || seen_step <= 0); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto rows = json_lines(file_text(mon.out));
    if (!rows.empty()) seen_step = rows.back()["completed_step"];
  }
  ASSERT_GT(seen_step, 0);

  const std::string profile = r.dir + "-chromium";
  const auto live = run(chromium_command(profile, "--dump-dom", url) + " 2>/dev/null");
  ASSERT_EQ(live.exit_code, 0) << live.output;
  const std::string shot = r.dir + "-monitor.png";
  const auto png = run(chromium_command(profile, "--screenshot=" + shot, url));
  EXPECT_EQ(png.exit_code, 0) << png.output;
  r.interrupt();
  const auto ran = r.result.get();
  EXPECT_NE(ran.output.find("interrupted"), std::string::npos) << ran.output;
  const long final_step = last_common_step(read_metrics(r.dir));

  const long points = attribute(live.output, "<body[^>]* data-points=\"([0-9]+)\"");
  const long step = attribute(live.output, "<body[^>]* data-last-step=\"(-?[0-9]+)\"");
  EXPECT_GE(points, 8) << live.output;
  EXPECT_GE(step, seen_step) << live.output;
  EXPECT_LE(step, final_step) << live.output;
  // Every plot drew points, the run's physical diagnostics among them.
  EXPECT_EQ(attribute(live.output, "<body[^>]* data-plots-with-data=\"([0-9]+)\""), 12) << live.output;
  for (const char* plot : {"latency", "compute", "rate", "bytes", "rank_bytes", "rejections", "resends", "courant",
                           "overlap", "velocity", "momentum", "balance"})
    EXPECT_GT(attribute(live.output, std::string("id=\"plot-") + plot + "\" data-points=\"([0-9]+)\""), 0) << plot;
  // The screenshot is a picture (docs/figures/monitor.png is one of these).
  ASSERT_TRUE(std::filesystem::exists(shot)) << png.output;
  EXPECT_GT(std::filesystem::file_size(shot), 20000u);
  EXPECT_EQ(file_text(shot).substr(1, 3), "PNG");
  std::printf("monitor page screenshot: %s\n", shot.c_str());

  // The run has ended; the monitor, still serving, has it to the last step.
  const auto rows_at_end = json_lines(file_text(mon.out)).size();
  for (int i = 0; i < 50 && json_lines(file_text(mon.out)).size() < rows_at_end + 2; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const auto after = run(chromium_command(profile, "--dump-dom", url) + " 2>/dev/null");
  mon.signal(SIGINT);
  EXPECT_EQ(mon.done.get().exit_code, 0) << file_text(mon.err);
  EXPECT_EQ(attribute(after.output, "<body[^>]* data-last-step=\"(-?[0-9]+)\""), final_step) << after.output;
  EXPECT_GT(attribute(after.output, "<body[^>]* data-points=\"([0-9]+)\""), points);
}

// lcm-logger records a run's traffic (Debian's liblcm-bin): authentic messages on the run's
// channels. Played back with lcm-logplayer at a monitor of the same run, every one is refused as
// sent before the monitor listened: a recording is not live traffic.
TEST(Monitor, LcmLoggerRecordsARunAndAPlayedBackRecordingIsRefused) {
  const std::string dir = fresh_run_dir("logged");
  std::ofstream(dir + ".toml") << small_scene_text(30);
  // The run's bus is known once run.toml exists: the logger starts then, the nodes a moment later.
  auto ran =
      std::async(std::launch::async, [&] { return run(bin("hemocosim") + " run " + dir + ".toml --out " + dir); });
  for (int i = 0; i < 600 && !std::filesystem::exists(dir + "/run.toml"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(std::filesystem::exists(dir + "/run.toml"));
  std::string url, run_id;
  {
    std::smatch m;
    const auto info = file_text(dir + "/run.toml");
    ASSERT_TRUE(std::regex_search(info, m, std::regex("lcm_url = ['\"]([^'\"]+)['\"]"))) << info;
    url = m[1];
    ASSERT_TRUE(std::regex_search(info, m, std::regex("run_id = ['\"]([^'\"]+)['\"]"))) << info;
    run_id = m[1];
  }
  const std::string log = dir + "-traffic.lcmlog";
  Background logger("lcm-logger --lcm-url='" + url + "' --channel='" + run_id + "/.*' --force " + log, dir + "-logger");
  const auto r = ran.get();
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  logger.signal(SIGINT);
  logger.done.get();

  hemo::RunContext ctx;
  ctx.secret_file = dir + "/secret";
  ctx.load_secret();
  std::map<std::string, long> per_channel;
  long authentic = 0, events = 0;
  {
    lcm::LogFile file(log, "r");
    ASSERT_TRUE(file.good()) << file_text(logger.err);
    for (const lcm::LogEvent* e = file.readNextEvent(); e; e = file.readNextEvent()) {
      ++events;
      ++per_channel[e->channel];
      if (hemo::verify(static_cast<const std::uint8_t*>(e->data), static_cast<std::size_t>(e->datalen), ctx.secret))
        ++authentic;
    }
  }
  for (const char* kind : {"HELLO", "MESH", "STEP", "FLUID_STATE", "PARTICLE_FEEDBACK", "STEP_DONE", "HEARTBEAT"})
    EXPECT_GT(per_channel[run_id + "/" + kind], 0) << kind;
  EXPECT_GE(per_channel[run_id + "/STEP"], 31);  // start-up and 30 steps, and the stop
  EXPECT_EQ(authentic, events);

  // Played back (fast) at a monitor of the run: nothing accepted, everything refused as pre-start.
  // A listener allows 1 s of clock skew between hosts (kClockSkewAllowanceUs): a recording
  // younger than that when it starts would pass; this one is older.
  std::this_thread::sleep_for(std::chrono::microseconds(hemo::kClockSkewAllowanceUs + 1'000'000));
  Background monitor(bin("hemocosim") + " monitor " + dir + " --json --interval 0.5", dir + "-replay");
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const auto played = run("lcm-logplayer --speed=10 --lcm-url='" + url + "' " + log);
  EXPECT_EQ(played.exit_code, 0) << played.output;
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // two more intervals
  monitor.signal(SIGINT);
  EXPECT_EQ(monitor.done.get().exit_code, 0) << file_text(monitor.err);
  const auto rows = json_lines(file_text(monitor.out));
  ASSERT_FALSE(rows.empty());
  const auto& own = rows.back()["monitor"];
  EXPECT_EQ(own["accepted"].get<long>(), 0) << own.dump();
  EXPECT_GT(own["rejected"]["prestart"].get<long>(), events / 2) << own.dump();
  EXPECT_EQ(own["rejected"]["auth"].get<long>(), 0) << own.dump();
  EXPECT_TRUE(rows.back()["channels"].empty()) << rows.back().dump();
}
