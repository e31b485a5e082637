// SPDX-License-Identifier: GPL-3.0-or-later
#include "closures/drag_closure.h"
#include "closures/exponential_drag.h"
#include "closures/stokes_drag.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace hemo::particles;

namespace {
DragParams platelet() {
  DragParams p;
  p.diameter = 2.66e-6;
  p.fluid_density = 1025;
  p.viscosity = 1.2e-3;
  return p;
}
constexpr double kPi = 3.14159265358979323846;
}  // namespace

TEST(StokesDrag, CoefficientAndForce) {
  const auto drag = make_drag_closure("stokes", platelet());
  EXPECT_EQ(drag->name(), "stokes");
  const double beta = drag->coefficient(Vec3(1e-3, 0, 0));
  EXPECT_NEAR(beta, 3 * kPi * 1.2e-3 * 2.66e-6, 1e-20);
  const Vec3 slip(1e-4, -2e-4, 3e-4);
  const Vec3 f = drag->coefficient(slip) * slip;  // F = 3 pi mu d (u - v)
  EXPECT_NEAR(f.z(), 3 * kPi * 1.2e-3 * 2.66e-6 * 3e-4, 1e-22);
  EXPECT_TRUE(std::isfinite(drag->coefficient(Vec3::Zero())));
  EXPECT_EQ((drag->coefficient(Vec3::Zero()) * Vec3::Zero()).norm(), 0.0);  // zero slip, zero force
}

TEST(DragRegistry, SelectsByNameFromTheScene) {
  hemo::Species s{"rbc"};
  s.diameter = 5.56e-6;
  s.drag = "stokes";
  hemo::Plasma plasma;
  EXPECT_EQ(make_drag_closure(s, plasma)->name(), "stokes");
  s.drag = "no-such-law";
  try {
    make_drag_closure(s, plasma);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-law"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("stokes"), std::string::npos);
  }
}

TEST(ExponentialDrag, TendsToExplicitForSmallSteps) {
  const double m = 8.79e-15, beta = 3e-8, dt = 1e-12;  // dt << tau = 0.29 us
  EXPECT_NEAR(exponential_drag_coefficient(m, beta, dt) / beta, 1.0, 1e-5);
  EXPECT_EQ(exponential_drag_coefficient(m, 0.0, dt), 0.0);
  EXPECT_EQ(exponential_drag_force(m, beta, Vec3::Zero(), dt).norm(), 0.0);
}

TEST(ExponentialDrag, NeverOvershootsForLargeSteps) {
  // Pure drag towards a fixed fluid velocity, integrated with the force the engine applies;
  // for dt up to 1000 tau the particle approaches u monotonically and never passes it.
  const double m = 8.79e-15, beta = 3e-8, tau = m / beta;
  const Vec3 u(0, 0, 0.02);
  for (double ratio : {0.1, 1.0, 10.0, 1000.0}) {
    const double dt = ratio * tau;
    Vec3 v(0.001, -0.002, 0);
    double prev_gap = (u - v).norm();
    for (int n = 0; n < 50; ++n) {
      const Vec3 f = exponential_drag_force(m, beta, u - v, dt);
      v += f / m * dt;
      const double gap = (u - v).norm();
      EXPECT_LE(gap, prev_gap * (1 + 1e-12));
      EXPECT_GE((u - v).z(), -1e-15);  // same side as at the start: no overshoot
      prev_gap = gap;
    }
    // The discrete decay is the exact exponential: gap_n = gap_0 exp(-n dt / tau).
    const double expected = Vec3(0.001, -0.002, -0.02).norm() * std::exp(-50 * ratio);
    EXPECT_NEAR(prev_gap, expected, 1e-12 + 1e-9 * expected);
  }
}
