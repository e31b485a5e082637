// The partitioned exchange on real nodes over real LCM (docs/notes/partitioned-exchange.md): with
// two ranks each, every fluid rank publishes its own cells to the particle ranks that need them
// and every particle rank takes them itself. The run ends as the one-rank run does, to the
// round-off of the decomposed fluid's sums, and each rank's bytes say that no rank gathers,
// broadcasts or receives the whole state any more.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

using namespace hemo::test;

namespace {

// The small scene twice as long on cells half as long (24 layers of 5 um, 480 cells), so that
// a particle rank's half of the vessel, with its margin and halo, is not the whole mesh.
std::string long_scene_text(const std::string& run_keys = "") {
  std::string text = small_scene_text(12, run_keys);
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"length_um = 60", "length_um = 120"},
                                 {"axial_cells = 6", "axial_cells = 24"}}) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("coupled_small.toml lost its " + from);
    text.replace(at, from.size(), to);
  }
  return text;
}

struct RankedRun {
  std::string dir;
  Metrics metrics;
};

RankedRun run_long(const std::string& name, const std::string& ranks, const std::string& run_keys = "") {
  RankedRun r{fresh_run_dir(name), {}};
  std::ofstream(r.dir + ".toml") << long_scene_text(run_keys);
  const auto result = run(bin("hemocosim") + " run " + r.dir + ".toml --out " + r.dir + ranks);
  EXPECT_EQ(result.exit_code, 0) << result.output;
  r.metrics = read_metrics(r.dir);
  return r;
}

const RankedRun& one_by_one() {
  static const RankedRun r = run_long("partitioned-1x1", "");
  return r;
}
const RankedRun& two_by_two() {
  static const RankedRun r = run_long("partitioned-2x2", " --np-fluid 2 --np-particles 2");
  return r;
}

std::vector<double> over_steps(const RankedRun& r, const std::string& node, const std::string& name) {
  return hemo::test::over_steps(r.metrics, node, name);
}

double sum(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0); }

}  // namespace

// The decomposed fluid sums its cells in another order, nothing else differs: after 12 steps
// the particles are where the one-rank run has them to 1e-12 m (measured: 4e-14 m on the 40 um
// vessel) and move as fast to 1e-6 of the fastest (measured: 8e-8), and the plasma's mean
// velocity agrees to 1e-7 (measured: 1e-8). (The exchange itself adds nothing: the partitioned
// 2 x 2 run gave the gathered-and-broadcast 2 x 2 run's snapshots and diagnostics bit for bit.)
TEST(PartitionedRun, TwoRanksEachEndAsOneRankEachToRoundOff) {
  const RankedRun& a = one_by_one();
  const RankedRun& b = two_by_two();
  const auto names = snapshot_names(a.dir + "/particles.h5");
  ASSERT_EQ(names, snapshot_names(b.dir + "/particles.h5"));
  ASSERT_GE(names.size(), 2u);
  const auto sa = read_snapshot(a.dir + "/particles.h5", names.back());
  const auto sb = read_snapshot(b.dir + "/particles.h5", names.back());
  ASSERT_EQ(sa.id, sb.id);
  double fastest = 0, position = 0, velocity = 0;
  for (std::size_t i = 0; i < sa.position.size(); ++i) {
    fastest = std::max(fastest, std::abs(sa.velocity[i]));
    position = std::max(position, std::abs(sa.position[i] - sb.position[i]));
    velocity = std::max(velocity, std::abs(sa.velocity[i] - sb.velocity[i]));
  }
  std::printf("[ info ] 2 x 2 against 1 x 1 after %s: positions %.3g m, velocities %.3g of the fastest\n",
              names.back().c_str(), position, velocity / fastest);
  EXPECT_GT(position, 0) << "a decomposed fluid sums in another order: the runs cannot be the same run";
  EXPECT_LT(position, 1e-12);
  EXPECT_LT(velocity, 1e-6 * fastest);
  const auto ua = over_steps(a, "fluid", "mean_velocity_m_s"), ub = over_steps(b, "fluid", "mean_velocity_m_s");
  ASSERT_EQ(ua.size(), 12u);
  ASSERT_EQ(ub.size(), ua.size());
  for (std::size_t i = 0; i < ua.size(); ++i) EXPECT_NEAR(ub[i], ua[i], 1e-7 * std::abs(ua[i])) << "step " << i + 1;
}

