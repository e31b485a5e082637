// The codec of the partitioned exchange (model/cell_partition.h): every fluid rank's cells sliced
// out of its own arrays in its own (scrambled) local order, for every particle rank by the
// overlap map, and assembled on the particle rank into whole-mesh arrays, must give each particle
// rank every cell it needs with its own values, and nothing else; the check of the cell ids
// names a dropped, repeated, misplaced or foreign cell.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <cell_partition.h>
#include <overlap_map.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

using hemo::assemble_cells;
using hemo::cell_list_problem;
using hemo::slice_cells;
using hemo::particles::Vec3;

namespace {

constexpr double kH = 1e-5;

// 2 x 2 x nz cubes of edge kH, cell (i, j, k) = i + 2 (j + 2 k), periodic along z.
hemo::CellPoints column(int nz) {
  hemo::CellPoints m;
  auto point = [](int i, int j, int k) { return i + 3 * (j + 3 * k); };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= 2; ++j)
      for (int i = 0; i <= 2; ++i) m.points.emplace_back(i * kH, j * kH, k * kH);
  m.cells.resize(static_cast<std::size_t>(4 * nz));
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i)
        for (int c = 0; c < 8; ++c)
          m.cells[static_cast<std::size_t>(i + 2 * (j + 2 * k))].push_back(
              point(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2)));
  return m;
}

// A value no two (cell, component) pairs share.
double value_of(int cell, int component) { return 1000.0 * cell + component + 0.25; }

struct Case {
  static constexpr int kPerCell = 9;  // a tensor field: misplacing a component shows too
  int nz = 16;
  hemo::CellPoints mesh = column(nz);
  hemo::FluidDecomposition fluid;
  hemo::ParticleDecomposition particles;
  hemo::OverlapMap map;
  // Per fluid rank: its cells in its local order (a scramble of the global one, as decomposePar's
  // cellProcAddressing may be), and its own array of values in that order.
  std::vector<std::vector<int>> local_cells;
  std::vector<std::vector<double>> local_values;

  Case() {
    const int n = 4 * nz;
    // Fluid ranks: interleaved blocks of 3 layers, so that every particle rank needs several.
    fluid.ranks = 3;
    for (int c = 0; c < n; ++c) fluid.owner.push_back((c / 4 / 3) % fluid.ranks);
    particles.margin = 0.4 * kH;
    for (int p = 0; p < 4; ++p)
      particles.boxes.push_back({Vec3(0, 0, p * nz * kH / 4), Vec3(2 * kH, 2 * kH, (p + 1) * nz * kH / 4)});
    map = hemo::overlap_map(mesh, fluid, particles, hemo::AxialPeriod{0, nz * kH});
    local_cells.resize(3);
    for (int c = 0; c < n; ++c) local_cells[static_cast<std::size_t>(fluid.owner[c])].push_back(c);
    for (auto& cells : local_cells) {
      std::reverse(cells.begin(), cells.end());
      std::rotate(cells.begin(), cells.begin() + 1, cells.end());
      std::vector<double> values;
      for (int c : cells)
        for (int k = 0; k < kPerCell; ++k) values.push_back(value_of(c, k));
      local_values.push_back(values);
    }
  }
  // The local indices of `cells` on fluid rank f.
  std::vector<int> local_index(int f, const std::vector<int>& cells) const {
    const auto& mine = local_cells[static_cast<std::size_t>(f)];
    std::vector<int> out;
    for (int c : cells) out.push_back(static_cast<int>(std::find(mine.begin(), mine.end(), c) - mine.begin()));
    return out;
  }
};

}  // namespace

