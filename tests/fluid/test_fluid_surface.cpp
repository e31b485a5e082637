// Verification of surface vessels (docs/design.md, "Surface vessels"): the real hemocosim-fluid
// under the coordinator, plasma alone (hemocosim-prescribed-particles --mode none), on the small
// Y bifurcation meshed by snappyHexMesh (D_p = 30 um, L_p = L_d = 60 um, 60 degrees, cubes of
// 2.5 um: ~5,000 cells), the parent's inlet taking the nominal tube's Q (gamma_w = 799 1/s:
// Re = U d / nu = 0.08) as a fixed parabola, both outlets p = 0; 40 steps of 0.1 ms (20 viscous
// times R_p^2 / nu: steady). The flow split between the daughters against the Poiseuille network:
// both outlets at p = 0 behind one junction, Q_1 / Q_2 = R_2 / R_1 with R_i = 8 mu L_i / (pi r_i^4).
// Every number asserted is printed.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_run.h"

#include <driving.h>
#include <scene.h>
#include <vessel_ends.h>

#include <fmt/format.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

using namespace hemo::fluidtest;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRp = 15e-6, kLp = 60e-6, kLd = 60e-6, kGamma = 799;

struct Split {
  double q = 0, q_in = 0, q1 = 0, q2 = 0;  // m^3/s: asked, through the inlet, through each outlet
  double seconds = 0;
  std::string dir;
  double ratio() const { return q1 / q2; }
};

// The small bifurcation's scene; `daughters`: more [vessel] keys (their diameters).
SceneSpec bifurcation_spec(const std::string& name, const std::string& daughters, const std::string& inlet) {
  SceneSpec s;
  s.name = name;
  s.diameter_um = 2 * kRp * 1e6;
  s.length_um = kLp * 1e6;
  s.vessel =
      "shape = \"bifurcation\"\nends = \"open\"\ninlet = \"" + inlet + "\"\ndaughter_length_um = 60\n" + daughters;
  s.mesh = "surface_cell_size_um = 2.5";
  s.dt = 1e-4;
  s.steps = 40;
  s.particle_command = bin("hemocosim-prescribed-particles") + " --mode none --record state.csv";
  return s;
}

Split run_bifurcation(const std::string& name, const std::string& daughters, const std::string& inlet = "poiseuille") {
  const SceneSpec s = bifurcation_spec(name, daughters, inlet);
  const auto r = run_scene(s);
  EXPECT_EQ(r.command.exit_code, 0) << r.command.output;
  const Metrics m = read_metrics(r.dir);
  Split out;
  out.q = kPi * kRp * kRp * kRp * kGamma / 4;
  out.q_in = last(m, "fluid", "inlet_plasma_flux_m3_s");
  out.q1 = last(m, "fluid", "outlet_1_plasma_flux_m3_s");
  out.q2 = last(m, "fluid", "outlet_2_plasma_flux_m3_s");
  out.seconds = r.command.seconds;
  out.dir = r.dir;
  return out;
}

// The volumes of the mesh's cells in each daughter beyond the junction's sphere (centres at
// z > L_p + r_p, x > 0 for daughter 1, x < 0 for daughter 2), from the recorded state.
// A feeder's cells (x >= split_x) are not the vessel's.
std::pair<double, double> daughter_volumes(const std::string& dir, double split_x = 1) {
  double v1 = 0, v2 = 0;
  for (const CellState& c : read_state(dir + "/state.csv"))
    if (c.z > kLp + kRp && c.x < split_x) (c.x > 0 ? v1 : v2) += c.volume;
  return {v1, v2};
}

// Q_1 / Q_2 of the network whose daughters are tubes of radii r1, r2 and lengths l1, l2.
double network_ratio(double r1, double l1, double r2, double l2) {
  return (std::pow(r1, 4) / l1) / (std::pow(r2, 4) / l2);
}

// The network's two readings of Q_1 / Q_2 for daughters of radii r1, r2 (see below): each daughter
// L_d long from the junction point, or only beyond the parent's round end.
std::pair<double, double> network_readings(double r1, double r2) {
  return {network_ratio(r1, kLd, r2, kLd),
          network_ratio(r1, kLd - std::sqrt(kRp * kRp - r1 * r1), r2, kLd - std::sqrt(kRp * kRp - r2 * r2))};
}

}  // namespace

