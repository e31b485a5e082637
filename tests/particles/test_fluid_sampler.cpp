// SPDX-License-Identifier: GPL-3.0-or-later
#include "synthetic_case.h"
#include "cell_fields.h"
#include "fluid_sampler.h"
#include "over_the_wire.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

using namespace hemo::particles;
using hemo::particles::synthetic::box_mesh;
using hemo::particles::synthetic::fluid_state;

namespace {
// u = u0 + A x, i.e. G = A^T (G[i][j] = d u_j / d x_i = A[j][i]).
const double A[3][3] = {{0.1, -2.0, 0.5}, {3.0, 0.2, -1.0}, {0.7, 1.5, -0.3}};
const double U0[3] = {0.01, -0.02, 0.3};

void linear(const std::array<double, 3>& x, std::array<double, 3>& u, std::array<double, 9>& g) {
  for (int j = 0; j < 3; ++j) {
    u[j] = U0[j];
    for (int i = 0; i < 3; ++i) {
      u[j] += A[j][i] * x[i];
      g[3 * i + j] = A[j][i];
    }
  }
}
}  // namespace

TEST(FluidSampler, LinearFieldIsReproducedExactly) {
  const auto mesh = box_mesh(3, 2, 4, -1, 1, -1, 1, 4, 2);
  const CellLocator loc(mesh);
  FluidSampler fs(loc);
  fs.set_state(fluid_state(mesh, linear));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> ux(-1, 1), uz(0, 4);
  for (int n = 0; n < 500; ++n) {
    const Vec3 x(ux(rng), ux(rng), uz(rng));
    const int c = loc.locate(x);
    ASSERT_GE(c, 0);
    const Vec3 u = fs.velocity(c, loc.wrap(x));
    for (int j = 0; j < 3; ++j) {
      double exact = U0[j];
      for (int i = 0; i < 3; ++i) exact += A[j][i] * x[i];
      EXPECT_NEAR(u[j], exact, 1e-13);
    }
  }
}

TEST(FluidSampler, ShearRateOfSimpleShear) {
  const auto mesh = box_mesh(2, 2, 2, 0, 1, 0, 1, 1, 1);
  const CellLocator loc(mesh);
  FluidSampler fs(loc);
  const double rate = 799;
  // u_z = rate * x: only G[0][2] = rate; gamma_dot = rate.
  fs.set_state(fluid_state(mesh, [&](const auto& x, auto& u, auto& g) {
    u = {0, 0, rate * x[0]};
    g = {0, 0, rate, 0, 0, 0, 0, 0, 0};
  }));
  for (int c = 0; c < loc.n_cells(); ++c) EXPECT_NEAR(fs.shear_rate(c), rate, 1e-9);
}

