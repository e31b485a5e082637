// SPDX-License-Identifier: GPL-3.0-or-later
// The red-cell lift (closures/rbc_lift.h): points to the axis in Poiseuille flow, vanishes on it.
#include "closures/rbc_lift.h"
#include "flows.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace hemo::particles;
using namespace hemo::particles::testing;

namespace {
const double kD = 5.56e-6, kR = 50e-6, kUmax = 799 * kR / 2;  // gamma_w = 799 1/s
}

TEST(RbcLift, PointsToTheAxisInPoiseuilleFlowAndVanishesOnIt) {
  const RbcLift lift(plasma_params(kD));
  EXPECT_EQ(lift.force(poiseuille_flow(Vec3::Zero(), kR, kUmax)).norm(), 0.0);
  for (double r_over_R : {0.05, 0.3, 0.6, 0.9, 0.95}) {
    for (double angle : {0.0, 1.0, 2.5, 4.0}) {
      const Vec3 x(r_over_R * kR * std::cos(angle), r_over_R * kR * std::sin(angle), 17e-6);
      const Vec3 f = lift.force(poiseuille_flow(x, kR, kUmax));
      const Vec3 inward = -Vec3(x.x(), x.y(), 0).normalized();
      EXPECT_GT(f.dot(inward), 0.999999 * f.norm()) << "r/R " << r_over_R;  // radial, inward
      EXPECT_NEAR(f.z(), 0.0, 1e-12 * f.norm());
    }
  }
}

TEST(RbcLift, MagnitudeAtTheWallAndItsGrowthWithShear) {
  const RbcLift lift(plasma_params(kD));
  const double nu = 1.2e-3 / 1025;
  // Near the wall of the calibration vessel: r = 0.9 R, gamma = 719 1/s, G.a = -gamma e_r.
  const Vec3 x(0.9 * kR, 0, 0);
  const double gamma = 0.9 * 799;
  const double cl = 100.271 / std::pow(gamma * kD * kD / nu, 0.63);
  const double expected = cl * 1025 * std::pow(kD, 6) * gamma * gamma * gamma / nu;
  const Vec3 f = lift.force(poiseuille_flow(x, kR, kUmax));
  EXPECT_NEAR(f.norm(), expected, 1e-9 * expected);
  EXPECT_NEAR(f.norm(), 1.17e-11, 0.01e-11);  // ~12 pN: ~60 um/s of migration against the drag
  // |F| ~ gamma^2.37 along a radius of Poiseuille flow.
  const double f1 = lift.force(poiseuille_flow(Vec3(0.4 * kR, 0, 0), kR, kUmax)).norm();
  const double f2 = lift.force(poiseuille_flow(Vec3(0.8 * kR, 0, 0), kR, kUmax)).norm();
  EXPECT_NEAR(std::log(f2 / f1) / std::log(2.0), 2.37, 1e-9);
}

TEST(RbcLift, FiniteAndZeroWithoutFlowOrShear) {
  const RbcLift lift(plasma_params(kD));
  ParticleFlow rest;
  EXPECT_EQ(lift.force(rest).norm(), 0.0);
  ParticleFlow plug;
  plug.velocity = Vec3(0, 0, 0.01);
  EXPECT_EQ(lift.force(plug).norm(), 0.0);
  // Vanishing shear: the force vanishes like gamma^2.37, never blows up through C_l ~ gamma^-0.63.
  double previous = 1;
  for (double u : {1e-2, 1e-5, 1e-10, 1e-200}) {
    const double f = lift.force(poiseuille_flow(Vec3(0.5 * kR, 0, 0), kR, u)).norm();
    EXPECT_TRUE(std::isfinite(f));
    EXPECT_LT(f, previous);
    previous = f;
  }
}
