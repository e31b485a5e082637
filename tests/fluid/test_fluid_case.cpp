// Unit tests of the fluid node's scene settings and case writer.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "fluid_case.h"

#include <filesystem>

namespace {

hemo::Scene paper_scene() {
  hemo::Scene s;
  s.vessel = {100e-6, 600e-6};
  s.driving.wall_shear_rate = 799;
  s.rbc.present = true;
  s.rbc.diameter = 5.56e-6;
  s.platelet.present = true;
  s.platelet.diameter = 2.66e-6;
  return s;
}

TEST(FluidCase, PressureDropFromWallShearRate) {
  const auto s = paper_scene();
  // dP = 4 mu l gamma / d
  EXPECT_NEAR(hemo::driving_pressure_drop(s), 4 * 1.2e-3 * 600e-6 * 799 / 100e-6, 1e-12);
  auto t = s;
  t.driving.wall_shear_rate = 0;
  t.driving.pressure_drop = 10;
  EXPECT_DOUBLE_EQ(hemo::driving_pressure_drop(t), 10);
  t.driving.wall_shear_rate = 5;
  EXPECT_DOUBLE_EQ(hemo::driving_pressure_drop(t), 10);
  t.driving.pressure_drop = 0;
  t.driving.wall_shear_rate = 0;
  EXPECT_DOUBLE_EQ(hemo::driving_pressure_drop(t), 0);  // no driving: flow from sources only
  t.driving.pressure_drop = -1;
  EXPECT_THROW(hemo::driving_pressure_drop(t), std::invalid_argument);
}

TEST(FluidCase, SettingsAndPoiseuille) {
  const auto s = paper_scene();
  const auto f = hemo::fluid_settings(s);
  EXPECT_DOUBLE_EQ(f.kinematic_viscosity, 1.2e-3 / 1025);
  EXPECT_NEAR(f.body_force, f.pressure_drop / (1025 * 600e-6), 1e-12);
  EXPECT_DOUBLE_EQ(f.largest_particle_diameter, 5.56e-6);
  // The wall shear rate of the analytic profile is the one asked for.
  const double R = 50e-6, h = 1e-9;
  const double rate = -(hemo::poiseuille_velocity(f, s.vessel, R) - hemo::poiseuille_velocity(f, s.vessel, R - h)) / h;
  EXPECT_NEAR(rate, 799, 0.02);  // one-sided difference: error 799 h / (2R)
  EXPECT_DOUBLE_EQ(hemo::poiseuille_velocity(f, s.vessel, R), 0);
}

TEST(FluidCase, RefusesAMeshFinerThanTheParticles) {
  const auto s = paper_scene();
  const auto paper = hemo::make_vessel_mesh(s.vessel, s.mesh);
  EXPECT_FALSE(hemo::unresolved_mesh_problem(hemo::compute_geometry(paper), 5.56e-6));
  const auto fine = hemo::make_vessel_mesh(s.vessel, hemo::MeshSpec{16, 12, 100});
  const auto problem = hemo::unresolved_mesh_problem(hemo::compute_geometry(fine), 5.56e-6);
  ASSERT_TRUE(problem);
  EXPECT_NE(problem->find("mesh too fine"), std::string::npos);
  EXPECT_EQ(problem->find('\n'), std::string::npos) << "one line";
}

TEST(FluidCase, WritesTheCase) {
  const auto s = paper_scene();
  const auto f = hemo::fluid_settings(s);
  const auto mesh = hemo::make_vessel_mesh(s.vessel, hemo::MeshSpec{2, 1, 2});
  const auto dir = std::filesystem::temp_directory_path() / "hemocosim_test_case";
  std::filesystem::remove_all(dir);
  hemo::write_case(dir.string(), f, s.vessel, mesh, hemo::compute_geometry(mesh), hemo::InitialFlow::poiseuille);
  for (const char* p :
       {"system/controlDict", "system/fvSchemes", "system/fvSolution", "0/U", "0/p", "constant/polyMesh/boundary"})
    EXPECT_TRUE(std::filesystem::exists(dir / p)) << p;
  std::filesystem::remove_all(dir);
}

}  // namespace
