// Unit tests of the fluid node's scene settings and case writer.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "fluid_case.h"

#include <filesystem>
#include <fstream>
#include <sstream>

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

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The written fvSolution of a scene: its PISO and solver entries as OpenFOAM reads them.
std::string written_fv_solution(const hemo::FluidSolver& solver) {
  auto f = hemo::fluid_settings(paper_scene());
  f.solver = solver;
  const auto s = paper_scene();
  const auto mesh = hemo::make_vessel_mesh(s.vessel, hemo::MeshSpec{2, 1, 2});
  const auto dir = std::filesystem::temp_directory_path() / "hemocosim_test_fv_solution";
  std::filesystem::remove_all(dir);
  hemo::write_case(dir.string(), f, s.vessel, mesh, hemo::compute_geometry(mesh), hemo::InitialFlow::poiseuille);
  const std::string text = read_text(dir / "system" / "fvSolution");
  std::filesystem::remove_all(dir);
  return text;
}

// The entry `name value;` within the sub-dictionary that starts at `block` (e.g. "    U\n    {").
std::string entry_in(const std::string& text, const std::string& block, const std::string& name) {
  const auto start = text.find(block);
  if (start == std::string::npos) return "(no block " + block + ")";
  const auto end = text.find('}', start);
  std::istringstream lines(text.substr(start, end - start));
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    std::string key, value;
    words >> key >> value;
    if (key == name) return value;
  }
  return "(no " + name + ")";
}

// fluid.non_orthogonal_correctors, velocity_relative_tolerance and momentum_predictor reach the
// case's fvSolution; by default it says what it said before they were keys (1, 0, yes).
TEST(FluidCase, SolverKeysReachFvSolution) {
  const std::string defaults = written_fv_solution(hemo::FluidSolver{});
  EXPECT_EQ(entry_in(defaults, "PISO\n{", "nNonOrthogonalCorrectors"), "1;");
  EXPECT_EQ(entry_in(defaults, "PISO\n{", "momentumPredictor"), "yes;");
  EXPECT_EQ(entry_in(defaults, "    U\n    {", "relTol"), "0;");
  EXPECT_EQ(entry_in(defaults, "    U\n    {", "tolerance"), "9.9999999999999998e-13;");

  hemo::FluidSolver loose;
  loose.non_orthogonal_correctors = 0;
  loose.velocity_relative_tolerance = 0.05;
  loose.velocity_tolerance = 1e-6;
  loose.momentum_predictor = false;
  loose.pressure_solver = "GAMG";
  const std::string text = written_fv_solution(loose);
  EXPECT_EQ(entry_in(text, "PISO\n{", "nNonOrthogonalCorrectors"), "0;");
  EXPECT_EQ(entry_in(text, "PISO\n{", "momentumPredictor"), "no;");
  EXPECT_EQ(entry_in(text, "    U\n    {", "relTol"), "0.050000000000000003;");
  EXPECT_EQ(entry_in(text, "    U\n    {", "tolerance"), "9.9999999999999995e-07;");
  EXPECT_EQ(entry_in(text, "    p\n    {", "solver"), "GAMG;");
  // pFinal keeps relTol 0 whatever p's is: the last corrector solves to the tolerance.
  EXPECT_EQ(entry_in(text, "    pFinal\n    {", "relTol"), "0;");
}

}  // namespace