// What each rank of the 2 x 2 run moves: every fluid rank sends its partitions and, but the
// master, its own step reports and heartbeats, nothing else (no gather to the master), every particle rank receives its own cells' state on its own
// channels, less than the whole state, and nothing of the state by MPI (no broadcast); the
// master no longer publishes the whole-mesh FLUID_STATE. Bytes per step, from profile.csv's
// source (metrics.csv).
TEST(PartitionedRun, NoRankGathersBroadcastsOrReceivesTheWholeState) {
  const RankedRun& a = one_by_one();
  const RankedRun& b = two_by_two();
  const auto state = over_steps(a, "fluid", "bus_sent_fluid_state_B");
  ASSERT_EQ(state.size(), 12u);
  const double whole = *std::min_element(state.begin(), state.end());  // a resend counts twice
  EXPECT_TRUE(over_steps(b, "fluid", "bus_sent_fluid_state_B").empty()) << "the master published the whole state";
  for (int r = 0; r < 2; ++r) {
    const std::string rank = "rank" + std::to_string(r);
    const auto sent = over_steps(b, "fluid", rank + "_sent_B"), partitions = over_steps(b, "fluid", rank + "_sent_fluid_state_B");
    ASSERT_EQ(sent.size(), 12u) << rank;
    ASSERT_EQ(partitions.size(), sent.size()) << rank;
    // Fluid rank 0 also holds the node's port: its reports and whatever it answers.
    if (r == 1) {
      const auto reports = over_steps(b, "fluid", "rank1_sent_report_B");
      ASSERT_EQ(reports.size(), sent.size());
      EXPECT_GT(sum(reports), 0);
      EXPECT_NEAR(sum(sent), sum(partitions) + sum(reports), 0.01 * sum(partitions))
          << "fluid rank 1 sent more than its partitions and its reports";
    }
    EXPECT_GT(*std::min_element(partitions.begin(), partitions.end()), 0) << "fluid " << rank;

    const auto received = over_steps(b, "particles", rank + "_received_B");
    const auto own = over_steps(b, "particles", rank + "_received_fluid_state_B");
    ASSERT_EQ(received.size(), 12u) << rank;
    ASSERT_EQ(own.size(), received.size()) << rank;
    const double least = *std::min_element(own.begin(), own.end());
    std::printf("[ info ] particle %s: %.0f B of fluid state a step (the whole state: %.0f B), %.0f B in all\n",
                rank.c_str(), least, whole, received.front());
    EXPECT_GT(least, 0) << "particle " << rank;
    EXPECT_LT(least, 0.9 * whole) << "particle " << rank << " received the whole state";
    // Everything else it receives (the order, the deposition's and the tracking's all-reduces)
    // weighs less than a state: no state comes by broadcast.
    for (std::size_t i = 0; i < received.size(); ++i)
      EXPECT_LT(received[i] - own[i], whole) << "particle " << rank << ", step " << i + 1;
  }
}

