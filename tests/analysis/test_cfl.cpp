// Cell-free layer thickness: edge method on stations with a known outer edge, profile method on
// constructed fractions, and the default station count.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "observables.h"
#include "synthetic.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

using namespace hemo::analysis;
using namespace hemo::analysis::test;

namespace {
const Tube kTube{50 * kUm, 600 * kUm};
const double kD = 5.56 * kUm;

// One snapshot whose RBCs fill every station with `per_station` cells, all at r <= edge - d/2,
// one of them exactly there: each station's outer edge is `edge`. Stations listed in `skip`
// are left empty.
Snapshot station_filling(const Stations& st, double edge, int per_station, std::mt19937_64& rng,
                         const std::vector<int>& skip = {}) {
  std::uniform_real_distribution<double> u(0, 1);
  Snapshot s;
  long id = 0;
  for (int ia = 0; ia < st.axial; ++ia)
    for (int is = 0; is < st.sectors; ++is) {
      if (std::find(skip.begin(), skip.end(), ia * st.sectors + is) != skip.end()) continue;
      for (int k = 0; k < per_station; ++k) {
        const double r = (k == 0 ? 1.0 : u(rng)) * (edge - kD / 2);
        const double theta = -kPi + (is + 0.05 + 0.9 * u(rng)) * 2 * kPi / st.sectors;
        // z unwrapped: some cells are one or two periods away; the station must not care.
        const double z = (ia + 0.05 + 0.9 * u(rng)) * kTube.length / st.axial + (k % 3 - 1) * kTube.length;
        add_particle(s, id++, kRbc, r, theta, z);
      }
    }
  return s;
}
}  // namespace

TEST(CflEdge, KnownEdgeAtEveryStationGivesExactThickness) {
  std::mt19937_64 rng(3);
  const Stations st{4, 6};
  // Two snapshots with edges 44 and 45 um: <edge> = 44.5 um, delta = 5.5 um to round-off.
  std::vector<StationEdges> per_snapshot;
  for (double edge : {44 * kUm, 45 * kUm}) {
    const Cells rbc = select_species(station_filling(st, edge, 20, rng), kRbc);
    per_snapshot.push_back(rbc_core_edges(rbc, kD, kTube, st));
    ASSERT_EQ(per_snapshot.back().edge.size(), 24u);
    EXPECT_EQ(per_snapshot.back().empty, 0);
  }
  const auto c = cfl_thickness_edge(per_snapshot, kTube);
  EXPECT_EQ(c.method, "edge");
  EXPECT_NEAR(c.thickness, 5.5 * kUm, 1e-12);
  EXPECT_NEAR(c.edge_std, 0.5 * kUm, 1e-12);
  EXPECT_EQ(c.samples, 48);
}

TEST(CflEdge, EmptyStationsAreSkippedAndCounted) {
  std::mt19937_64 rng(5);
  const Stations st{4, 6};
  const Cells rbc = select_species(station_filling(st, 40 * kUm, 5, rng, {0, 7, 23}), kRbc);
  const auto e = rbc_core_edges(rbc, kD, kTube, st);
  EXPECT_EQ(e.empty, 3);
  EXPECT_EQ(e.edge.size(), 21u);
  const auto c = cfl_thickness_edge({e}, kTube);
  EXPECT_NEAR(c.thickness, 10 * kUm, 1e-12);
  EXPECT_EQ(c.empty_samples, 3);
}

// One stray cell at the wall moves one station's edge, not the answer: delta changes by
// (stray edge - edge) / stations.
TEST(CflEdge, AStrayCellMovesOneStationOnly) {
  std::mt19937_64 rng(9);
  const Stations st{16, 24};
  Snapshot s = station_filling(st, 44 * kUm, 20, rng);
  add_particle(s, 99999, kRbc, kTube.radius - kD / 2, 0.1, 1 * kUm);
  const auto c = cfl_thickness_edge({rbc_core_edges(select_species(s, kRbc), kD, kTube, st)}, kTube);
  EXPECT_NEAR(c.thickness, 6 * kUm - 6 * kUm / 384, 1e-12);
}

TEST(CflEdge, NoRbcsGiveNoThickness) {
  const auto c = cfl_thickness_edge({}, kTube);
  EXPECT_TRUE(std::isnan(c.thickness));
}

// About 20 RBCs per station, with the calibration case's 16 x 24 shape (docs/model.md §5).
TEST(CflEdge, DefaultStationsReproduceTheCalibrationCase) {
  const double rbcs = 0.15 * kTube.volume() / 90e-18;  // 7,854
  const auto st = default_stations(rbcs, kTube);
  EXPECT_EQ(st.axial, 16);
  EXPECT_EQ(st.sectors, 24);
  // Twice the diameter at the same Ht: ~4x the RBCs, ~20 per station again.
  const Tube wide{100 * kUm, 600 * kUm};
  const auto w = default_stations(0.15 * wide.volume() / 90e-18, wide);
  EXPECT_NEAR(0.15 * wide.volume() / 90e-18 / w.count(), 20, 2);
  EXPECT_EQ(default_stations(5, kTube).count(), 1);
}

// Profile method on a constructed fraction: core 0.2 out to bin 6, 0.1 in bin 7, then 0.
// The level is 10 % of 0.2 = 0.02; between the centres of bins 7 (0.1) and 8 (0) the crossing is
// 80 % of a bin width out: edge = 7.5 + 0.8 = 8.3 widths, delta = 1.7 widths.
TEST(CflProfile, ThresholdCrossingIsInterpolatedBetweenBinCentres) {
  const Tube t{10 * kUm, 100 * kUm};
  std::vector<double> f{0.2, 0.2, 0.2, 0.2, 0.2, 0.2, 0.2, 0.1, 0, 0};
  auto c = cfl_thickness_profile(f, t);
  EXPECT_EQ(c.method, "profile");
  EXPECT_NEAR(c.core_mean_fraction, 0.2, 1e-12);
  EXPECT_NEAR(c.thickness, 1.7 * kUm, 1e-12);
  // A dip below the level inside the core (layering, outside the r < R/2 core mean) does not
  // end the core early: the edge is searched from the wall inward.
  f[6] = 0.01;
  c = cfl_thickness_profile(f, t);
  EXPECT_NEAR(c.thickness, 1.7 * kUm, 1e-12);
  // Cells against the wall: no layer.
  f = std::vector<double>(10, 0.2);
  EXPECT_DOUBLE_EQ(cfl_thickness_profile(f, t).thickness, 0);
  // No RBCs: undefined.
  EXPECT_TRUE(std::isnan(cfl_thickness_profile(std::vector<double>(10, 0.0), t).thickness));
}

// Real spheres filling a core whose outer surface is at 44 um: the spread volume fraction falls
// to zero at 44 um, so the profile method's delta lies within one bin (1 um) of the true 6 um.
TEST(CflProfile, SpheresWithAKnownSurfaceGiveTheLayerWithinABin) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(0, 1);
  const double edge = 44 * kUm;
  std::vector<double> r;
  for (int i = 0; i < 8000; ++i) r.push_back((edge - kD / 2) * std::sqrt(u(rng)));
  const auto f = radial_volume_fraction(r, kD, 90e-18, kTube, 50);
  const auto c = cfl_thickness_profile(f, kTube);
  EXPECT_NEAR(c.thickness, 6 * kUm, 1 * kUm);
}