// Murray's equal daughters: half the flow each. The snapped mesh is not mirror-symmetric (the
// box's cubes cut the two daughters differently): their meshed volumes beyond the junction differ
// by 0.4 % (printed), and a tube's resistance goes as its section squared, so the two halves may
// differ by about 1 %; that is the tolerance. Measured: 1.4e-4 (and 1.1e-3 with cubes of 1.25 um,
// 47,000 cells, when we ran it: the asymmetry is the mesh's, not converging to a bias).
TEST(FluidSurfaceVessel, SymmetricBifurcationSplitsTheFlowInHalves) {
  const Split s = run_bifurcation("bifurcation-symmetric", "");
  const auto [v1, v2] = daughter_volumes(s.dir);
  std::printf(
      "Symmetric bifurcation (%.1f s): Q_in / Q - 1 = %+.2e, (Q_1 + Q_2) / Q - 1 = %+.2e;\n"
      "  Q_1 / (Q_1 + Q_2) = %.6f, Q_1 / Q_2 - 1 = %+.3e (network: 0); daughters' meshed volumes V_1 / V_2 - 1 = "
      "%+.2e\n",
      s.seconds, s.q_in / s.q - 1, (s.q1 + s.q2) / s.q - 1, s.q1 / (s.q1 + s.q2), s.ratio() - 1, v1 / v2 - 1);
  EXPECT_NEAR(s.q_in / s.q, 1, 1e-9);
  EXPECT_NEAR((s.q1 + s.q2) / s.q, 1, 1e-6);  // steady: what enters leaves
  EXPECT_NEAR(s.ratio(), 1, 0.01);
  EXPECT_LT(std::abs(v1 / v2 - 1), 0.01);  // the asymmetry the tolerance is made of
}

