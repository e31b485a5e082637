// SPDX-License-Identifier: GPL-3.0-or-later
// The oblate platelet closures (closures/oblate.h): Stokes factors, drag, lift and torque signs.
#include "closures/oblate.h"
#include "flows.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace hemo::particles;
using namespace hemo::particles::testing;

namespace {
const double kD = 2.66e-6, kLambda = 0.52 / 2.06, kMu = 1.2e-3, kNu = kMu / 1025;

// Slip of `speed` along x, symmetry axis at `phi` from it in the x-y plane.
ParticleFlow at_incidence(double phi, double speed = 1e-4) {
  ParticleFlow f;
  f.slip = Vec3(speed, 0, 0);
  f.axis = Vec3(std::cos(phi), std::sin(phi), 0);
  return f;
}
}  // namespace

TEST(OblateStokesFactors, SphereAndDiskLimitsAndTabulatedValues) {
  // lambda -> 1: the sphere, from both the closed form and the series near 1.
  for (double l : {1.0, 1 - 1e-9, 1 - 1e-5, 1 - 1e-4, 1 - 1e-3}) {
    EXPECT_NEAR(oblate_k0(l), 1.0, 0.14 * (1 - l) + 1e-15) << l;
    EXPECT_NEAR(oblate_k90(l), 1.0, 0.07 * (1 - l) + 1e-15) << l;
  }
  // The closed form and the series agree where they meet.
  EXPECT_NEAR(oblate_k0(1 - 0.99999e-4), oblate_k0(1 - 1.00001e-4), 1e-9);
  EXPECT_NEAR(oblate_k90(1 - 0.99999e-4), oblate_k90(1 - 1.00001e-4), 1e-9);
  // lambda -> 0: the disk, 16 mu a U broadside and 32/3 mu a U edgewise, i.e.
  // K_0 -> (8/3pi) lambda^-1/3, K_90 -> (16/9pi) lambda^-1/3.
  for (double l : {1e-4, 1e-6}) {
    EXPECT_NEAR(oblate_k0(l) / (8 / (3 * kPi) * std::cbrt(1 / l)), 1.0, 2 * l) << l;
    EXPECT_NEAR(oblate_k90(l) / (16 / (9 * kPi) * std::cbrt(1 / l)), 1.0, 2 * l) << l;
  }
  // docs/model.md §7.1's table.
  EXPECT_NEAR(oblate_k0(0.25), 1.37683, 5e-6);
  EXPECT_NEAR(oblate_k90(0.25), 1.08315, 5e-6);
  EXPECT_NEAR(oblate_k0(0.5), 1.14061, 5e-6);
  EXPECT_NEAR(oblate_k90(0.5), 0.99875, 5e-6);
  EXPECT_NEAR(oblate_k0(0.1), 1.83655, 5e-6);
  EXPECT_NEAR(oblate_k90(0.1), 1.32132, 5e-6);
}

TEST(OblateDrag, StokesLimitInterpolatesBroadsideAndEdgewise) {
  const OblateDrag drag(plasma_params(kD, kLambda));
  const double stokes = 3 * kPi * kMu * kD;
  const double slow = 1e-9;  // Re ~ 2e-12
  EXPECT_NEAR(drag.coefficient(at_incidence(0, slow)), stokes * oblate_k0(kLambda), 1e-7 * stokes);
  EXPECT_NEAR(drag.coefficient(at_incidence(kPi / 2, slow)), stokes * oblate_k90(kLambda), 1e-7 * stokes);
  const double phi = 0.7, s2 = std::sin(phi) * std::sin(phi);
  EXPECT_NEAR(drag.coefficient(at_incidence(phi, slow)),
              stokes * (oblate_k0(kLambda) * (1 - s2) + oblate_k90(kLambda) * s2), 1e-7 * stokes);
  // Broadside-on is the largest drag; n and -n are the same body.
  EXPECT_GT(drag.coefficient(at_incidence(0)), drag.coefficient(at_incidence(kPi / 2)));
  EXPECT_DOUBLE_EQ(drag.coefficient(at_incidence(0.3)), drag.coefficient(at_incidence(0.3 + kPi)));
  // Matches the printed C_D at Re = 0.5: |F| = C_D 1/2 rho u^2 (pi/4) d^2.
  const double re = 0.5, u = re * kNu / kD;
  const double cd0 = 24 / re *
                     (oblate_k0(kLambda) + 0.15 * std::pow(kLambda, 95.91) * std::pow(re, 0.687) +
                      0.2927 * std::pow(1 - kLambda, 0.4374) * std::pow(re, 0.7512));
  EXPECT_NEAR(drag.coefficient(at_incidence(0, u)) * u, cd0 * 0.5 * 1025 * u * u * kPi / 4 * kD * kD,
              1e-9 * cd0 * u * u);
  // Finite at zero slip, force -> 0.
  EXPECT_TRUE(std::isfinite(drag.coefficient(at_incidence(0.4, 0.0))));
}

