// The partitioned exchange's point (docs/scale-out.md §4, docs/notes/partitioned-exchange.md item
// 10): the bytes any one rank sends and receives a step scale with its own cells, not with the
// whole mesh. A vessel of 10^5 cells (the small scene's cross-section, 48 cells a layer, made
// 2,084 layers of 10 um long, 20.8 mm: a rank's sub-domain on 4 ranks is 521 layers against a
// margin and halo of one or two), few particles, a few steps, on 1 x 1, 2 x 2 and 4 x 4 ranks
// (oversubscribed on this machine). The largest per-rank volume, sent plus received, must fall
// about as 1/P: the gather and broadcast it replaces kept a whole state (144 B a cell) on the
// master or a particle rank whatever P was.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

using namespace hemo::test;

namespace {

constexpr long kSteps = 5;

std::string long_vessel_text() {
  std::string text = small_scene_text(kSteps);
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"length_um = 60", "length_um = 20840"},
                                 {"core_cells = 2", "core_cells = 4"},
                                 {"axial_cells = 6", "axial_cells = 2084"},
                                 {"hematocrit = 0.08", "hematocrit = 0.002"},
                                 {"number_density_per_ul = 300000", "number_density_per_ul = 0"}}) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("coupled_small.toml lost its " + from);
    text.replace(at, from.size(), to);
  }
  return text;
}

struct Largest {
  double bytes = 0;  // sent + received a step, the mean over the steps after the first
  std::string who;
};

// The rank of either node that moves the most a step. The first step is left out: its report
// also holds the start-up (the MESH, the step-0 state and feedback).
Largest largest_rank(const Metrics& m, int ranks) {
  Largest out;
  for (const char* node : {"fluid", "particles"})
    for (int r = 0; r < ranks; ++r) {
      const std::string rank = "rank" + std::to_string(r);
      const auto sent = over_steps(m, node, rank + "_sent_B"), received = over_steps(m, node, rank + "_received_B");
      EXPECT_EQ(sent.size(), static_cast<std::size_t>(kSteps)) << node << " " << rank;
      EXPECT_EQ(received.size(), sent.size()) << node << " " << rank;
      if (sent.size() < 2 || received.size() != sent.size()) continue;
      const double bytes = (std::accumulate(sent.begin() + 1, sent.end(), 0.0) +
                            std::accumulate(received.begin() + 1, received.end(), 0.0)) /
                           static_cast<double>(sent.size() - 1);
      if (bytes > out.bytes) out = {bytes, std::string(node) + " " + rank};
    }
  return out;
}

Largest run_ranks(int p) {
  const std::string dir = fresh_run_dir("scaling-" + std::to_string(p) + "x" + std::to_string(p));
  std::ofstream(dir + ".toml") << long_vessel_text();
  const std::string ranks = p > 1 ? " --np-fluid " + std::to_string(p) + " --np-particles " + std::to_string(p) : "";
  const auto result = run(bin("hemocosim") + " run " + dir + ".toml --out " + dir + ranks);
  EXPECT_EQ(result.exit_code, 0) << result.output;
  const Largest l = largest_rank(read_metrics(dir), p);
  std::printf("[ info ] %d x %d ranks: the largest per-rank volume is %s's, %.0f B a step (%.0f s)\n", p, p,
              l.who.c_str(), l.bytes, result.seconds);
  return l;
}

}  // namespace

// Measured: see the info lines (docs/scale-out.md §4 has the figures). Bounds: 1/P with room for
// the margin's and halo's cells, the reports and the order: 2 x 2 below 0.65 and 4 x 4 below 0.4
// of 1 x 1. A rank that still received or sent the whole state (the broadcast, the gather) or the
// whole feedback (the all-reduce, the scatter) would hold 4 x 4 above 0.75.
TEST(PartitionedScaling, TheLargestPerRankBytesFallAsOneOverTheRanks) {
  const Largest one = run_ranks(1), two = run_ranks(2), four = run_ranks(4);
  ASSERT_GT(one.bytes, 1e5 * 144) << "1 x 1 does not move the whole state of 10^5 cells";
  std::printf("[ info ] largest per-rank volume against 1 x 1: 2 x 2 %.3f, 4 x 4 %.3f\n", two.bytes / one.bytes,
              four.bytes / one.bytes);
  EXPECT_LT(two.bytes, 0.65 * one.bytes);
  EXPECT_LT(four.bytes, 0.4 * one.bytes);
  EXPECT_LT(four.bytes, 0.65 * two.bytes);
}