TEST(FluidSampler, CheckNamesTheCause) {
  const auto mesh = box_mesh(2, 2, 2, 0, 1, 0, 1, 1, 1, "abc");
  auto s = fluid_state(mesh, linear);
  EXPECT_EQ(FluidSampler::check(s, mesh.n_cells, "abc"), "");
  EXPECT_NE(FluidSampler::check(s, mesh.n_cells, "other").find("mesh"), std::string::npos);
  EXPECT_NE(FluidSampler::check(s, 9, "abc").find("cells"), std::string::npos);
  hemo::velocity_of(s, 5)[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(FluidSampler::check(s, mesh.n_cells, "abc").find("cell 5"), std::string::npos);
  const CellLocator loc(mesh);
  FluidSampler fs(loc);
  EXPECT_THROW(fs.set_state(s), std::invalid_argument);
}

TEST(FluidSampler, ForgedLengthIsRejected) {
  const auto mesh = box_mesh(2, 2, 2, 0, 1, 0, 1, 1, 1, "abc");  // 8 cells
  const CellLocator loc(mesh);
  FluidSampler fs(loc);
  const auto good = fluid_state(mesh, linear);
  EXPECT_EQ(FluidSampler::check(hemo::test::over_the_wire(good), mesh.n_cells, "abc"), "");

  // A sender that keeps n_cells but sends one cell's velocity too few: decodes fine, must not pass.
  auto short_velocity = good;
  short_velocity.n_velocity_values -= 3;
  short_velocity.velocity.resize(static_cast<std::size_t>(short_velocity.n_velocity_values));
  const auto received = hemo::test::over_the_wire(short_velocity);
  EXPECT_EQ(FluidSampler::check(received, mesh.n_cells, "abc"),
            "fluid state: velocity has 21 values, not 3 per cell of 8 cells");
  EXPECT_THROW(fs.set_state(received), std::invalid_argument);

  auto long_gradient = good;
  long_gradient.n_gradient_values += 9;
  long_gradient.velocity_gradient.resize(static_cast<std::size_t>(long_gradient.n_gradient_values));
  EXPECT_EQ(FluidSampler::check(hemo::test::over_the_wire(long_gradient), mesh.n_cells, "abc"),
            "fluid state: velocity gradient has 81 values, not 9 per cell of 8 cells");

  // A length field that disagrees with its own array (built in process, never encoded).
  auto lying = good;
  lying.n_velocity_values = 0;
  EXPECT_EQ(FluidSampler::check(lying, mesh.n_cells, "abc"),
            "fluid state: velocity has 0 values, not 3 per cell of 8 cells");
  EXPECT_THROW(fs.set_state(lying), std::invalid_argument);
}

// coupling.fluid_velocity = "cell" (CFDEM's default): every point of a cell sees the cell's own
// value, where the reconstruction sees the linear field.
TEST(FluidSampler, CellSamplingReturnsTheCellValueEverywhereInTheCell) {
  const auto mesh = box_mesh(3, 2, 4, -1, 1, -1, 1, 4, 2);
  const CellLocator loc(mesh);
  FluidSampler cell(loc, FluidSampler::Sampling::cell), reconstructed(loc);
  cell.set_state(fluid_state(mesh, linear));
  reconstructed.set_state(fluid_state(mesh, linear));
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(-1, 1), uz(0, 4);
  double largest_difference = 0;
  for (int n = 0; n < 500; ++n) {
    const Vec3 x(ux(rng), ux(rng), uz(rng));
    const int c = loc.locate(x);
    ASSERT_GE(c, 0);
    EXPECT_EQ(cell.velocity(c, loc.wrap(x)), cell.cell_velocity(c));
    EXPECT_EQ(cell.gradient(c), reconstructed.gradient(c));  // the gradient is the cell's either way
    largest_difference =
        std::max(largest_difference, (reconstructed.velocity(c, loc.wrap(x)) - cell.cell_velocity(c)).norm());
  }
  EXPECT_GT(largest_difference, 0.5);  // |A| ~ 1 over cells ~ 1 wide
}

// The pressure gradient is optional in a fluid state: none, or 3 values per cell, all finite.
TEST(FluidSampler, PressureGradientIsOptionalAndChecked) {
  const auto mesh = box_mesh(2, 2, 2, 0, 1, 0, 1, 1, 1);
  const CellLocator loc(mesh);
  FluidSampler fs(loc);
  auto state = fluid_state(mesh, linear);
  ASSERT_EQ(state.n_pressure_gradient_values, 0);
  fs.set_state(state);
  EXPECT_FALSE(fs.has_pressure_gradient());
  EXPECT_TRUE(fs.cell_pressure_gradients().empty());

  state.n_pressure_gradient_values = 3 * state.n_cells;
  state.pressure_gradient.assign(static_cast<std::size_t>(state.n_pressure_gradient_values), 0.0);
  for (int c = 0; c < state.n_cells; ++c) state.pressure_gradient[3 * c + 2] = -100.0 * (c + 1);
  EXPECT_EQ(FluidSampler::check(state, state.n_cells, state.mesh_hash), "");
  fs.set_state(state);
  ASSERT_TRUE(fs.has_pressure_gradient());
  EXPECT_EQ(fs.pressure_gradient(3), Vec3(0, 0, -400.0));
  EXPECT_EQ(fs.cell_pressure_gradients(), state.pressure_gradient);

  auto short_one = state;
  short_one.pressure_gradient.pop_back();
  EXPECT_NE(FluidSampler::check(short_one, state.n_cells, state.mesh_hash).find("pressure gradient"),
            std::string::npos);
  auto nan = state;
  nan.pressure_gradient[4] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(FluidSampler::check(nan, state.n_cells, state.mesh_hash).find("pressure gradient is not finite"),
            std::string::npos);
  EXPECT_THROW(fs.set_state(nan), std::invalid_argument);
}
