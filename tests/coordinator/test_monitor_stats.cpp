// The monitor's bookkeeping without a run (issue #23): latency per direction, compute and wait,
// rate and ETA, bytes/s, resends and rejection counts, as the JSON row and the table show them.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <cmath>
#include <regex>

#include "monitor_stats.h"

using namespace hemo;
using nlohmann::json;

namespace {
constexpr std::int64_t kT0ns = 1'700'000'000'000'000'000;  // a wall-clock instant, ns

// A message sent at kT0ns + sent_us and received latency_us later.
void send(MonitorStats& s, const std::string& kind, const std::string& sender, std::int64_t step, double now_s,
          std::int64_t latency_us, std::size_t bytes = 100) {
  const std::int64_t sent = kT0ns + static_cast<std::int64_t>(now_s * 1e9);
  s.message(kind, sender, step, bytes, sent, sent / 1000 + latency_us, now_s);
}

void done(MonitorStats& s, const std::string& node, std::int64_t step, double compute, double wait,
          std::vector<std::string> names = {}, std::vector<double> values = {}) {
  s.step_done(node, step, true, "", compute, wait, names, values);
}
}  // namespace

TEST(MonitorStats, LatencyIsKeptPerDirectionAndEmptiedEachInterval) {
  MonitorStats s("run1");
  s.close_interval(0, 0);
  send(s, "FLUID_STATE", "fluid", 1, 0.1, 250);
  send(s, "FLUID_STATE", "fluid", 2, 0.2, 750);
  send(s, "PARTICLE_FEEDBACK", "particles", 1, 0.3, 100);
  send(s, "STEP", "coordinator", 2, 0.4, -40);  // another host's clock, behind: shown as it is
  const auto row = s.close_interval(1, 1);
  const auto& l = row["latency_ms"];
  EXPECT_EQ(l["FLUID_STATE"]["n"], 2);
  EXPECT_NEAR(l["FLUID_STATE"]["mean"].get<double>(), 0.5, 1e-6);
  EXPECT_NEAR(l["FLUID_STATE"]["max"].get<double>(), 0.75, 1e-6);
  EXPECT_NEAR(l["FLUID_STATE"]["last"].get<double>(), 0.75, 1e-6);
  EXPECT_EQ(l["FLUID_STATE"]["from_to"], "fluid -> particles");
  EXPECT_NEAR(l["PARTICLE_FEEDBACK"]["mean"].get<double>(), 0.1, 1e-6);
  EXPECT_NEAR(l["STEP"]["mean"].get<double>(), -0.04, 1e-6);
  EXPECT_EQ(l["STEP_DONE"]["n"], 0);
  EXPECT_TRUE(l["STEP_DONE"]["mean"].is_null());
  // Heartbeats carry no latency figure of their own: only the four exchanges are kept.
  EXPECT_EQ(l.size(), 4u);

  const auto next = s.close_interval(2, 2);
  EXPECT_EQ(next["latency_ms"]["FLUID_STATE"]["n"], 0);
  EXPECT_TRUE(next["latency_ms"]["FLUID_STATE"]["mean"].is_null());
}

// The partitioned exchange's pairs (FLUID_STATE.<f>.<p>, PARTICLE_FEEDBACK.<f>.<p>) are their
// direction's: their latency is kept with it, and a pair's message seen twice was resent.
TEST(MonitorStats, APairsChannelCountsInItsDirectionsLatency) {
  MonitorStats s("run1");
  s.close_interval(0, 0);
  send(s, "FLUID_STATE.0.1", "fluid", 1, 0.1, 200);
  send(s, "FLUID_STATE.1.0", "fluid.1", 1, 0.2, 400);
  send(s, "PARTICLE_FEEDBACK.1.1", "particles.1", 1, 0.3, 300);
  send(s, "PARTICLE_FEEDBACK.1.1", "particles.1", 1, 0.4, 300);  // again
  const auto row = s.close_interval(1, 1);
  const auto& l = row["latency_ms"];
  EXPECT_EQ(l.size(), 4u);
  EXPECT_EQ(l["FLUID_STATE"]["n"], 2);
  EXPECT_NEAR(l["FLUID_STATE"]["mean"].get<double>(), 0.3, 1e-6);
  EXPECT_NEAR(l["FLUID_STATE"]["max"].get<double>(), 0.4, 1e-6);
  EXPECT_EQ(l["PARTICLE_FEEDBACK"]["n"], 2);
  EXPECT_EQ(row["channels"]["FLUID_STATE.1.0"]["msgs"], 1);  // the bytes stay per channel
  EXPECT_EQ(row["resends"]["repeated_messages"], 1);
}