// The same symmetric bifurcation fed by a feeder (vessel.inlet = "feeder", a surface vessel's
// default as an open O-grid's): a straight periodic tube of the inlet's equivalent radius beside
// it, the scene's 4/3 O-grid section in 60 layers of 2.5 um, driven from rest by the scene's G
// alone, its end faces mapped onto the snapped inlet by their overlaps (OpenFOAM's AMI: the
// inlet's cubes do not match the O-grid's cells). Three fluxes: the feeder's own (its cells' u_z V
// over its period: exact for a flow uniform along z), the periodic tube's at the scene's drop (the
// same O-grid section of the same radius, 2 layers, driven by the same dP over the same length:
// the same G) and the inlet's. The feeder carries the tube's flow to the solver's tolerance, as
// the straight vessel's does (1e-6). The inlet takes the feeder's flux through its footprint, the
// circle of the feeder's radius: not what the feeder's wall polygon, circumscribed, holds beyond
// it, 1.3 % of its area in its 16 corners, where the wall cells' velocity is about a quarter of the
// mean (their centres at ~0.93 R); that bounds the shortfall by ~3.5e-3, the tolerance 5e-3.
// Measured -2.7e-3, and -2.0e-4 with the feeder's section at 8/6 (32 sides, thinner wall cells)
// when we ran it; sampling one cell per inlet face (nearestCell) instead gave -9.0e-3 and
// +6.0e-3. The vessel then carries what it takes in (1e-6) and splits it in halves as the fixed
// inlet's does (1 %, the mesh's asymmetry: see above).
TEST(FluidSurfaceVessel, FedSymmetricBifurcationCarriesTheFeedersFlow) {
  const SceneSpec spec = bifurcation_spec("bifurcation-fed", "", "feeder");
  const auto r = run_scene(spec);
  ASSERT_EQ(r.command.exit_code, 0) << r.command.output;
  const hemo::Scene scene = hemo::load_scene(r.dir + ".toml");
  ASSERT_EQ(scene.vessel.inlet, "feeder");
  const hemo::FeederLayout f = hemo::feeder_layout(scene);
  const auto cells = read_state(r.dir + "/state.csv");
  double q_feeder = 0;
  int feeder_cells = 0;
  for (const CellState& c : cells)
    if (f.in_feeder(c.x)) {
      q_feeder += c.u[2] * c.volume / f.period;
      ++feeder_cells;
    }
  EXPECT_EQ(feeder_cells, 64 * f.layers);
  const Metrics m = read_metrics(r.dir);
  const double q_in = last(m, "fluid", "inlet_plasma_flux_m3_s");
  const double q1 = last(m, "fluid", "outlet_1_plasma_flux_m3_s"), q2 = last(m, "fluid", "outlet_2_plasma_flux_m3_s");

  SceneSpec tube;
  tube.name = "bifurcation-fed-tube";
  tube.diameter_um = 2 * f.radius * 1e6;
  tube.length_um = kLp * 1e6;
  tube.axial = 2;
  tube.driving = fmt::format("pressure_drop_Pa = {:.17g}", hemo::driving_pressure_drop(scene));
  tube.dt = 1e-4;
  tube.steps = 40;
  tube.particle_command = spec.particle_command;
  const auto t = run_scene(tube);
  ASSERT_EQ(t.command.exit_code, 0) << t.command.output;
  double q_per = 0;
  for (const CellState& c : read_state(t.dir + "/state.csv")) q_per += c.u[2] * c.volume / (kLp);

  const auto [v1, v2] = daughter_volumes(r.dir, f.split_x);
  std::printf(
      "Fed symmetric bifurcation (%.1f s; feeder r = %.3f um, %d layers, period %.1f um): Q_feeder / Q_per - 1 = "
      "%+.2e, Q_in / Q_feeder - 1 = %+.2e, (Q_1 + Q_2) / Q_in - 1 = %+.2e;\n"
      "  Q_1 / Q_2 - 1 = %+.3e (network: 0); daughters' meshed volumes V_1 / V_2 - 1 = %+.2e; Q_per / Q - 1 = %+.3e\n",
      r.command.seconds, f.radius * 1e6, f.layers, f.period * 1e6, q_feeder / q_per - 1, q_in / q_feeder - 1,
      (q1 + q2) / q_in - 1, q1 / q2 - 1, v1 / v2 - 1, q_per / (kPi * kRp * kRp * kRp * kGamma / 4) - 1);
  EXPECT_NEAR(q_feeder / q_per, 1, 1e-6);
  EXPECT_NEAR(q_in / q_feeder, 1, 5e-3);
  EXPECT_NEAR((q1 + q2) / q_in, 1, 1e-6);
  EXPECT_NEAR(q1 / q2, 1, 0.01);
}

// The feeder scaled to Q ("feeder_at_q"): OpenFOAM's setAverage makes the mean of the sampled
// section over the inlet's own faces Q / A, so the inlet takes Q whatever the sampling makes of the
// feeder's flow (the snapped inlet is flat, its faces' normals -z).
TEST(FluidSurfaceVessel, FedAtQBifurcationTakesQ) {
  const Split s = run_bifurcation("bifurcation-fed-at-q", "", "feeder_at_q");
  std::printf("Fed at Q (%.1f s): Q_in / Q - 1 = %+.2e, (Q_1 + Q_2) / Q - 1 = %+.2e, Q_1 / Q_2 - 1 = %+.3e\n",
              s.seconds, s.q_in / s.q - 1, (s.q1 + s.q2) / s.q - 1, s.ratio() - 1);
  EXPECT_NEAR(s.q_in / s.q, 1, 1e-9);
  EXPECT_NEAR((s.q1 + s.q2) / s.q, 1, 1e-6);
  EXPECT_NEAR(s.ratio(), 1, 0.01);
}

