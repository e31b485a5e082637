// SPDX-License-Identifier: GPL-3.0-or-later
// An open vessel's feeder developed on its own first (vessel.feeder_develop_s,
// model/feeder_develop.h): the derived periodic scene is the feeder's tube with the open scene's
// blood, numerics and driving, and the open run's feeder and vessel start from its cells.
#include "minimal_scene.h"

#include <driving.h>
#include <feeder_develop.h>
#include <placement.h>
#include <scene.h>
#include <units.h>
#include <vessel_ends.h>

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

using namespace hemo;
using namespace hemo::particles;

namespace {

// An open straight vessel of 30 um with a feeder, the blood of scenes/bifurcation-30.toml.
constexpr const char* kOpenScene = R"(
[run]
name = "open"
seed = 7
max_courant = 3

[vessel]
diameter_um = 30
length_um = 60
ends = "open"
feeder_develop_s = 0.05

[mesh]
core_cells = 2
ring_cells = 2
axial_cells = 8

[driving]
wall_shear_rate_per_s = 799

[rbc]
hematocrit = 0.15

[platelet]
number_density_per_ul = 300000
mass_scaling = 60

[contact]
cell_youngs_modulus_Pa = 3.75e3

[time]
coupling_interval_s = 1e-4
coupling_steps = 1000
dem_steps_per_contact = 3

[output]
every_steps = 100
)";

Scene load_text(const std::string& text) { return load_scene(test::write_temp(text)); }

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The body force G = dP / (rho l) that drives a periodic vessel, or an open vessel's feeder.
double body_force(const Scene& s) { return driving_pressure_drop(s) / (s.plasma.density * s.vessel.length); }

}  // namespace

TEST(FeederDevelop, TheDerivedSceneIsTheFeedersPeriodicTubeWithTheScenesBlood) {
  const Scene open = load_text(kOpenScene);
  ASSERT_TRUE(develops_feeder(open));
  const FeederLayout feeder = feeder_layout(open);
  const Scene tube = load_text(feeder_develop_scene_text(open, kOpenScene));

  EXPECT_EQ(tube.vessel.shape, "straight");
  EXPECT_EQ(tube.vessel.ends, "periodic");
  EXPECT_EQ(tube.vessel.feeder_develop, 0);  // it develops nothing itself
  EXPECT_NEAR(tube.vessel.diameter, 2 * feeder.radius, 1e-12 * feeder.radius);
  EXPECT_NEAR(tube.vessel.length, feeder.period, 1e-12 * feeder.period);
  EXPECT_GT(feeder.period, open.vessel.length);  // the feeder's period, not the vessel's length
  EXPECT_EQ(tube.mesh.axial_cells, feeder.layers);
  EXPECT_EQ(tube.mesh.core_cells, open.mesh.core_cells);
  EXPECT_EQ(tube.mesh.ring_cells, open.mesh.ring_cells);
  // Driven as the feeder is: the same body force, hence the same wall shear rate in the same tube.
  EXPECT_NEAR(body_force(tube), body_force(open), 1e-12 * body_force(open));
  EXPECT_NEAR(tube.driving.wall_shear_rate, open.driving.wall_shear_rate, 1e-9 * open.driving.wall_shear_rate);
  // The blood, numerics and seed are the scene's.
  EXPECT_EQ(tube.run.seed, open.run.seed);
  EXPECT_EQ(tube.run.max_courant, open.run.max_courant);
  EXPECT_EQ(tube.rbc.hematocrit, open.rbc.hematocrit);
  EXPECT_EQ(tube.platelet.number_density, open.platelet.number_density);
  EXPECT_EQ(tube.platelet.mass_scaling, open.platelet.mass_scaling);
  EXPECT_EQ(tube.contact.cell_youngs_modulus, open.contact.cell_youngs_modulus);
  EXPECT_EQ(tube.time.coupling_interval, open.time.coupling_interval);
  EXPECT_EQ(tube.time.steps_per_contact, open.time.steps_per_contact);
  EXPECT_EQ(tube.output.every_steps, open.output.every_steps);
  // 0.05 s of 1e-4 s, its last step checkpointed (the scene's every 1000 does not divide 500).
  EXPECT_EQ(feeder_develop_steps(open), 500);
  EXPECT_EQ(tube.time.coupling_steps, 500);
  EXPECT_EQ(tube.output.checkpoint_every_steps, 500);
  EXPECT_EQ(tube.run.name, "open-feeder-develop");
  // As many cells as the open run's feeder is placed with: the same tube at the same blood.
  const auto placed = place_scene_particles(open, *make_vessel_wall(open.vessel), 0.0);
  long in_feeder = 0;
  for (const auto& p : placed) in_feeder += feeder.in_feeder(p.position.x());
  EXPECT_EQ(rbc_count(tube) + platelet_count(tube), in_feeder);
}

