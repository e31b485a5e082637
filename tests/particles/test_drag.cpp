// SPDX-License-Identifier: GPL-3.0-or-later
// Stokes drag, the closure registry, and the exponential drag update.
#include "closures/closure.h"
#include "closures/exponential_drag.h"
#include "closures/stokes_drag.h"
#include "flows.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace hemo::particles;
using namespace hemo::particles::testing;

namespace {
ParticleFlow with_slip(const Vec3& slip) {
  ParticleFlow f;
  f.slip = slip;
  return f;
}
}  // namespace

TEST(StokesDrag, CoefficientAndForce) {
  const auto drag = make_drag_closure("stokes", plasma_params(2.66e-6));
  EXPECT_EQ(drag->name(), "stokes");
  const double beta = drag->coefficient(with_slip(Vec3(1e-3, 0, 0)));
  EXPECT_NEAR(beta, 3 * kPi * 1.2e-3 * 2.66e-6, 1e-20);
  const Vec3 slip(1e-4, -2e-4, 3e-4);
  const Vec3 f = drag->coefficient(with_slip(slip)) * slip;  // F = 3 pi mu d (u - v)
  EXPECT_NEAR(f.z(), 3 * kPi * 1.2e-3 * 2.66e-6 * 3e-4, 1e-22);
  EXPECT_TRUE(std::isfinite(drag->coefficient(with_slip(Vec3::Zero()))));
  EXPECT_TRUE(drag->slip_independent());
}

TEST(ClosureRegistry, SelectsByNameFromTheScene) {
  hemo::Scene scene;
  scene.vessel.diameter = 100e-6;
  hemo::Species s{"rbc"};
  s.diameter = 5.56e-6;
  for (const auto& name : hemo::known_drag_closures()) {
    s.drag = name;
    auto p = closure_params(s, scene);
    if (name == "oblate") p.aspect_ratio = 0.25;
    EXPECT_EQ(make_drag_closure(name, p)->name(), name);
  }
  for (const auto& name : hemo::known_lift_closures()) {
    auto p = closure_params(s, scene);
    if (name == "oblate") p.aspect_ratio = 0.25;
    auto lift = make_lift_closure(name, p);
    EXPECT_EQ(lift == nullptr, name == "none") << name;
    if (lift) {
      EXPECT_EQ(lift->name(), name);
    }
  }
  for (const auto& name : hemo::known_torque_closures()) {
    auto p = closure_params(s, scene);
    p.aspect_ratio = 0.25;
    EXPECT_EQ(make_torque_closure(name, p) == nullptr, name == "none") << name;
  }
  // The scene's lists and the registry agree.
  EXPECT_EQ(drag_closure_names().size(), hemo::known_drag_closures().size());
  EXPECT_EQ(lift_closure_names().size(), hemo::known_lift_closures().size());
  EXPECT_EQ(torque_closure_names().size(), hemo::known_torque_closures().size());
  try {
    make_drag_closure("no-such-law", closure_params(s, scene));
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
  // With other forces and no drag, nothing is added.
  EXPECT_EQ(exponential_drag_force(m, 0.0, Vec3(1, 2, 3), Vec3(4, 5, 6), dt).norm(), 0.0);
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

TEST(ExponentialDrag, WithOtherForcesReachesTheExactTerminalSlipAtAnyStep) {
  // Constant external force F_o and linear drag: the terminal slip is -F_o / beta, reached
  // after a few steps, whatever dt / tau; and each step's velocity change is the exact one.
  const double m = 9.9e-14, beta = 1.9e-7, tau = m / beta;
  const Vec3 u(0, 0, 0.01), other(1e-12, 0, -3e-12);
  for (double ratio : {0.01, 1.0, 10.0, 1000.0}) {
    const double dt = ratio * tau;
    Vec3 v = Vec3::Zero();
    for (int n = 0; n < 10000 && n * ratio < 60; ++n) {
      const Vec3 v_exact = u + other / beta - (u + other / beta - v) * std::exp(-dt / tau);
      v += (exponential_drag_force(m, beta, u - v, other, dt) + other) / m * dt;
      EXPECT_LT((v - v_exact).norm(), 1e-12 * (u.norm() + v.norm())) << "dt/tau " << ratio;
    }
    EXPECT_LT((v - (u + other / beta)).norm(), 1e-9 * u.norm()) << "dt/tau " << ratio;
  }
}

TEST(ExponentialDrag, IntervalResponseIsTheDerivativeOfTheIntervalImpulse) {
  // A coupling interval of DEM steps in a held fluid velocity u, with other forces and a beta
  // that changes every few steps (closures refreshed every k steps): the interval's drag
  // impulse J(u) is linear in u, and its slope must be m (1 - exp(-B/m)), B = sum beta dt,
  // whatever the interval is against tau = m / beta (0.01 to 100 relaxation times).
  const double m = 9.9e-14, beta0 = 1.9e-7, tau = m / beta0;
  const Vec3 other(1e-12, 0, -3e-12), u(0, 0, 0.01), du(0, 0, 1e-3);
  for (double interval_over_tau : {0.01, 0.3, 1.0, 5.0, 100.0}) {
    const int steps = 40;
    const double dt = interval_over_tau * tau / steps;
    double beta_time = 0;
    const auto impulse = [&](const Vec3& fluid) {
      Vec3 v(0, 0, 0.004), j = Vec3::Zero();
      beta_time = 0;
      for (int n = 0; n < steps; ++n) {
        const double beta = beta0 * (1.0 + 0.5 * ((n / 7) % 3));
        const Vec3 f = exponential_drag_force(m, beta, fluid - v, other, dt);
        v += (f + other) / m * dt;
        j += f * dt;
        beta_time += beta * dt;
      }
      return j;
    };
    const Vec3 slope = (impulse(u + du) - impulse(u)) / du.z();
    const double response = interval_drag_response(m, beta_time);
    EXPECT_NEAR(slope.z(), response, 1e-9 * response) << "interval/tau " << interval_over_tau;
    EXPECT_NEAR(slope.x(), 0.0, 1e-9 * response);
  }
  // Limits: a particle that barely moves resists with beta dt; one that follows with its mass.
  EXPECT_NEAR(interval_drag_response(m, 1e-6 * m), 1e-6 * m, 1e-12 * m);
  EXPECT_NEAR(interval_drag_response(m, 50 * m), m, 1e-15 * m);
  EXPECT_EQ(interval_drag_response(m, 0.0), 0.0);
}