// Unequal daughters, D_1 = 24 um and D_2 = 18 um: the network's Q_1 / Q_2 = (r_1 / r_2)^4 L_2 / L_1.
// Which length is a daughter's tube is the network's own ambiguity at the junction: from the
// junction point, L_d for both (3.16), or only beyond the parent's round end, the sphere of r_p
// the daughter leaves at sqrt(r_p^2 - r_i^2) from it (L_d - 9 um and L_d - 12 um: 2.975). The
// simulated split must lie between those two readings, give or take the mesh's 1 % (above). It
// is not a mesh error: halving the cubes (1.25 um, 42,000 cells) moved it by 0.5 %, from 2.988 to
// 3.003, when we ran it; against the network with L_d it is -5.5 %, with the lengths beyond the
// sphere +0.4 %.
TEST(FluidSurfaceVessel, UnequalDaughtersSplitTheFlowAsThePoiseuilleNetwork) {
  const Split s = run_bifurcation("bifurcation-unequal", "daughter_1_diameter_um = 24\ndaughter_2_diameter_um = 18");
  const double r1 = 12e-6, r2 = 9e-6;
  const auto [from_junction, beyond_sphere] = network_readings(r1, r2);
  std::printf(
      "Unequal daughters 24 / 18 um (%.1f s): Q_in / Q - 1 = %+.2e, (Q_1 + Q_2) / Q - 1 = %+.2e;\n"
      "  Q_1 / Q_2 = %.4f; network with L_d: %.4f (error %+.2e), with the tubes beyond the junction's sphere: %.4f "
      "(error %+.2e)\n",
      s.seconds, s.q_in / s.q - 1, (s.q1 + s.q2) / s.q - 1, s.ratio(), from_junction, s.ratio() / from_junction - 1,
      beyond_sphere, s.ratio() / beyond_sphere - 1);
  EXPECT_NEAR(s.q_in / s.q, 1, 1e-9);
  EXPECT_NEAR((s.q1 + s.q2) / s.q, 1, 1e-6);
  EXPECT_GT(s.ratio(), beyond_sphere * (1 - 0.01));
  EXPECT_LT(s.ratio(), from_junction * (1 + 0.01));
}

// An imported surface (scenes/surfaces/y-bifurcation.stl: D_p = 30 um, daughters of 22 and 16 um,
// 60 um long, 90 degrees apart, its solids named "in", "out_wide", "out_narrow"), plasma alone,
// run from a scene beside a copy of its surfaces/ folder with a stand-in particle node: the run
// directory keeps the STL at the scene's relative path; out_wide, named first, is outlet_1 and
// carries the larger share. The network's split of that geometry, read as above, lies between
// 3.396 (beyond the sphere) and 3.574 (L_d); the STL is faceted at 5 um, its walls' chords up to
// h^2 / (8 r) inside the circle (0.28 um for the wide daughter, 0.39 um for the narrow one), which
// can raise the split by up to (1.049 / 1.026)^4 - 1 = 9 %: the bounds are the network's
// readings, less the mesh's 1 %, plus those 9 %. Measured 3.377 when we ran it.
TEST(FluidSurfaceVessel, ImportedSurfaceRunsFromItsSceneWithItsSolidsAsPatches) {
  namespace fs = std::filesystem;
  const std::string dir = fresh_run_dir("imported");
  const fs::path root = fs::path(dir).parent_path() / (fs::path(dir).filename().string() + "-scene");
  fs::create_directories(root / "surfaces");
  fs::copy_file(fs::path(HEMO_SCENES_DIR) / "surfaces" / "y-bifurcation.stl", root / "surfaces" / "y-bifurcation.stl",
                fs::copy_options::overwrite_existing);
  // The inlet takes the flow rate of a 30-um tube at a wall shear rate of 799 1/s as a parabola,
  // both outlets hold p = 0; 40 steps of 1e-4 s are 20 viscous times R^2 / nu: steady.
  const std::string scene = "[run]\nname = \"imported\"\nparticle_command = \"" + bin("hemocosim-prescribed-particles") +
                            " --mode none --record state.csv\"\n"
                            "[vessel]\ndiameter_um = 30\nlength_um = 60\nshape = \"imported\"\n"
                            "surface = \"surfaces/y-bifurcation.stl\"\nsurface_inlet = \"in\"\n"
                            "surface_outlets = \"out_wide out_narrow\"\nends = \"open\"\ninlet = \"poiseuille\"\n"
                            "[mesh]\nsurface_cell_size_um = 2.5\n[driving]\nwall_shear_rate_per_s = 799\n"
                            "[time]\ncoupling_interval_s = 1e-4\ncoupling_steps = 40\n";
  std::ofstream(root / "imported.toml") << scene;
  const auto r = run(bin("hemocosim") + " run " + (root / "imported.toml").string() + " --out " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(fs::path(dir) / "surfaces" / "y-bifurcation.stl"));
  const Metrics m = read_metrics(dir);
  const double q = kPi * kRp * kRp * kRp * kGamma / 4;
  const double q_in = last(m, "fluid", "inlet_plasma_flux_m3_s");
  const double q1 = last(m, "fluid", "outlet_1_plasma_flux_m3_s"), q2 = last(m, "fluid", "outlet_2_plasma_flux_m3_s");
  const double r1 = 11e-6, r2 = 8e-6;
  const auto [from_junction, beyond_sphere] = network_readings(r1, r2);
  std::printf(
      "Imported Y, 22 / 16 um at 90 degrees (%.1f s): Q_in / Q - 1 = %+.2e, (Q_1 + Q_2) / Q - 1 = %+.2e; Q_1 / Q_2 = "
      "%.4f; network %.4f (L_d, error %+.2e) to %.4f (beyond the sphere, error %+.2e)\n",
      r.seconds, q_in / q - 1, (q1 + q2) / q - 1, q1 / q2, from_junction, q1 / q2 / from_junction - 1, beyond_sphere,
      q1 / q2 / beyond_sphere - 1);
  EXPECT_NEAR(q_in / q, 1, 1e-9);
  EXPECT_NEAR((q1 + q2) / q, 1, 1e-6);
  EXPECT_GT(q1 / q2, beyond_sphere * (1 - 0.01));
  EXPECT_LT(q1 / q2, from_junction * (1 + 0.09));
  fs::remove_all(root);
}

