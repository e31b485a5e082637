// Scenes: units are converted once, unknown keys and impossible values are refused with their line.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "scene.h"
#include "test_helpers.h"
#include "units.h"

#include <gtest/gtest.h>

#include <map>
#include <set>

using namespace hemo;

namespace {
const char* kMinimal = R"(
[vessel]
diameter_um = 100
length_um = 600

[driving]
wall_shear_rate_per_s = 799
)";

std::vector<SceneProblem> problems_of(const std::string& text) {
  try {
    load_scene(test::write_temp(text));
  } catch (const SceneError& e) {
    return e.problems();
  }
  return {};
}
}  // namespace

TEST(Scene, MinimalSceneTakesModelDefaultsInSI) {
  const Scene s = load_scene(test::write_temp(kMinimal));
  EXPECT_DOUBLE_EQ(s.vessel.diameter, 100e-6);
  EXPECT_DOUBLE_EQ(s.vessel.length, 600e-6);
  EXPECT_EQ(s.mesh.cells(), 1536);  // the paper's mesh
  EXPECT_DOUBLE_EQ(s.plasma.viscosity, 1.2e-3);
  // dP = 4 mu l gamma / d
  EXPECT_NEAR(s.driving.pressure_drop, 4 * 1.2e-3 * 600e-6 * 799 / 100e-6, 1e-12);
  EXPECT_NEAR(s.rbc.volume, 90e-18, 1e-30);
  EXPECT_NEAR(s.platelet.mass, 8.79e-15, 1e-27);
  EXPECT_FALSE(s.rbc.present);
}

