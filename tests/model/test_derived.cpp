// SPDX-License-Identifier: GPL-3.0-or-later
// The physics model/ derives from a scene, each relation written once (driving.h, dem_step.h),
// and the closure names a scene validates against (closure_names.h): the formulas, and that
// scene loading and `hemocosim check`'s work estimate take their figures from these very
// functions, to the bit.
#include "calibration_scene.h"
#include "minimal_scene.h"

#include <closure_names.h>
#include <dem_step.h>
#include <driving.h>
#include <momentum_balance.h>
#include <scene.h>
#include <units.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

using namespace hemo;
using namespace hemo::particles;

namespace {
using test::calibration_scene;

Scene load_text(const std::string& text) { return load_scene(test::write_temp(text)); }
}  // namespace

// The paper's vessel: 799 1/s in plasma of 1.2 mPa s over 600 um of a 100 um tube is 23.0112 Pa.
TEST(Driving, PressureDropAndWallShearRateAreInverse) {
  const double d = 100e-6, l = 600e-6, mu = 1.2e-3;
  EXPECT_NEAR(pressure_drop_of(799, d, mu, l), 23.0112, 1e-9);
  EXPECT_NEAR(wall_shear_rate_of(d, 23.0112, mu, l), 799, 1e-9);
  for (const double g : {1.0, 799.0, 2.5e4})
    EXPECT_NEAR(wall_shear_rate_of(d, pressure_drop_of(g, d, mu, l), mu, l), g, 1e-12 * g);
  // tau_w = mu gamma_w, to rounding.
  EXPECT_NEAR(wall_shear_stress_of(d, 23.0112, l), mu * 799, 1e-12);
}

// An open vessel's inlet takes Poiseuille's flow rate of the scene's wall shear rate in the nominal
// tube: the paper's 799 1/s in a 100 um tube is pi (50 um)^3 799 / 4 = 7.844e-11 m^3/s (4.7 uL/min),
// and its mean velocity Q / (pi R^2) is gamma_w d / 8.
TEST(Driving, TheOpenInletsFlowRateIsPoiseuillesOfTheWallShearRate) {
  const double R = 50e-6;
  EXPECT_NEAR(flow_rate_of(R, 799), 7.84416e-11, 1e-16);
  EXPECT_NEAR(flow_rate_of(R, 799) / (units::pi * R * R), 799 * 2 * R / 8, 1e-15);
  const Scene s = load_text(test::kMinimalScene);
  EXPECT_EQ(nominal_flow_rate(s), flow_rate_of(s.vessel.radius(), s.driving.wall_shear_rate));
  // The same through the pressure drop: Poiseuille's dP = 8 mu Q l / (pi R^4).
  EXPECT_NEAR(8 * s.plasma.viscosity * nominal_flow_rate(s) * s.vessel.length / (units::pi * std::pow(R, 4)),
              s.driving.pressure_drop, 1e-12 * s.driving.pressure_drop);
}

// load_scene fills the driving it was not given from the one it was, through these functions.
TEST(Driving, SceneLoadingUsesTheRelation) {
  const Scene by_shear = load_text(test::kMinimalScene);
  EXPECT_EQ(by_shear.driving.wall_shear_rate, 799);
  EXPECT_EQ(by_shear.driving.pressure_drop,
            pressure_drop_of(799, by_shear.vessel.diameter, by_shear.plasma.viscosity, by_shear.vessel.length));
  const Scene by_dp = load_text("[vessel]\ndiameter_um = 100\nlength_um = 600\n[driving]\npressure_drop_Pa = 23\n");
  EXPECT_EQ(by_dp.driving.pressure_drop, 23);
  EXPECT_EQ(by_dp.driving.wall_shear_rate,
            wall_shear_rate_of(by_dp.vessel.diameter, 23, by_dp.plasma.viscosity, by_dp.vessel.length));
  EXPECT_EQ(wall_shear_rate(by_dp), by_dp.driving.wall_shear_rate);
  EXPECT_EQ(driving_pressure_drop(by_shear), by_shear.driving.pressure_drop);
  EXPECT_EQ(imposed_wall_shear_stress(by_dp), wall_shear_stress_of(100e-6, 23, 600e-6));
}