TEST(MonitorStats, AMessageWithoutASendStampHasNoLatency) {
  MonitorStats s("run1");
  s.message("STEP", "coordinator", 1, 10, 0, 123456, 0.5);
  const auto row = s.close_interval(1, 1);
  EXPECT_EQ(row["latency_ms"]["STEP"]["n"], 0);
  EXPECT_EQ(row["channels"]["STEP"]["msgs"], 1);
}

TEST(MonitorStats, ACouplingStepIsDoneWhenBothNodesReportedIt) {
  MonitorStats s("run1", 100);
  EXPECT_EQ(s.completed_step(), -1);
  done(s, "fluid", 3, 0.2, 0.1);
  EXPECT_EQ(s.completed_step(), -1);  // the particles have said nothing yet
  done(s, "particles", 2, 0.4, 0.05);
  EXPECT_EQ(s.completed_step(), 2);
  done(s, "particles", 3, 0.6, 0.15);
  EXPECT_EQ(s.completed_step(), 3);
  done(s, "particles", 3, 9.0, 9.0);  // a resent report: not a step of its own
  const auto row = s.close_interval(1, 1);
  EXPECT_EQ(row["completed_step"], 3);
  EXPECT_EQ(row["nodes"]["particles"]["reports"], 2);
  EXPECT_NEAR(row["nodes"]["particles"]["compute_s"].get<double>(), 0.5, 1e-12);
  EXPECT_NEAR(row["nodes"]["particles"]["wait_s"].get<double>(), 0.1, 1e-12);
  EXPECT_NEAR(row["nodes"]["particles"]["last_compute_s"].get<double>(), 0.6, 1e-12);
  EXPECT_NEAR(row["nodes"]["fluid"]["compute_s"].get<double>(), 0.2, 1e-12);
  // No report in the next interval: no mean, but the last step's figures stay.
  const auto quiet = s.close_interval(2, 2);
  EXPECT_TRUE(quiet["nodes"]["fluid"]["compute_s"].is_null());
  EXPECT_NEAR(quiet["nodes"]["fluid"]["last_compute_s"].get<double>(), 0.2, 1e-12);
}

TEST(MonitorStats, DiagnosticsAreTheLatestStepsAndAFailureIsShown) {
  MonitorStats s("run1");
  done(s, "fluid", 1, 0.1, 0, {"courant_max", "momentum_budget_residual_z_N"}, {0.3, 1e-12});
  done(s, "fluid", 2, 0.1, 0, {"courant_max", "bad"}, {0.4, std::nan("")});
  s.step_done("particles", 2, false, "a particle left the mesh", 0.1, 0, {}, {});
  const auto row = s.close_interval(1, 1);
  const auto& d = row["diagnostics"]["fluid"];
  EXPECT_EQ(d["step"], 2);
  EXPECT_DOUBLE_EQ(d["values"]["courant_max"].get<double>(), 0.4);
  EXPECT_FALSE(d["values"].contains("momentum_budget_residual_z_N"));  // not sent with step 2
  EXPECT_TRUE(d["values"]["bad"].is_null());                           // NaN is no JSON number
  EXPECT_EQ(row["nodes"]["particles"]["ok"], false);
  EXPECT_EQ(row["nodes"]["particles"]["error"], "a particle left the mesh");
  EXPECT_NE(format_monitor_table(row, "udpm://x").find("particles reported: a particle left the mesh"),
            std::string::npos);
}