TEST(CellPartition, EveryParticleRankAssemblesExactlyTheCellsItNeedsWithTheirOwnValues) {
  const Case k;
  const double unset = std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = k.mesh.cells.size();
  int ranks_taking_from_two = 0;
  for (int p = 0; p < 4; ++p) {
    std::vector<double> whole(Case::kPerCell * n, unset);
    ranks_taking_from_two += k.map.from[p].size() >= 2;
    for (const auto& [f, cells] : k.map.from[p]) {
      const auto values = slice_cells(k.local_values[static_cast<std::size_t>(f)], Case::kPerCell, k.local_index(f, cells));
      ASSERT_EQ(values.size(), Case::kPerCell * cells.size());
      EXPECT_EQ(cell_list_problem(cells, cells), "");
      assemble_cells(cells, values, Case::kPerCell, whole);
    }
    const auto needed = k.map.needed(p);
    ASSERT_FALSE(needed.empty());
    ASSERT_LT(needed.size(), n) << "the case must leave some cells out of particle rank " << p;
    for (std::size_t c = 0; c < n; ++c) {
      const bool want = std::binary_search(needed.begin(), needed.end(), static_cast<int>(c));
      for (int j = 0; j < Case::kPerCell; ++j) {
        const double got = whole[Case::kPerCell * c + j];
        if (want)
          EXPECT_EQ(got, value_of(static_cast<int>(c), j)) << "particle rank " << p << ", cell " << c << "[" << j << "]";
        else
          EXPECT_TRUE(std::isnan(got)) << "particle rank " << p << " got cell " << c << ", which it does not need";
      }
    }
  }
  EXPECT_GT(ranks_taking_from_two, 0) << "the case must make some particle rank take from two fluid ranks";
}

TEST(CellPartition, TheCellCheckNamesADroppedRepeatedMisplacedOrForeignCell) {
  const std::vector<int> want{3, 4, 9, 10, 11};
  EXPECT_EQ(cell_list_problem(want, want), "");
  EXPECT_EQ(cell_list_problem({}, {}), "");
  EXPECT_EQ(cell_list_problem({3, 4, 10, 11}, want), "cell 9 is missing");
  EXPECT_EQ(cell_list_problem({3, 4}, want), "cell 9 is missing (and 2 more)");
  EXPECT_EQ(cell_list_problem({}, want), "cell 3 is missing (and 4 more)");
  EXPECT_EQ(cell_list_problem({3, 4, 4, 9, 10, 11}, want), "cell 4 received twice");
  EXPECT_EQ(cell_list_problem({3, 9, 4, 10, 11}, want), "cell 4 received after cell 9 (the cells must be ascending)");
  EXPECT_EQ(cell_list_problem({3, 4, 5, 9, 10, 11}, want), "cell 5 was not expected");
  EXPECT_EQ(cell_list_problem({3, 4, 9, 10, 11, 12}, want), "cell 12 was not expected");
  EXPECT_EQ(cell_list_problem({2, 3, 4, 9, 10}, want), "cell 2 was not expected");
  // A cell swapped for another: the foreign one is named, whatever else is missing.
  EXPECT_EQ(cell_list_problem({3, 4, 8, 10, 11}, want), "cell 8 was not expected");
}

TEST(CellPartition, ValuesThatDoNotFitTheirCellsOrTheMeshAreRefusedWithOneLine) {
  std::vector<double> whole(3 * 4, 0.0);
  try {
    assemble_cells({0, 1}, {1, 2, 3, 4, 5}, 3, whole);
    FAIL() << "5 values for 2 cells of 3 taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "5 values for 2 cells of 3 values each");
  }
  try {
    assemble_cells({4}, {1, 2, 3}, 3, whole);
    FAIL() << "cell 4 of a 4-cell mesh taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "cell 4 is outside the mesh of 4 cells");
  }
  try {
    slice_cells({1, 2, 3, 4, 5, 6}, 3, {0, 2});
    FAIL() << "local cell 2 of 2 sliced";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "local cell 2 is outside the rank's 2 cells");
  }
  EXPECT_EQ(whole, std::vector<double>(12, 0.0)) << "a refused assembly must not have written";
}

// The feedback's partials: each adds to what the cells hold, the other cells untouched; a refused
// one adds nothing.
TEST(CellPartition, AddedValuesSumWithWhatTheCellsHold) {
  std::vector<double> whole = {1, 1, 1, 1};
  hemo::add_cells({1, 3}, {0.5, 2}, 1, whole);
  hemo::add_cells({3}, {4}, 1, whole);
  EXPECT_EQ(whole, (std::vector<double>{1, 1.5, 1, 7}));
  EXPECT_THROW(hemo::add_cells({0, 4}, {1, 1}, 1, whole), std::invalid_argument);
  EXPECT_EQ(whole, (std::vector<double>{1, 1.5, 1, 7})) << "a refused sum must not have written";
}