// scenes/bifurcation-30.toml's feeder: the O-grid of the inlet's equivalent diameter, layers of the
// snapped cubes, cells narrower than a red cell shared over the scene's kernel (which the derived
// O-grid scene accepts as the surface vessel's does).
TEST(FeederDevelop, TheBifurcationsFeederDevelopsAsAnOGridWithItsKernel) {
  const std::string path = std::string(HEMO_SCENES_DIR) + "/bifurcation-30.toml";
  Scene open = load_scene(path);
  open.vessel.feeder_develop = 0.2;
  const FeederLayout feeder = feeder_layout(open);
  const Scene tube = load_text(feeder_develop_scene_text(open, file_text(path)));
  EXPECT_NEAR(tube.vessel.diameter, 2 * feeder.radius, 1e-12 * feeder.radius);
  EXPECT_LT(std::abs(tube.vessel.diameter - open.vessel.diameter), 0.01 * open.vessel.diameter);  // faceted disc
  EXPECT_NEAR(tube.vessel.length, feeder.period, 1e-12 * feeder.period);
  EXPECT_EQ(tube.mesh.axial_cells, feeder.layers);
  EXPECT_EQ(tube.mesh.surface_cell_size, 0);
  EXPECT_EQ(tube.solid_fraction, open.solid_fraction);
  EXPECT_EQ(tube.kernel_width_diameters, open.kernel_width_diameters);
  EXPECT_NEAR(body_force(tube), body_force(open), 1e-12 * body_force(open));
  EXPECT_EQ(tube.time.coupling_steps, 2000);
  EXPECT_EQ(tube.output.checkpoint_every_steps, 1000);  // the scene's, which divides 2000
}

TEST(FeederDevelop, ADevelopTimeThatIsNoneIsRefusedNamingTheKey) {
  auto refused = [](const std::string& line, const std::string& ends = "open") {
    std::string text = kOpenScene;
    text.replace(text.find("feeder_develop_s = 0.05"), 23, line);
    text.replace(text.find("ends = \"open\""), 13, "ends = \"" + ends + "\"");
    try {
      load_text(text);
    } catch (const SceneError& e) {
      for (const auto& p : e.problems())
        if (p.key == "vessel.feeder_develop_s") return p.message;
      return std::string("refused, not for vessel.feeder_develop_s: ") + e.what();
    }
    return std::string("accepted");
  };
  EXPECT_NE(refused("feeder_develop_s = -0.1").find("must be in [0, 1000]"), std::string::npos);
  EXPECT_NE(refused("feeder_develop_s = nan").find("finite"), std::string::npos);
  EXPECT_NE(refused("feeder_develop_s = \"long\"").find("expected a number"), std::string::npos);
  EXPECT_NE(refused("feeder_develop_s = 0.1", "periodic").find("needs a feeder"), std::string::npos);
  std::string adaptive = kOpenScene;
  adaptive.replace(adaptive.find("dem_steps_per_contact = 3"), 25,
                   "dem_steps_per_contact = 3\ncoupling_relaxation_times = 20");
  try {
    load_text(adaptive);
    ADD_FAILURE() << "adaptive intervals with a developed feeder accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("fixed coupling intervals"), std::string::npos) << e.what();
  }
  EXPECT_EQ(refused("feeder_develop_s = 0"), "accepted");
  EXPECT_FALSE(develops_feeder(load_text(test::kMinimalScene)));
  EXPECT_THROW(feeder_develop_scene_text(load_text(test::kMinimalScene), test::kMinimalScene), std::invalid_argument);
}

// The vessel starts with copies of the feeder's cells that fit in it, each with its source's motion.
TEST(FeederDevelop, TheVesselsCopiesCarryTheirDevelopedSourcesMotion) {
  const Scene open = load_text(kOpenScene);
  const FeederLayout feeder = feeder_layout(open);
  const auto wall = make_vessel_wall(open.vessel);
  std::vector<PlacedParticle> cells(2);
  cells[0].diameter = cells[1].diameter = open.rbc.diameter;
  cells[0].position = Vec3(1e-6, -2e-6, 10e-6);   // in the vessel's length: copied
  cells[1].position = Vec3(0, 0, feeder.vessel_length + 10e-6);  // beyond it: the feeder's alone
  PlacedParticle::Motion m;
  m.velocity = Vec3(1e-5, 2e-5, 3e-3);
  m.angular_velocity = Vec3(4, 5, 6);
  m.orientation = Eigen::Vector4d(0.5, 0.5, 0.5, 0.5);
  m.angular_momentum = Vec3(7e-20, 8e-20, 9e-20);
  cells[0].motion = m;
  const auto filled = fill_open_vessel(cells, *wall, feeder, 0.0);
  ASSERT_EQ(filled.size(), 3u);
  EXPECT_DOUBLE_EQ(filled[0].position.x(), 1e-6 + feeder.axis_x);  // the feeder's own, on its axis
  EXPECT_DOUBLE_EQ(filled[2].position.x(), 1e-6 + feeder.inlet_x);  // the copy, on the inlet's
  EXPECT_EQ(filled[2].position.z(), filled[0].position.z());
  ASSERT_TRUE(filled[2].motion.has_value());
  EXPECT_EQ(filled[2].motion->velocity, m.velocity);
  EXPECT_EQ(filled[2].motion->angular_velocity, m.angular_velocity);
  EXPECT_EQ(filled[2].motion->orientation, m.orientation);
  EXPECT_EQ(filled[2].motion->angular_momentum, m.angular_momentum);
  EXPECT_FALSE(filled[1].motion.has_value());
}
