// SPDX-License-Identifier: GPL-3.0-or-later
#include "box_mesh.h"
#include "fluid_sampler.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

using namespace hemo::particles;
using hemo::particles::testing::box_mesh;
using hemo::particles::testing::fluid_state;

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
  s.velocity[5][1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(FluidSampler::check(s, mesh.n_cells, "abc").find("cell 5"), std::string::npos);
  const CellLocator loc(mesh);
  FluidSampler fs(loc);
  EXPECT_THROW(fs.set_state(s), std::invalid_argument);
}