// A node's rank >= 1 reports on its own channel: its timings and bytes are shown with the node's
// diagnostics, the latest of each rank, a resend of an older step changing nothing.
TEST(MonitorStats, ARanksOwnReportIsShownWithItsNodesDiagnostics) {
  MonitorStats s("run1");
  done(s, "particles", 3, 0.1, 0, {"rank0_sent_B"}, {500});
  s.rank_done("particles", 1, 3, 0.2, 0.05, {"rank1_sent_B"}, {700});
  s.rank_done("particles", 1, 2, 9.0, 9.0, {"rank1_sent_B"}, {1});  // a resend of step 2
  const auto row = s.close_interval(1, 1);
  const auto& v = row["diagnostics"]["particles"]["values"];
  EXPECT_DOUBLE_EQ(v["rank0_sent_B"].get<double>(), 500);
  EXPECT_DOUBLE_EQ(v["rank1_sent_B"].get<double>(), 700);
  EXPECT_DOUBLE_EQ(v["rank1_compute_s"].get<double>(), 0.2);
  EXPECT_DOUBLE_EQ(v["rank1_wait_s"].get<double>(), 0.05);
}

TEST(MonitorStats, RateAndEtaOverTheWindow) {
  std::deque<std::pair<double, std::int64_t>> h;
  EXPECT_FALSE(rate_and_eta(h, 10, 100).steps_per_s);
  h = {{0, 10}};
  EXPECT_FALSE(rate_and_eta(h, 10, 100).steps_per_s);  // one sample is no rate
  h = {{0, 10}, {1, 14}, {2, 20}};
  auto r = rate_and_eta(h, 10, 100);
  ASSERT_TRUE(r.steps_per_s && r.eta_s);
  EXPECT_DOUBLE_EQ(*r.steps_per_s, 5.0);  // (20 - 10) / 2
  EXPECT_DOUBLE_EQ(*r.eta_s, 16.0);       // 80 steps left
  // Only the window counts: a fast start long ago does not hide today's pace.
  h = {{0, 0}, {100, 900}, {105, 910}, {110, 920}};
  r = rate_and_eta(h, 10, 1000);
  EXPECT_DOUBLE_EQ(*r.steps_per_s, 2.0);
  EXPECT_DOUBLE_EQ(*r.eta_s, 40.0);
  // Samples further apart than the window: the last two.
  h = {{0, 0}, {50, 100}, {100, 150}};
  EXPECT_DOUBLE_EQ(*rate_and_eta(h, 10, 1000).steps_per_s, 1.0);
  // A stalled run: rate 0, no ETA; a finished one: ETA 0; no total: no ETA.
  h = {{0, 5}, {5, 5}};
  r = rate_and_eta(h, 10, 100);
  EXPECT_DOUBLE_EQ(*r.steps_per_s, 0.0);
  EXPECT_FALSE(r.eta_s);
  h = {{0, 90}, {1, 100}};
  EXPECT_DOUBLE_EQ(*rate_and_eta(h, 10, 100).eta_s, 0.0);
  EXPECT_FALSE(rate_and_eta(h, 10, 0).eta_s);
}

