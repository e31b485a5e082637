// Unit tests of the analytic flows published by hemocosim-analytic-fluid.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "analytic_flow.h"
#include "cell_fields.h"

#include <cmath>

namespace {

hemo::Scene paper_scene() {
  hemo::Scene s;
  s.vessel = {100e-6, 600e-6};
  s.driving.wall_shear_rate = 799;
  return s;
}

// The gradient is the derivative of the velocity (central differences, G[i][j] = d u_j/d x_i).
void expect_consistent(const hemo::AnalyticFlow& flow, const hemo::Vec3& x, double scale) {
  const auto g = flow.gradient(x);
  const double h = 1e-7;
  for (int i = 0; i < 3; ++i) {
    hemo::Vec3 xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    const auto up = flow.velocity(xp), um = flow.velocity(xm);
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(g[i * 3 + j], (up[j] - um[j]) / (2 * h), 1e-6 * scale) << i << j;
  }
}

TEST(AnalyticFlow, PoiseuilleOfTheScenesPressureDrop) {
  const auto s = paper_scene();
  const auto fluid = hemo::fluid_settings(s);
  const auto flow = hemo::poiseuille_flow(fluid, s.vessel);
  const double R = 50e-6;
  EXPECT_NEAR(flow.velocity({0, 0, 1e-4})[2], 799 * R / 2, 1e-12);  // u_max = gamma_w R / 2
  EXPECT_NEAR(flow.velocity({R, 0, 0})[2], 0, 1e-15);
  EXPECT_NEAR(flow.velocity({0.3 * R, 0.2 * R, 0})[2],
              hemo::poiseuille_velocity(fluid, s.vessel, std::hypot(0.3, 0.2) * R), 1e-15);
  EXPECT_NEAR(flow.wall_shear_rate(), 799, 1e-9);
  expect_consistent(flow, {0.3 * R, -0.4 * R, 2e-4}, 799);
}

TEST(AnalyticFlow, LinearShear) {
  const auto flow = hemo::shear_flow(500, 0.01);
  EXPECT_DOUBLE_EQ(flow.velocity({2e-5, 7e-6, 3e-5})[2], 0.01 + 500 * 2e-5);
  EXPECT_DOUBLE_EQ(flow.gradient({1, 2, 3})[2], 500);
  EXPECT_DOUBLE_EQ(flow.wall_shear_rate(), 500);
  expect_consistent(flow, {1e-5, 2e-5, 0}, 500);
}

TEST(AnalyticFlow, FillsTheStateAtCellCentres) {
  const auto s = paper_scene();
  const auto mesh = hemo::make_vessel_mesh(s.vessel, hemo::MeshSpec{4, 3, 24});
  const auto geo = hemo::compute_geometry(mesh);
  const auto flow = hemo::poiseuille_flow(hemo::fluid_settings(s), s.vessel);
  hemo::fluid_state_t state;
  hemo::fill_state(flow, geo, "hash", 0.25, state);
  ASSERT_EQ(state.n_cells, mesh.n_cells);
  EXPECT_EQ(state.mesh_hash, "hash");
  EXPECT_DOUBLE_EQ(state.time_s, 0.25);
  for (int c = 0; c < mesh.n_cells; c += 97) {
    EXPECT_DOUBLE_EQ(hemo::velocity_of(state, c)[2], flow.velocity(geo.cell_centres[c])[2]);
    EXPECT_DOUBLE_EQ(hemo::gradient_of(state, c)[1 * 3 + 2], flow.gradient(geo.cell_centres[c])[1 * 3 + 2]);
  }
}

}  // namespace