// A scene built in code: the rate given wins, else it follows from the drop, else there is none.
TEST(Driving, WallShearRateOfASceneBuiltInCode) {
  Scene s;
  s.vessel.diameter = 100e-6;
  s.vessel.length = 600e-6;
  EXPECT_EQ(wall_shear_rate(s), 0);
  EXPECT_EQ(driving_pressure_drop(s), 0);
  s.driving.pressure_drop = 4 * s.plasma.viscosity * s.vessel.length * 799 / s.vessel.diameter;
  EXPECT_NEAR(wall_shear_rate(s), 799, 1e-9);
  s.driving.wall_shear_rate = 500;  // given: taken as it is
  EXPECT_EQ(wall_shear_rate(s), 500);
  EXPECT_EQ(driving_pressure_drop(s), s.driving.pressure_drop);  // the drop wins
  s.driving = {};
  s.driving.wall_shear_rate = 799;
  EXPECT_NEAR(driving_pressure_drop(s), 23.0112, 1e-9);
  s.driving.wall_shear_rate = -1;
  EXPECT_THROW(driving_pressure_drop(s), std::invalid_argument);
}

TEST(Driving, VesselVolume) {
  Vessel v;
  v.diameter = 100e-6;
  v.length = 600e-6;
  EXPECT_NEAR(vessel_volume(v), units::pi * 50e-6 * 50e-6 * 600e-6, 1e-24);
}

TEST(DemStep, HertzContactTimeFormula) {
  // Two equal spheres: m* = m/2, R* = r/2, E* = E / (2 (1 - nu^2)).
  const double m = 1e-13, r = 3e-6, e = 7.5e5, nu = 0.45, v = 4e-3;
  const double ms = m / 2, rs = r / 2, es = e / (2 * (1 - nu * nu));
  EXPECT_NEAR(hertz_contact_time(m, r, e, nu, m, r, e, nu, v), 2.87 * std::pow(ms * ms / (rs * es * es * v), 0.2),
              1e-18);
  const double inf = std::numeric_limits<double>::infinity();
  const double ew = 7.5e7, nuw = 0.18;
  const double esw = 1 / ((1 - nu * nu) / e + (1 - nuw * nuw) / ew);
  EXPECT_NEAR(hertz_contact_time(m, r, e, nu, inf, inf, ew, nuw, v), 2.87 * std::pow(m * m / (r * esw * esw * v), 0.2),
              1e-18);
}

// The shortest of the pairs and walls, at the shear velocity of the larger particle of each pair.
TEST(DemStep, ShortestContactTimeIsTheMinimumOverTheContacts) {
  const Scene s = calibration_scene();
  const auto& c = s.contact;
  const double inf = std::numeric_limits<double>::infinity();
  const double mr = s.rbc.mass, rr = s.rbc.diameter / 2, mp = s.platelet.mass, rp = s.platelet.diameter / 2;
  const double e = c.cell_youngs_modulus, nu = c.cell_poisson_ratio, ew = c.wall_youngs_modulus,
               nuw = c.wall_poisson_ratio, g = 799;
  const double times[] = {hertz_contact_time(mr, rr, e, nu, mr, rr, e, nu, g * 2 * rr),
                          hertz_contact_time(mr, rr, e, nu, mp, rp, e, nu, g * 2 * rr),
                          hertz_contact_time(mr, rr, e, nu, inf, inf, ew, nuw, g * 2 * rr),
                          hertz_contact_time(mp, rp, e, nu, mp, rp, e, nu, g * 2 * rp),
                          hertz_contact_time(mp, rp, e, nu, inf, inf, ew, nuw, g * 2 * rp)};
  double shortest = inf;
  for (const double t : times) shortest = std::min(shortest, t);
  const ContactTime t = shortest_contact_time(s, g);
  EXPECT_EQ(t.time, shortest);
  EXPECT_EQ(t.time, times[4]);
  EXPECT_EQ(t.limiting, "platelet-wall");
  // Without driving, 1 mm/s stands in for the impact velocity.
  Scene rbc_only = s;
  rbc_only.platelet.present = false;
  EXPECT_EQ(shortest_contact_time(rbc_only, 0).time,
            std::min(hertz_contact_time(mr, rr, e, nu, mr, rr, e, nu, 1e-3),
                     hertz_contact_time(mr, rr, e, nu, inf, inf, ew, nuw, 1e-3)));
  Scene none = s;
  none.rbc.present = none.platelet.present = false;
  EXPECT_EQ(shortest_contact_time(none, g).time, inf);
  EXPECT_EQ(shortest_contact_time(none, g).limiting, "");
}

