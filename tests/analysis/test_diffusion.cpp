// Radial MSD matched by id, and D from a line through the origin: exact on constructed data,
// within a few per cent on a seeded random walk.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "observables.h"
#include "synthetic.h"

#include <gtest/gtest.h>

#include <random>

using namespace hemo::analysis;
using namespace hemo::analysis::test;

TEST(RadialMsd, MatchesPlateletsByIdNotByOrder) {
  Snapshot a, b;
  add_particle(a, 1, kPlatelet, 10 * kUm, 0.0, 0);
  add_particle(a, 2, kPlatelet, 20 * kUm, 1.0, 0);
  add_particle(a, 3, kPlatelet, 30 * kUm, 2.0, 0);
  add_particle(a, 4, kRbc, 5 * kUm, 0.0, 0);
  // Later: reordered, angle and z changed (irrelevant), id 3 gone, id 5 new, the RBC moved.
  add_particle(b, 2, kPlatelet, 23 * kUm, -2.0, 50 * kUm);
  add_particle(b, 5, kPlatelet, 40 * kUm, 0.0, 0);
  add_particle(b, 1, kPlatelet, 9 * kUm, 3.0, 7 * kUm);
  add_particle(b, 4, kRbc, 45 * kUm, 0.0, 0);
  const auto p = radial_msd(select_species(a, kPlatelet), 0.5, select_species(b, kPlatelet), 0.75);
  EXPECT_DOUBLE_EQ(p.lag_s, 0.25);
  EXPECT_EQ(p.matched, 2);
  EXPECT_NEAR(p.msd_m2, (9 + 1) / 2.0 * 1e-12, 1e-24);
  EXPECT_TRUE(std::isnan(radial_msd({}, 0, select_species(b, kPlatelet), 1).msd_m2));
}

TEST(Diffusivity, ExactLineThroughOriginIsRecovered) {
  const double D = 2.3e-10;
  std::vector<MsdPoint> msd;
  for (int k = 1; k <= 30; ++k) msd.push_back({0.01 * k, 2 * D * 0.01 * k, 100});
  const auto fit = fit_diffusivity(msd, 0.1);
  EXPECT_NEAR(fit.diffusivity, D, 1e-12 * D);
  EXPECT_EQ(fit.points, 10);  // 0.01 .. 0.10 s; 0.1 itself is inside despite rounding in 0.01 * 10
  EXPECT_NEAR(fit.window_end, 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(fit.t_fit, 0.1);
}

TEST(Diffusivity, PointsOutsideTheWindowAreIgnored) {
  // Sub-diffusive plateau after 0.1 s must not pull D down.
  std::vector<MsdPoint> msd{{0, 0, 10}, {0.05, 1e-11, 10}, {0.1, 2e-11, 10}, {0.2, 2e-11, 10}, {0.4, 2e-11, 10}};
  const auto fit = fit_diffusivity(msd, 0.1);
  EXPECT_EQ(fit.points, 2);
  EXPECT_NEAR(fit.diffusivity, 1e-10, 1e-22);
  const auto none = fit_diffusivity({{0.5, 1e-11, 10}}, 0.1);
  EXPECT_EQ(none.points, 0);
  EXPECT_TRUE(std::isnan(none.diffusivity));
}

// A random walk in r with Gaussian steps of variance 2 D dt: MSD = 2 D t. With N = 20,000
// walkers (seed 20240601) each MSD point has a relative standard error of sqrt(2/N) = 1 %;
// the fit over 10 points must land within 3 % of D.
TEST(Diffusivity, RandomWalkInRadiusGivesItsDiffusivity) {
  const double D = 2.3e-10, dt = 0.01, r0 = 1e-3;  // r0 far from the axis: no reflection at r = 0
  const int N = 20000, steps = 20;
  std::mt19937_64 rng(20240601);
  std::normal_distribution<double> step(0, std::sqrt(2 * D * dt));
  std::vector<double> r(N, r0);
  auto snapshot = [&](const std::vector<double>& radii) {
    Snapshot s;
    for (int i = 0; i < N; ++i) add_particle(s, i, kPlatelet, radii[i], 0.37 * i, 0);
    return select_species(s, kPlatelet);
  };
  const Cells reference = snapshot(r);
  std::vector<MsdPoint> msd;
  for (int k = 1; k <= steps; ++k) {
    for (double& x : r) x += step(rng);
    msd.push_back(radial_msd(reference, 0, snapshot(r), k * dt));
    EXPECT_EQ(msd.back().matched, N);
  }
  const auto fit = fit_diffusivity(msd, 0.1);
  EXPECT_EQ(fit.points, 10);
  EXPECT_NEAR(fit.diffusivity, D, 0.03 * D);
}
