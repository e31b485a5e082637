// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_timing.h"

#include "calibration_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace hemo::particles;

using hemo::test::calibration_scene;

TEST(DemTiming, StepFromTheCalibrationScene) {
  hemo::Scene s = calibration_scene();
  const auto t = derive_dem_timing(s, 1e-5);
  // Contacts last about a microsecond; the platelet-wall one is the shortest.
  EXPECT_GT(t.contact_time, 0.5e-6);
  EXPECT_LT(t.contact_time, 3e-6);
  EXPECT_EQ(t.limiting, "platelet-wall");
  EXPECT_LE(t.dt, t.contact_time / s.time.steps_per_contact * (1 + 1e-12));
  EXPECT_EQ(t.substeps, static_cast<int>(std::ceil(1e-5 / (t.contact_time / s.time.steps_per_contact))));
  EXPECT_NEAR(t.dt * t.substeps, 1e-5, 1e-18);
  EXPECT_GT(t.dt, t.relaxation_time / 10);  // drag relaxation does not limit the step
  EXPECT_FALSE(t.relaxation_limited);
  const auto fixed = derive_dem_timing(s, 1e-5, 25);
  EXPECT_EQ(fixed.substeps, 25);
  EXPECT_NEAR(fixed.dt, 4e-7, 1e-20);
}

TEST(DemTiming, RelaxationTimeOfTheDragClosuresCanBoundTheStep) {
  hemo::Scene s = calibration_scene();
  s.rbc.drag = "rbc_fit";
  s.platelet.drag = "oblate";
  s.platelet.semi_axis_a = 2.06e-6;
  s.platelet.semi_axis_c = 0.52e-6;
  const auto free = derive_dem_timing(s, 1e-5);
  // The platelet broadside-on: tau = m / (3 pi mu d K_0), K_0(0.252) = 1.374.
  const double tau = 8.79e-15 / (3 * 3.14159265358979 * 1.2e-3 * 2.66e-6 * 1.3745);
  EXPECT_NEAR(free.relaxation_time, tau, 0.002 * tau);
  s.time.relaxation_factor = 0.5;
  const auto bound = derive_dem_timing(s, 1e-5);
  EXPECT_TRUE(bound.relaxation_limited);
  EXPECT_LE(bound.dt, 0.5 * tau * 1.002);
  EXPECT_GT(bound.substeps, free.substeps);
  s.time.relaxation_factor = 100;  // looser than the contact bound: no effect
  EXPECT_EQ(derive_dem_timing(s, 1e-5).substeps, free.substeps);
  s.time.steps_per_contact = 20;
  EXPECT_GE(derive_dem_timing(s, 1e-5).substeps, 2 * free.substeps - 1);
}

// time.mass_scaling = s: Hertz's t_c ~ m*^(2/5), so every contact time grows by s^(2/5) and the DEM
// step with it; the drag relaxation time m / beta grows by s. Nothing else changes.
TEST(DemTiming, MassScalingStretchesContactTimeByItsTwoFifthPower) {
  hemo::Scene s = calibration_scene();
  const auto physical = derive_dem_timing(s, 1e-4);
  for (double scaling : {10.0, 100.0, 1000.0}) {
    s.time.mass_scaling = scaling;
    const auto scaled = derive_dem_timing(s, 1e-4);
    EXPECT_NEAR(scaled.contact_time, physical.contact_time * std::pow(scaling, 0.4), 1e-12 * scaled.contact_time);
    EXPECT_NEAR(scaled.relaxation_time, physical.relaxation_time * scaling, 1e-12 * scaled.relaxation_time);
    EXPECT_EQ(scaled.limiting, physical.limiting);
    EXPECT_EQ(scaled.substeps, static_cast<int>(std::ceil(1e-4 / (scaled.contact_time / s.time.steps_per_contact))));
    EXPECT_EQ(dem_scene(s).platelet.mass, scaling * s.platelet.mass);
    EXPECT_EQ(dem_scene(s).rbc.mass, scaling * s.rbc.mass);
    EXPECT_EQ(dem_scene(s).rbc.diameter, s.rbc.diameter);
  }
}

// A species' own mass_scaling overrides time.mass_scaling for it alone. The platelets' contacts
// are the shortest; scaled 60x against the red cells' 10x, the red cell on the wall limits the
// step instead, with the contact time it has when only the red cells are scaled 10x.
TEST(DemTiming, PlateletMassScalingHandsTheStepToTheRedCells) {
  hemo::Scene s = calibration_scene();
  s.time.mass_scaling = 10;
  const auto together = derive_dem_timing(s, 1e-4);
  EXPECT_EQ(together.limiting, "platelet-wall");
  s.platelet.mass_scaling = 60;
  const auto apart = derive_dem_timing(s, 1e-4);
  EXPECT_EQ(dem_scene(s).platelet.mass, 60 * s.platelet.mass);
  EXPECT_EQ(dem_scene(s).rbc.mass, 10 * s.rbc.mass);
  EXPECT_EQ(apart.limiting, "rbc-wall");
  hemo::Scene red_only = s;
  red_only.platelet.present = false;
  EXPECT_NEAR(apart.contact_time, derive_dem_timing(red_only, 1e-4).contact_time, 1e-12 * apart.contact_time);
  // rbc-wall against platelet-wall at equal scaling: (m_rbc r_plt / (m_plt r_rbc))^(2/5) ~ 1.96
  EXPECT_GT(apart.contact_time, 1.9 * together.contact_time);
  EXPECT_LT(apart.substeps, together.substeps / 1.9);
  // Set back to 0, a species follows time.mass_scaling again.
  s.platelet.mass_scaling = 0;
  EXPECT_EQ(dem_scene(s).platelet.mass, 10 * s.platelet.mass);
}

