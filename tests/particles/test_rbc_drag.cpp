// SPDX-License-Identifier: GPL-3.0-or-later
// The red-cell drag fit (closures/rbc_drag.h).
#include "closures/rbc_drag.h"
#include "flows.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace hemo::particles;
using namespace hemo::particles::testing;

namespace {
const double kD = 5.56e-6, kMu = 1.2e-3, kRho = 1025, kNu = kMu / kRho;
ParticleFlow slip_along_x(double speed) {
  ParticleFlow f;
  f.slip = Vec3(speed, 0, 0);
  return f;
}
}  // namespace

TEST(RbcFitDrag, StokesLimitIsAnalyticAndThreeTimesStokes) {
  const RbcFitDrag drag(plasma_params(kD));
  const double stokes = 3 * kPi * kMu * kD;
  // Re -> 0: beta = 0.125 * 73.146 pi mu d = 3.04775 x 3 pi mu d, exactly, with no 0/0.
  EXPECT_DOUBLE_EQ(drag.coefficient(slip_along_x(0)), 0.125 * 73.146 * kPi * kMu * kD);
  EXPECT_NEAR(drag.coefficient(slip_along_x(0)) / stokes, 73.146 / 24, 1e-12);
  EXPECT_NEAR(drag.coefficient(slip_along_x(1e-300)) / stokes, 73.146 / 24, 1e-12);
  EXPECT_TRUE(std::isfinite(drag.coefficient(slip_along_x(0))));
}

TEST(RbcFitDrag, MatchesThePrintedLawAtStatedInputs) {
  const RbcFitDrag drag(plasma_params(kD));
  for (double re : {1e-4, 0.01, 0.3, 0.5, 0.8, 1.0}) {
    const double speed = re * kNu / kD;
    // F = 0.125 C_d rho pi d^2 |u_r|^2 as printed, against beta |u_r|.
    const double printed = 0.125 * RbcFitDrag::drag_coefficient(re) * kRho * kPi * kD * kD * speed * speed;
    EXPECT_NEAR(drag.coefficient(slip_along_x(speed)) * speed, printed, 1e-12 * printed) << "Re " << re;
  }
  // Magnitude at a typical slip of 10 um/s (Re = 4.7e-5): 3.05 x 3 pi mu d |u_r| = 1.92 pN.
  EXPECT_NEAR(drag.coefficient(slip_along_x(1e-5)) * 1e-5, 1.9171e-12, 1e-15);
  // The correction term is negligible below Re 0.5 and takes over near Re 0.9.
  const double b0 = drag.coefficient(0.0);
  EXPECT_GT(drag.coefficient(0.5) / b0, 0.999);
  EXPECT_LT(drag.coefficient(0.9) / b0, 0.8);
  EXPECT_EQ(drag.max_reynolds(), 0.5);
}

TEST(RbcFitDrag, ForceIsFiniteAndVanishesWithTheSlip) {
  const RbcFitDrag drag(plasma_params(kD));
  double previous = 1;
  for (double speed : {1e-2, 1e-4, 1e-8, 1e-12, 1e-20, 0.0}) {
    const double f = drag.coefficient(slip_along_x(speed)) * speed;
    EXPECT_TRUE(std::isfinite(f));
    EXPECT_LT(f, previous);
    previous = f;
  }
  EXPECT_EQ(previous, 0.0);
  EXPECT_TRUE(std::isfinite(drag.coefficient(slip_along_x(1e3))));  // far outside the fit: finite
}