TEST(OblateLift, VanishesBroadsideAndEdgewiseAndFlipsWithTheAngle) {
  const OblateLift lift(plasma_params(kD, kLambda));
  EXPECT_NEAR(lift.force(at_incidence(0)).norm(), 0.0, 1e-30);
  EXPECT_NEAR(lift.force(at_incidence(kPi / 2)).norm(), 0.0, 1e-25);
  for (double phi : {0.2, 0.6, 1.0, 1.4}) {
    const Vec3 up = lift.force(at_incidence(phi)), down = lift.force(at_incidence(-phi));
    EXPECT_GT(up.norm(), 0) << phi;
    EXPECT_NEAR(up.dot(Vec3(1, 0, 0)), 0.0, 1e-12 * up.norm());              // normal to u_r
    EXPECT_GT(up.y(), 0) << "lift toward the side n leans to, phi " << phi;  // in the plane of u_r and n
    EXPECT_NEAR((up + down).norm(), 0.0, 1e-12 * up.norm()) << phi;          // phi -> -phi flips it
    EXPECT_NEAR((lift.force(at_incidence(phi + kPi)) - up).norm(), 0.0, 1e-12 * up.norm());  // -n: same body
  }
  // Re -> 0: the normal part of the Stokes resistance tensor,
  // 3 pi mu d (K_0 - K_90)(n.u_r)(n - (n.e) e).
  const double phi = 0.5, u = 1e-9;
  const Vec3 expected = 3 * kPi * kMu * kD * (oblate_k0(kLambda) - oblate_k90(kLambda)) * u * std::cos(phi) *
                        std::sin(phi) * Vec3(0, 1, 0);
  EXPECT_NEAR((lift.force(at_incidence(phi, u)) - expected).norm(), 0.0, 1e-6 * expected.norm());
}

TEST(OblateTorque, VanishesBroadsideAndEdgewiseFlipsAndTurnsThePlateletBroadsideOn) {
  const OblateTorque torque(plasma_params(kD, kLambda));
  EXPECT_NEAR(torque.torque(at_incidence(0)).norm(), 0.0, 1e-40);
  EXPECT_NEAR(torque.torque(at_incidence(kPi / 2)).norm(), 0.0, 1e-35);
  for (double phi : {0.2, 0.6, 1.0, 1.4, kPi - 0.4}) {
    const ParticleFlow f = at_incidence(phi);
    const Vec3 t = torque.torque(f);
    EXPECT_GT(t.norm(), 0);
    EXPECT_NEAR((t + torque.torque(at_incidence(-phi))).norm(), 0.0, 1e-12 * t.norm());
    // A small rotation about t turns n toward +-e: |n.e| grows.
    const Vec3 n = f.axis, e = f.slip.normalized();
    const Vec3 n_after = (n + 1e-3 * t.normalized().cross(n)).normalized();
    EXPECT_GT(std::abs(n_after.dot(e)), std::abs(n.dot(e))) << "phi " << phi;
    // Magnitude as printed: C_T 1/2 rho u^2 (pi/8) d^3.
    const double re = kD * 1e-4 / kNu;
    const double ct =
        1.85 * std::pow((1 - kLambda) / kLambda, 0.832) / std::pow(re, 0.146) * std::abs(std::sin(phi) * std::cos(phi));
    EXPECT_NEAR(t.norm(), ct * 0.5 * 1025 * 1e-8 * kPi / 8 * kD * kD * kD, 1e-9 * t.norm());
  }
}

TEST(OblateClosures, FiniteAndVanishingWithTheSlip) {
  const ClosureParams p = plasma_params(kD, kLambda);
  const OblateDrag drag(p);
  const OblateLift lift(p);
  const OblateTorque torque(p);
  double f_prev = 1, l_prev = 1, t_prev = 1;
  for (double u : {1e-2, 1e-4, 1e-8, 1e-16, 1e-300, 0.0}) {
    const ParticleFlow f = at_incidence(0.6, u);
    const double fd = drag.coefficient(f) * u, fl = lift.force(f).norm(), ft = torque.torque(f).norm();
    EXPECT_TRUE(std::isfinite(fd) && std::isfinite(fl) && std::isfinite(ft)) << u;
    EXPECT_LE(fd, f_prev);
    EXPECT_LE(fl, l_prev);
    EXPECT_LE(ft, t_prev);
    f_prev = fd;
    l_prev = fl;
    t_prev = ft;
  }
  EXPECT_EQ(f_prev + l_prev + t_prev, 0.0);
}