TEST(MonitorStats, RowsCarryRateAndEtaFromTheStepsSeen) {
  MonitorStats s("run1", 50, 10);
  s.close_interval(0, 0);
  for (int k = 1; k <= 10; ++k) done(s, "fluid", k, 0, 0), done(s, "particles", k, 0, 0);
  auto row = s.close_interval(1, 1);
  EXPECT_TRUE(row["steps_per_s"].is_null());  // the monitor saw no step at the interval's start
  EXPECT_TRUE(row["eta_s"].is_null());
  for (int k = 11; k <= 30; ++k) done(s, "fluid", k, 0, 0), done(s, "particles", k, 0, 0);
  row = s.close_interval(3, 3);
  EXPECT_DOUBLE_EQ(row["steps_per_s"].get<double>(), 10.0);  // 20 steps in 2 s
  EXPECT_DOUBLE_EQ(row["steps_per_s_smoothed"].get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(row["eta_s"].get<double>(), 2.0);  // 20 of 50 left
  EXPECT_EQ(row["total_steps"], 50);
}

TEST(MonitorStats, BytesPerSecondResendsAndRejections) {
  MonitorStats s("run1");
  s.close_interval(0, 0);
  send(s, "FLUID_STATE", "fluid", 1, 0.1, 10, 3000);
  send(s, "FLUID_STATE", "fluid", 2, 0.2, 10, 3000);
  send(s, "RESEND", "particles", 2, 0.3, 10, 50);
  send(s, "FLUID_STATE", "fluid", 2, 0.4, 10, 3000);  // the answer: step 2 again
  send(s, "HEARTBEAT", "fluid", -1, 0.5, 10, 80);
  send(s, "HEARTBEAT", "fluid", -1, 1.0, 10, 80);  // heartbeats repeat step -1 by nature
  ProcessCounts c;
  c.accepted = 40, c.rejected_auth = 3, c.rejected_replay = 2;
  s.heartbeat("fluid", 7.5, c);
  ProcessCounts own;
  own.accepted = 9, own.rejected_short = 1;
  s.own_counts(own);
  const auto row = s.close_interval(2, 2);
  EXPECT_DOUBLE_EQ(row["channels"]["FLUID_STATE"]["bytes_per_s"].get<double>(), 4500.0);
  EXPECT_DOUBLE_EQ(row["channels"]["FLUID_STATE"]["msgs_per_s"].get<double>(), 1.5);
  EXPECT_EQ(row["channels"]["FLUID_STATE"]["last_step"], 2);
  EXPECT_EQ(row["resends"]["requests"], 1);
  EXPECT_EQ(row["resends"]["repeated_messages"], 1);
  const auto& f = row["processes"]["fluid"];
  EXPECT_EQ(f["rejected"]["auth"], 3);
  EXPECT_EQ(f["rejected"]["replay"], 2);
  EXPECT_EQ(f["rejected_total"], 5);
  EXPECT_EQ(f["alive"], true);
  EXPECT_EQ(row["processes"]["particles"]["counts_known"], false);  // no heartbeat from it yet
  EXPECT_EQ(row["monitor"]["rejected_total"], 1);
  // Silent for longer than two heartbeats: no longer alive.
  EXPECT_EQ(s.close_interval(4, 4)["processes"]["fluid"]["alive"], false);

  // The table shows the same figures, each process's drops in the row format scripts read.
  const auto table = format_monitor_table(row, "udpm://239.255.1.1:7667?ttl=0");
  EXPECT_TRUE(std::regex_search(table, std::regex("\nfluid +40 +0 +0 +3 +0 +2 +0\n"))) << table;
  EXPECT_TRUE(std::regex_search(table, std::regex("\n\\(this monitor\\) +9 +1 +0 +0 +0 +0 +0\n"))) << table;
  EXPECT_TRUE(std::regex_search(table, std::regex("\nFLUID_STATE +3 +1.5 +4500 "))) << table;
  EXPECT_NE(table.find("resend requests seen 1"), std::string::npos) << table;
  EXPECT_NE(table.find("fluid alive"), std::string::npos) << table;
}

TEST(MonitorStats, EveryDocumentedKeyIsInTheRow) {
  MonitorStats s("run1", 10);
  const auto row = json::parse(s.close_interval(1, 1).dump());
  for (const char* key : {"schema", "run_id", "unix_time_s", "elapsed_s", "interval_s", "ordered_step",
                          "completed_step", "total_steps", "time_s", "steps_per_s", "steps_per_s_smoothed", "eta_s",
                          "latency_ms", "channels", "nodes", "diagnostics", "balance", "resends", "processes"})
    EXPECT_TRUE(row.contains(key)) << key;
  EXPECT_EQ(row["schema"], kMonitorSchema);
}

// The momentum balance: the fluid's wall shear stress, interval mean, against the imposed
// d dP / (4 l) of the calibration vessel (0.9588 Pa at 799 1/s), and the wall shear rate it makes.
TEST(MonitorStats, WallShearStressIsHeldAgainstTheImposedOne) {
  Scene scene;
  scene.vessel.diameter = 100e-6;
  scene.vessel.length = 600e-6;
  scene.plasma.viscosity = 1.2e-3;
  scene.driving.pressure_drop = 4 * 1.2e-3 * 600e-6 * 799 / 100e-6;
  scene.mesh.wall_polygon = WallPolygon::inscribed;  // the exact balance reaches cos(pi/16) of the imposed
  MonitorStats s("run1", 10);
  s.balance_reference(scene);
  s.close_interval(0, 0);
  const std::vector<std::string> names = {"courant_max", "wall_shear_stress_Pa"};
  done(s, "fluid", 1, 0.01, 0, names, {0.1, 0.84});
  done(s, "fluid", 2, 0.01, 0, names, {0.1, 0.85});
  done(s, "fluid", 2, 0.01, 0, names, {0.1, 5.0});                    // a resend: not counted again
  done(s, "particles", 2, 0.01, 0, {"wall_shear_stress_Pa"}, {9.0});  // not the fluid's
  const auto row = s.close_interval(1, 1);
  const auto& b = row["balance"];
  EXPECT_EQ(b["samples"], 2);
  EXPECT_NEAR(b["wall_shear_stress_Pa"].get<double>(), 0.845, 1e-12);
  EXPECT_NEAR(b["imposed_wall_shear_stress_Pa"].get<double>(), 1.2e-3 * 799, 1e-12);
  EXPECT_NEAR(b["ratio"].get<double>(), 0.845 / (1.2e-3 * 799), 1e-12);
  EXPECT_NEAR(b["wall_shear_rate_per_s"].get<double>(), 0.845 / 1.2e-3, 1e-9);
  EXPECT_NEAR(b["imposed_wall_shear_rate_per_s"].get<double>(), 799, 1e-9);
  EXPECT_NEAR(b["mesh_ratio"].get<double>(), std::cos(3.14159265358979323846 / 16), 1e-12);  // 4 core cells
  const auto table = format_monitor_table(row, "udpm://x");
  EXPECT_NE(table.find("momentum balance: wall shear stress 0.8450 Pa = 0.881 of the imposed 0.9588 Pa (0.981 on this "
                       "mesh); wall shear rate 704.2 of 799.0 1/s; 2 steps in this interval"),
            std::string::npos)
      << table;

  // An interval without a report keeps the latest value; a NaN report is left out.
  done(s, "fluid", 3, 0.01, 0, names, {0.1, std::nan("")});
  const auto quiet = s.close_interval(2, 2);
  EXPECT_EQ(quiet["balance"]["samples"], 0);
  EXPECT_NEAR(quiet["balance"]["wall_shear_stress_Pa"].get<double>(), 0.85, 1e-12);
}

TEST(MonitorStats, WithoutTheSceneTheBalanceShowsTheRealisedStressOnly) {
  MonitorStats s("run1");
  s.close_interval(0, 0);
  EXPECT_TRUE(s.close_interval(1, 1)["balance"]["wall_shear_stress_Pa"].is_null());
  EXPECT_EQ(format_monitor_table(s.close_interval(1.5, 1.5), "udpm://x").find("momentum balance"), std::string::npos);
  done(s, "fluid", 1, 0.01, 0, {"wall_shear_stress_Pa"}, {0.9});
  const auto row = s.close_interval(2, 2);
  EXPECT_NEAR(row["balance"]["wall_shear_stress_Pa"].get<double>(), 0.9, 1e-12);
  EXPECT_TRUE(row["balance"]["ratio"].is_null());
  EXPECT_TRUE(row["balance"]["wall_shear_rate_per_s"].is_null());
  EXPECT_NE(format_monitor_table(row, "udpm://x").find("wall shear stress 0.9000 Pa = - of the imposed - Pa"),
            std::string::npos);
}
