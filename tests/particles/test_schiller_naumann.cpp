// SPDX-License-Identifier: GPL-3.0-or-later
// Schiller–Naumann drag (closures/schiller_naumann_drag.h).
#include "closures/schiller_naumann_drag.h"
#include "flows.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace hemo::particles;
using namespace hemo::particles::testing;

TEST(SchillerNaumannDrag, StokesLimitPrintedLawAndVanishingForce) {
  const double d = 2.66e-6, mu = 1.2e-3, nu = mu / 1025;
  const SchillerNaumannDrag drag(plasma_params(d));
  ParticleFlow f;
  EXPECT_DOUBLE_EQ(drag.coefficient(f), 3 * kPi * mu * d);  // Re = 0: Stokes, no 0/0
  for (double re : {1e-3, 0.1, 1.0, 10.0}) {
    const double u = re * nu / d;
    f.slip = Vec3(0, u, 0);
    const double cd = 24 / re * (1 + 0.15 * std::pow(re, 0.687));
    EXPECT_NEAR(drag.coefficient(f) * u, cd * 0.5 * 1025 * u * u * kPi / 4 * d * d, 1e-12 * cd * u * u) << re;
  }
  // 1 % above Stokes at Re = 0.012, 15 % at Re = 1.
  f.slip = Vec3(1.0 * nu / d, 0, 0);
  EXPECT_NEAR(drag.coefficient(f) / (3 * kPi * mu * d), 1.15, 1e-12);
  f.slip = Vec3(1e-300, 0, 0);
  EXPECT_TRUE(std::isfinite(drag.coefficient(f) * 1e-300));
}