// Every rank of both nodes reports every step itself (common/rank_report.h), and the coordinator
// hears each report: metrics.csv has, for the start-up and each of the 12 steps, rank 1's
// timings and bytes under either node beside the node's own report (rank 0's), and no rank the
// nodes do not have. A rank's reports and heartbeats cost it well under 1 kB a step.
TEST(PartitionedRun, TheCoordinatorHeardEveryRanksReportOfEveryStep) {
  const RankedRun& b = two_by_two();
  for (const char* node : {"fluid", "particles"}) {
    auto steps_of = [&](const std::string& name) {
      std::vector<long> out;
      const auto it = b.metrics.find({node, name});
      if (it != b.metrics.end())
        for (const auto& [step, value] : it->second) out.push_back(step);
      return out;
    };
    const std::vector<long> own = steps_of("compute_s"), rank1 = steps_of("rank1_compute_s");
    for (const auto& [key, values] : b.metrics)
      EXPECT_FALSE(key.first == node && key.second.rfind("rank2_", 0) == 0) << node << " has no rank 2: " << key.second;
    std::vector<long> steps(13);
    std::iota(steps.begin(), steps.end(), 0L);
    EXPECT_EQ(own, steps) << node;
    EXPECT_EQ(rank1, steps) << node << "'s rank 1";
    for (const char* name : {"rank1_wait_s", "rank1_sent_B", "rank1_received_B", "rank0_sent_B"})
      EXPECT_EQ(over_steps(b, node, name).size(), 12u) << node << " " << name;
    const auto reports = over_steps(b, node, "rank1_sent_report_B");
    ASSERT_EQ(reports.size(), 12u) << node;
    std::printf("[ info ] %s rank 1: its reports and heartbeats %.0f B a step\n", node, sum(reports) / 12);
    EXPECT_LT(sum(reports) / 12, 1024) << node;
  }
}

// Every 7th message each bus receives dropped (run.drop_every): a particle rank's own bus hears
// its two partitions a step and nothing else, so at least 3 of its 24 are lost. It asks the
// fluid ranks that kept them again, which answer from their own
// threads while they wait in OpenFOAM's collectives, and the run ends bit for bit as without.
TEST(PartitionedRun, LostPartitionsAreAskedAgainAndLeaveTheResultUnchanged) {
  const RankedRun& clean = two_by_two();
  const RankedRun lossy = run_long("partitioned-2x2-lossy", " --np-fluid 2 --np-particles 2", "drop_every = 7\n");
  const auto names = snapshot_names(clean.dir + "/particles.h5");
  ASSERT_EQ(names, snapshot_names(lossy.dir + "/particles.h5"));
  for (const auto& name : names) {
    const auto a = read_snapshot(clean.dir + "/particles.h5", name), b = read_snapshot(lossy.dir + "/particles.h5", name);
    ASSERT_EQ(a.id, b.id) << name;
    EXPECT_EQ(a.position, b.position) << name;  // bit for bit
    EXPECT_EQ(a.velocity, b.velocity) << name;
  }
  EXPECT_EQ(over_steps(clean, "fluid", "mean_velocity_m_s"), over_steps(lossy, "fluid", "mean_velocity_m_s"));
}

// A particle rank takes its state after the order (RankedPort::advance), while the fluid solves:
// that wait is waiting, not the particle node's computing. In the serial scheme the fluid's
// compute (from its order to its state) and the particles' (from their state to their report)
// are disjoint parts of every step's wall time, so what the lockstep calls the coupling overhead,
// the wall time less both, is never negative (it was by about the fluid's solve when the wait
// counted as computing).
TEST(PartitionedRun, WaitingForTheStateIsNotComputing) {
  const RankedRun& b = two_by_two();
  const auto overhead = over_steps(b, "lockstep", "coupling_overhead_s");
  const auto fluid = over_steps(b, "fluid", "compute_s"), particles = over_steps(b, "particles", "compute_s");
  ASSERT_EQ(overhead.size(), 12u);
  for (std::size_t i = 0; i < overhead.size(); ++i) {
    std::printf("[ info ] step %zu: fluid %.2f ms, particles %.2f ms, overhead %.2f ms\n", i + 1, 1e3 * fluid[i],
                1e3 * particles[i], 1e3 * overhead[i]);
    EXPECT_GE(overhead[i], 0) << "step " << i + 1;
  }
}
