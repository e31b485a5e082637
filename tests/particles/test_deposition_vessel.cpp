// SPDX-License-Identifier: GPL-3.0-or-later
// The solid-fraction models on the calibration mesh (the paper's 1,536-cell O-grid): a cell's
// share of a particle must not jump as the particle moves, or d(alpha)/dt -- and the pressure
// that keeps the plasma's volume -- gets a kick of (jump) / (coupling interval) at every crossing.
#include "deposition.h"

#include <vessel_mesh.h>
#include <hemo/mesh_t.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

using namespace hemo::particles;

namespace {

struct CalibrationMesh {
  hemo::mesh_t message;
  CalibrationMesh() {
    hemo::Scene scene;
    scene.vessel.diameter = 100e-6;
    scene.vessel.length = 600e-6;
    const auto poly = hemo::make_vessel_mesh(scene.vessel, scene.mesh);
    hemo::fill_mesh_message(poly, hemo::compute_geometry(poly), scene.vessel, message);
  }
};

int most_shares = 0;  // the most cells one particle was shared with

std::vector<double> shares_of(const CellLocator& loc, const SolidFractionModel& model, const Vec3& x, double r) {
  std::vector<double> v(loc.n_cells(), 0.0);
  int cell = loc.locate(x);
  if (cell < 0) cell = loc.locate_in_wall_gap(x);
  if (cell < 0) return v;
  std::vector<CellShare> shares;
  model.share(cell, loc.wrap(x), r, shares);
  most_shares = std::max(most_shares, static_cast<int>(shares.size()));
  for (const CellShare& s : shares) v[s.cell] += s.fraction;
  return v;
}

// The largest change of any cell's share per step of a particle of radius r walked along
// `walks` random straight lines inside the vessel (steps of `step` m).
double largest_jump(const CellLocator& loc, const SolidFractionModel& model, double r, int walks, double step,
                    double* typical) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1), uz(0, 600e-6);
  double worst = 0;
  std::vector<double> all;
  for (int w = 0; w < walks; ++w) {
    Vec3 x;
    do x = Vec3(45e-6 * u(rng), 45e-6 * u(rng), uz(rng));
    while (std::hypot(x.x(), x.y()) > 45e-6);
    const Vec3 dir = Vec3(u(rng), u(rng), 0.3 * u(rng)).normalized();
    auto prev = shares_of(loc, model, x, r);
    for (int k = 0; k < 3000; ++k) {
      x += step * dir;
      if (std::hypot(x.x(), x.y()) > 50e-6 - r) break;
      const auto now = shares_of(loc, model, x, r);
      double jump = 0;
      for (int c = 0; c < loc.n_cells(); ++c) jump = std::max(jump, std::abs(now[c] - prev[c]));
      worst = std::max(worst, jump);
      all.push_back(jump);
      prev = now;
    }
  }
  std::sort(all.begin(), all.end());
  if (typical) *typical = all[all.size() / 2];
  return worst;
}

}  // namespace

TEST(SphereOverlapOnTheVessel, SharesDoNotJumpAsAParticleCrossesTheOGrid) {
  const CalibrationMesh mesh;
  const CellLocator loc(mesh.message);
  const auto model = make_solid_fraction_model("sphere_overlap", loc);
  double typical = 0;
  const double step = 0.01e-6, r = 2.78e-6;
  const double worst = largest_jump(loc, *model, r, 40, step, &typical);
  std::printf("[ info ] sphere_overlap on the O-grid: largest share change per %.2g um step %.3g (median %.3g)\n",
              step * 1e6, worst, typical);
  // A cap's volume changes by at most 3/(4 r) of the sphere per unit of its centre's travel; a
  // share, a product of caps renormalised, by a few times that -- not by a finite amount.
  EXPECT_LT(worst, 2 * 0.75 * step / r);
  std::printf("[ info ] at most %d cells shared one particle\n", most_shares);

  // The centre cell's share, for comparison, jumps by 1 at every crossing.
  const auto centre = make_solid_fraction_model("centre_cell", loc);
  EXPECT_GT(largest_jump(loc, *centre, r, 5, step, nullptr), 0.99);
}
