// SPDX-License-Identifier: GPL-3.0-or-later
// Shear-induced lift of the spherical surrogate (closures/shear_lift.h): sign and equilibrium.
#include "closures/shear_lift.h"
#include "flows.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace hemo::particles;
using namespace hemo::particles::testing;

namespace {
const double kD = 2.66e-6, kR = 50e-6, kUmax = 799 * kR / 2;
double radial_force(const ShearLift& lift, double r_over_R) {
  const Vec3 x(r_over_R * kR / std::sqrt(2), r_over_R * kR / std::sqrt(2), 3e-6);
  ParticleFlow flow = poiseuille_flow(x, kR, kUmax);
  flow.slip = Vec3::Zero();  // moving with the plasma: Re = 0
  const Vec3 f = lift.force(flow);
  return f.dot(Vec3(1, 1, 0).normalized());
}
}  // namespace

TEST(ShearLift, OutwardInsideSixTenthsOfRInwardBeyondZeroOnTheAxis) {
  const ShearLift lift(plasma_params(kD, 1, 2 * kR));
  EXPECT_EQ(lift.force(poiseuille_flow(Vec3::Zero(), kR, kUmax)).norm(), 0.0);
  for (double s : {0.1, 0.3, 0.5, 0.59}) EXPECT_GT(radial_force(lift, s), 0) << s;
  for (double s : {0.62, 0.8, 0.95}) EXPECT_LT(radial_force(lift, s), 0) << s;
  // The zero: s^2 = a / |c| (the Re term is ~1e-12 of the others here).
  double lo = 0.3, hi = 0.9;
  for (int i = 0; i < 60; ++i) (radial_force(lift, 0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
  EXPECT_NEAR(lo, std::sqrt(ShearLift::kA / -ShearLift::kC), 1e-6);
  EXPECT_NEAR(lo, 0.6056, 1e-4);
}

TEST(ShearLift, MagnitudeAsPrinted) {
  const ShearLift lift(plasma_params(kD, 1, 2 * kR));
  // At r = R/2: s = 1/2, C_L = beta (a/2 + c/8), |F| = 0.125 rho u_max^2 d^4 / D^2 |C_L|.
  const double beta = kD / (2 * kR);
  const double cl = beta * (ShearLift::kA * 0.5 + ShearLift::kC * 0.125);
  const double expected = 0.125 * 1025 * kUmax * kUmax * std::pow(kD, 4) / (4 * kR * kR) * cl;
  EXPECT_NEAR(radial_force(lift, 0.5), expected, 1e-9 * expected);
  EXPECT_LT(expected, 1e-15);  // ~0.1 fN: inertial migration is slow at these Re (see test_single_particle)
}

TEST(ShearLift, FiniteAndZeroWithoutFlow) {
  const ShearLift lift(plasma_params(kD, 1, 2 * kR));
  ParticleFlow rest;
  EXPECT_EQ(lift.force(rest).norm(), 0.0);
  ParticleFlow no_scale = poiseuille_flow(Vec3(10e-6, 0, 0), kR, kUmax);
  no_scale.centreline_speed = 0;
  EXPECT_EQ(lift.force(no_scale).norm(), 0.0);
}