TEST(DemStep, SubstepsResolveTheStep) {
  EXPECT_EQ(dem_substeps(1e-5, 1e-6), 10);  // 1e-5 / 1e-6 is a rounding error above 10: still 10
  EXPECT_EQ(dem_substeps(1e-5, 3e-6), 4);
  EXPECT_EQ(dem_substeps(1e-7, 1e-6), 1);  // at least one
}

TEST(DemStep, DemSceneScalesTheMasses) {
  Scene s = calibration_scene();
  s.time.mass_scaling = 10;
  s.platelet.mass_scaling = 60;
  const Scene d = dem_scene(s);
  EXPECT_EQ(d.rbc.mass, s.rbc.mass * 10);
  EXPECT_EQ(d.platelet.mass, s.platelet.mass * 60);
}

// `hemocosim check`'s estimate is the particle node's contact time and substep rule.
TEST(DemStep, WorkEstimateUsesTheContactTimeAndSubsteps) {
  const Scene s = load_text(std::string(test::kMinimalScene) +
                            "[rbc]\nhematocrit = 0.1\n[platelet]\nnumber_density_per_ul = 1e5\n[time]\nmass_scaling = 4\n");
  const WorkEstimate w = estimate_work(s);
  const double tc = shortest_contact_time(dem_scene(s), s.driving.wall_shear_rate).time;
  EXPECT_EQ(w.contact_time, tc);
  EXPECT_EQ(w.substeps, dem_substeps(s.time.coupling_interval, tc / s.time.steps_per_contact));
  EXPECT_GE(w.substeps, 1);
  EXPECT_EQ(w.particles, 0.1 * vessel_volume(s.vessel) / s.rbc.volume + s.platelet.number_density * vessel_volume(s.vessel));
}

// Each slot's names are unique and in byte order (the order of every list of closure names,
// messages included), and the string lists are the registration's.
TEST(ClosureNames, RegisteredOnceInByteOrder) {
  const std::vector<std::string>* lists[] = {&known_drag_closures(), &known_lift_closures(), &known_torque_closures()};
  for (const auto* names : lists) {
    ASSERT_FALSE(names->empty());
    for (std::size_t i = 1; i < names->size(); ++i) EXPECT_LT((*names)[i - 1], (*names)[i]);
  }
  EXPECT_EQ(known_drag_closures(), std::vector<std::string>(kDragClosureNames.begin(), kDragClosureNames.end()));
  EXPECT_EQ(known_lift_closures(), std::vector<std::string>(kLiftClosureNames.begin(), kLiftClosureNames.end()));
  EXPECT_EQ(known_torque_closures(), std::vector<std::string>(kTorqueClosureNames.begin(), kTorqueClosureNames.end()));
  constexpr std::string_view table[] = {"none", "oblate"};
  static_assert(same_closure_names(table, kTorqueClosureNames));
  constexpr std::string_view other[] = {"none", "oblate", "new_one"};
  static_assert(!same_closure_names(other, kTorqueClosureNames));
}

// A scene naming a closure the model does not register is refused, offering the registered names.
TEST(ClosureNames, SceneRefusesAnUnregisteredName) {
  try {
    load_text(std::string(test::kMinimalScene) + "[platelet]\nnumber_density_per_ul = 1e5\ndrag = \"no_such\"\n");
    FAIL() << "loaded";
  } catch (const SceneError& e) {
    ASSERT_EQ(e.problems().size(), 1u);
    EXPECT_EQ(e.problems()[0].key, "platelet.drag");
    EXPECT_NE(e.problems()[0].message.find("known: oblate, rbc_fit, schiller_naumann, stokes"), std::string::npos)
        << e.problems()[0].message;
  }
}
