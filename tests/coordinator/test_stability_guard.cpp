// The stability guards on a step's reports (coordinator/stability_guard.h), without a run.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "stability_guard.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using hemo::unstable_step;

namespace {
hemo::RunSettings limits() {
  hemo::RunSettings r;
  r.max_courant = 0.5;
  r.max_overlap = 0.2;
  return r;
}
}  // namespace

TEST(StabilityGuard, WithinTheLimitsSaysNothing) {
  EXPECT_EQ(unstable_step("fluid", 3, {"courant_max", "mean_velocity_m_s"}, {0.5, 0.01}, limits()), "");
  EXPECT_EQ(unstable_step("particles", 3, {"max_overlap"}, {0.2}, limits()), "");
  // Each guard belongs to its node: a particle diagnostic of that name is not the fluid's Courant number.
  EXPECT_EQ(unstable_step("particles", 3, {"courant_max"}, {9.0}, limits()), "");
  EXPECT_EQ(unstable_step("fluid", 3, {"max_overlap"}, {9.0}, limits()), "");
}

TEST(StabilityGuard, CourantNumberAboveTheLimitIsNamedWithItsCure) {
  const auto why = unstable_step("fluid", 12, {"mean_velocity_m_s", "courant_max"}, {0.01, 0.51}, limits());
  EXPECT_NE(why.find("fluid Courant number 0.51 at step 12"), std::string::npos) << why;
  EXPECT_NE(why.find("run.max_courant = 0.5"), std::string::npos) << why;
  EXPECT_NE(why.find("time.coupling_interval_s"), std::string::npos) << why;
}

// A fluid step of several intervals (fluid.solve_every > 1: the step reports fluid_step_s) has
// its own cure.
TEST(StabilityGuard, CourantNumberOfAFluidStepOfSeveralIntervalsNamesFluidSolveEvery) {
  const auto why =
      unstable_step("fluid", 20, {"courant_max", "fluid_solved", "fluid_step_s"}, {1.5, 1, 2e-3}, limits());
  EXPECT_NE(why.find("fluid Courant number 1.5 at step 20"), std::string::npos) << why;
  EXPECT_NE(why.find("lower fluid.solve_every"), std::string::npos) << why;
  EXPECT_EQ(why.find("time.coupling_interval_s"), std::string::npos) << why;
}

TEST(StabilityGuard, OverlapAboveTheLimitIsNamedWithItsCure) {
  const auto why = unstable_step("particles", 7, {"max_overlap"}, {0.35}, limits());
  EXPECT_NE(why.find("cells overlap by 0.35 of a diameter at step 7"), std::string::npos) << why;
  EXPECT_NE(why.find("time.dem_steps_per_contact"), std::string::npos) << why;
}

TEST(StabilityGuard, NonFiniteValuesOfAnyNodeAreNamed) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const auto why = unstable_step("fluid", 4, {"courant_max", "mean_velocity_m_s"}, {0.1, nan}, limits());
  EXPECT_NE(why.find("fluid node reported mean_velocity_m_s = nan at step 4"), std::string::npos) << why;
  EXPECT_NE(unstable_step("particles", 4, {"total_force_z_N"}, {-inf}, limits()).find("-inf"), std::string::npos);
  // A NaN Courant number is not "within the limit" (every comparison with NaN is false).
  EXPECT_NE(unstable_step("fluid", 4, {"courant_max"}, {nan}, limits()), "");
}