TEST(Scene, PressureDropGivesTheWallShearRate) {
  const Scene s = load_scene(test::write_temp(R"(
[vessel]
diameter_um = 100
length_um = 600
[driving]
pressure_drop_Pa = 23.0112
)"));
  EXPECT_NEAR(s.driving.wall_shear_rate, 799, 1e-9);
}

TEST(Scene, UnknownKeyIsNamedWithItsLine) {
  auto ps = problems_of(std::string(kMinimal) + "\n[vessel2]\nx = 1\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "vessel2");
  EXPECT_EQ(ps[0].message, "unknown key");
  ps = problems_of(R"(
[vessel]
diameter_um = 100
lenght_um = 600
length_um = 600
[driving]
wall_shear_rate_per_s = 799
)");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "vessel.lenght_um");
  EXPECT_EQ(ps[0].line, 4);
}

TEST(Scene, ImpossibleValuesAreAllReported) {
  auto ps = problems_of(R"(
[run]
max_restarts = -1
[vessel]
diameter_um = -5
length_um = 600
[driving]
wall_shear_rate_per_s = 799
pressure_drop_Pa = 3
[rbc]
hematocrit = 0.9
[time]
coupling_steps = 0
mass_scaling = 0.5
[platelet]
mass_scaling = 0.5
)");
  std::set<std::string> keys;
  for (auto& p : ps) keys.insert(p.key);
  EXPECT_TRUE(keys.count("time.mass_scaling"));
  EXPECT_TRUE(keys.count("platelet.mass_scaling"));
  EXPECT_TRUE(keys.count("vessel.diameter_um"));
  EXPECT_TRUE(keys.count("driving"));
  EXPECT_TRUE(keys.count("rbc.hematocrit"));
  EXPECT_TRUE(keys.count("time.coupling_steps"));
  EXPECT_TRUE(keys.count("run.max_restarts"));
}

TEST(Scene, WrongTypeAndSyntaxErrorsAreProblemsNotCrashes) {
  auto ps = problems_of(std::string(kMinimal) + "[mesh]\naxial_cells = \"many\"\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "mesh.axial_cells");
  ps = problems_of("[vessel\ndiameter_um = 1\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_GT(ps[0].line, 0);
}

TEST(Scene, ClosuresShapeDepositionAndTimingKeysHaveModelDefaults) {
  const Scene s = load_scene(test::write_temp(kMinimal));
  EXPECT_EQ(s.rbc.drag, "rbc_fit");
  EXPECT_EQ(s.rbc.lift, "rbc_lift");
  EXPECT_EQ(s.rbc.torque, "none");
  EXPECT_EQ(s.platelet.drag, "oblate");
  EXPECT_EQ(s.platelet.lift, "oblate");
  EXPECT_EQ(s.platelet.torque, "oblate");
  EXPECT_NEAR(s.platelet.semi_axis_a, 2.06e-6, 1e-18);
  EXPECT_NEAR(s.platelet.semi_axis_c, 0.52e-6, 1e-18);
  EXPECT_EQ(s.platelet.orientation_integrator, "splitting");
  EXPECT_EQ(s.solid_fraction, "sphere_overlap");
  EXPECT_EQ(s.implicit_drag, "interval_response");
  EXPECT_TRUE(s.return_held_back_momentum);
  EXPECT_EQ(s.time.steps_per_contact, 10);
  EXPECT_EQ(s.time.relaxation_factor, 0);
  EXPECT_EQ(s.gravity.z, 0);

  const Scene t = load_scene(test::write_temp(std::string(kMinimal) + R"(
[platelet]
drag = "schiller_naumann"
lift = "shear_lift"
torque = "none"
semi_axis_a_um = 2
semi_axis_c_um = 1
orientation_integrator = "euler"
mass_scaling = 60
[coupling]
solid_fraction = "centre_cell"
scheme = "parallel"
implicit_drag = "instantaneous"
return_held_back_momentum = false
[gravity]
z_m_s2 = -9.81
[time]
dem_steps_per_contact = 20
dem_step_max_relaxation_times = 2
mass_scaling = 10
)"));
  EXPECT_EQ(s.platelet.mass_scaling, 0);  // unset: time.mass_scaling's
  EXPECT_EQ(t.platelet.mass_scaling, 60);
  EXPECT_EQ(t.rbc.mass_scaling, 0);
  EXPECT_EQ(t.time.mass_scaling, 10);
  EXPECT_EQ(t.platelet.drag, "schiller_naumann");
  EXPECT_EQ(t.platelet.lift, "shear_lift");
  EXPECT_DOUBLE_EQ(t.platelet.semi_axis_c, 1e-6);
  EXPECT_EQ(t.platelet.orientation_integrator, "euler");
  EXPECT_EQ(t.solid_fraction, "centre_cell");
  EXPECT_EQ(s.coupling_scheme, "serial");
  EXPECT_EQ(t.coupling_scheme, "parallel");
  EXPECT_EQ(t.implicit_drag, "instantaneous");
  EXPECT_FALSE(t.return_held_back_momentum);
  EXPECT_DOUBLE_EQ(t.gravity.z, -9.81);
  EXPECT_EQ(t.time.steps_per_contact, 20);
  EXPECT_EQ(t.time.relaxation_factor, 2);
}

TEST(Scene, UnknownClosureNamesAndImpossibleShapesAreNamed) {
  auto ps = problems_of(std::string(kMinimal) + R"(
[rbc]
hematocrit = 0.1
lift = "oblate"
[platelet]
drag = "saffman"
semi_axis_c_um = 3
[coupling]
solid_fraction = "kernel"
implicit_drag = "explicit"
)");
  std::map<std::string, std::string> by_key;
  for (auto& p : ps) by_key[p.key] = p.message;
  EXPECT_NE(by_key["rbc.lift"].find("platelets"), std::string::npos) << by_key["rbc.lift"];
  EXPECT_NE(by_key["platelet.drag"].find("known: stokes, rbc_fit"), std::string::npos) << by_key["platelet.drag"];
  EXPECT_TRUE(by_key.count("platelet.semi_axis_c_um"));
  EXPECT_TRUE(by_key.count("coupling.solid_fraction"));
  EXPECT_NE(by_key["coupling.implicit_drag"].find("interval_response"), std::string::npos);
  EXPECT_NE(by_key["coupling.implicit_drag"].find("co_relaxed"), std::string::npos);
  EXPECT_TRUE(problems_of(std::string(kMinimal) + "[coupling]\nimplicit_drag = \"co_relaxed\"\n").empty());
}

TEST(Scene, ShippedScenesAreValid) {
  for (const char* name : {"quickstart.toml", "calibration.toml"}) {
    EXPECT_NO_THROW(load_scene(std::string(HEMO_SCENES_DIR) + "/" + name)) << name;
  }
}

// docs/scenes.md lists every key the code reads, with the default the code uses.
TEST(Scene, DocumentationListsEveryKeyWithItsDefault) {
  std::ifstream in(std::string(HEMO_SCENES_DIR) + "/../docs/scenes.md");
  ASSERT_TRUE(in);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string doc = ss.str();
  const auto keys = scene_keys();
  ASSERT_GT(keys.size(), 40u);
  for (const auto& k : keys)
    EXPECT_NE(doc.find("| `" + k.key + "` | " + k.default_value + " |"), std::string::npos)
        << k.key << " = " << k.default_value << " is not in docs/scenes.md: regenerate with hemocosim check --keys";
}

TEST(Scene, MissingRequiredKeyIsOneProblem) {
  auto ps = problems_of("[driving]\nwall_shear_rate_per_s = 799\n[vessel]\nlength_um = 60\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "vessel.diameter_um");
  EXPECT_EQ(ps[0].message, "missing");
}