// Stopped after step 4 and resumed from its checkpoint, the bifurcation's run is the run in one
// go to the last digit: the resumed fluid node reads its case's snapped mesh back rather than
// meshing again (and snappyHexMesh, run twice for the two runs, makes the same mesh). 10 steps from
// rest, so that every step changes the flow. Fed by a feeder (the default inlet), so that what is
// read back includes the feeder's region, its zone (where G drives) and the mapped inlet's offset;
// a fixed profile's mesh is the same read without them.
TEST(FluidSurfaceVessel, ResumedRunIsTheRunInOneGo) {
  SceneSpec s;
  s.diameter_um = 2 * kRp * 1e6;
  s.length_um = kLp * 1e6;
  s.vessel = "shape = \"bifurcation\"\nends = \"open\"\n";
  s.mesh = "surface_cell_size_um = 2.5";
  s.dt = 1e-5;
  s.steps = 10;
  s.particle_command = bin("hemocosim-prescribed-particles") + " --mode none --record state.csv";
  s.name = "bifurcation-one-go";
  const auto one_go = run_scene(s);
  ASSERT_EQ(one_go.command.exit_code, 0) << one_go.command.output;
  s.name = "bifurcation-parts";
  const auto parts = run_scene(s, "--stop-after-step 4");
  ASSERT_EQ(parts.command.exit_code, 0) << parts.command.output;
  namespace fs = std::filesystem;
  const fs::path snappy_log = fs::path(parts.dir) / "fluid" / "log.snappyHexMesh";
  ASSERT_TRUE(fs::exists(snappy_log));
  const auto meshed = fs::last_write_time(snappy_log);
  const auto resumed = run(bin("hemocosim") + " resume " + parts.dir);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_EQ(fs::last_write_time(snappy_log), meshed) << "the resumed run meshed again";
  const auto a = read_state(one_go.dir + "/state.csv"), c = read_state(parts.dir + "/state.csv");
  ASSERT_EQ(a.size(), c.size());
  double umax = 0, d = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      umax = std::max(umax, std::abs(a[i].u[k]));
      d = std::max(d, std::abs(a[i].u[k] - c[i].u[k]));
    }
  const auto m = read_metrics(one_go.dir);
  const auto& fastest = m.at({"fluid", "max_velocity_m_s"});
  std::printf(
      "Bifurcation, 10 steps: stopped at 4 and resumed vs one go max |du| / u_max = %.3e; max velocity step "
      "5 / step 10 - 1 = %+.3e\n",
      d / umax, fastest.at(5) / fastest.rbegin()->second - 1);
  EXPECT_GT(std::abs(fastest.at(5) / fastest.rbegin()->second - 1), 1e-4);
  EXPECT_EQ(d, 0.0);
}
