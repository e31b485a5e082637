// Scenes: units are converted once, unknown keys and impossible values are refused with their line.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>

#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <tuple>
#include <utility>

#include "minimal_scene.h"
#include "momentum_forms.h"
#include "scene.h"
#include "suspension_viscosity.h"
#include "units.h"
#include "vec.h"
#include "vessel_ends.h"

using namespace hemo;

namespace {
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
  const Scene s = load_scene(test::write_temp(test::kMinimalScene));
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
  auto ps = problems_of(std::string(test::kMinimalScene) + "\n[vessel2]\nx = 1\n");
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
  auto ps = problems_of(std::string(test::kMinimalScene) + "[mesh]\naxial_cells = \"many\"\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "mesh.axial_cells");
  ps = problems_of("[vessel\ndiameter_um = 1\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_GT(ps[0].line, 0);
}

TEST(Scene, ClosuresShapeDepositionAndTimingKeysHaveModelDefaults) {
  const Scene s = load_scene(test::write_temp(test::kMinimalScene));
  EXPECT_EQ(s.rbc.drag, "rbc_fit");
  EXPECT_EQ(s.rbc.lift, "rbc_lift");
  EXPECT_EQ(s.rbc.torque, "none");
  EXPECT_EQ(s.platelet.drag, "oblate");
  EXPECT_EQ(s.platelet.lift, "oblate");
  EXPECT_EQ(s.platelet.torque, "oblate");
  EXPECT_NEAR(s.platelet.semi_axis_a, 2.06e-6, 1e-18);
  EXPECT_NEAR(s.platelet.semi_axis_c, 0.52e-6, 1e-18);
  EXPECT_EQ(s.platelet.orientation_integrator, OrientationMethod::splitting);
  EXPECT_EQ(s.solid_fraction, "sphere_overlap");
  EXPECT_EQ(s.implicit_drag, ImplicitDrag::interval_response);
  EXPECT_TRUE(s.return_held_back_momentum);
  EXPECT_EQ(s.time.steps_per_contact, 10);
  EXPECT_EQ(s.time.relaxation_factor, 0);
  EXPECT_EQ(s.gravity.z, 0);

  const Scene t = load_scene(test::write_temp(std::string(test::kMinimalScene) + R"(
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
  EXPECT_EQ(t.platelet.orientation_integrator, OrientationMethod::euler);
  EXPECT_EQ(t.solid_fraction, "centre_cell");
  EXPECT_EQ(s.coupling_scheme, CouplingScheme::serial);
  EXPECT_EQ(t.coupling_scheme, CouplingScheme::parallel);
  EXPECT_EQ(t.implicit_drag, ImplicitDrag::instantaneous);
  EXPECT_FALSE(t.return_held_back_momentum);
  EXPECT_DOUBLE_EQ(t.gravity.z, -9.81);
  EXPECT_EQ(t.time.steps_per_contact, 20);
  EXPECT_EQ(t.time.relaxation_factor, 2);
}

TEST(Scene, UnknownClosureNamesAndImpossibleShapesAreNamed) {
  auto ps = problems_of(std::string(test::kMinimalScene) + R"(
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
  EXPECT_NE(by_key["platelet.drag"].find("known: oblate, rbc_fit, schiller_naumann, stokes)"), std::string::npos)
      << by_key["platelet.drag"];
  EXPECT_TRUE(by_key.count("platelet.semi_axis_c_um"));
  EXPECT_TRUE(by_key.count("coupling.solid_fraction"));
  EXPECT_NE(by_key["coupling.implicit_drag"].find("interval_response"), std::string::npos);
  EXPECT_NE(by_key["coupling.implicit_drag"].find("co_relaxed"), std::string::npos);
  EXPECT_TRUE(problems_of(std::string(test::kMinimalScene) + "[coupling]\nimplicit_drag = \"co_relaxed\"\n").empty());
}

// The feeder is the vessel's length and whole layers of the same thickness beyond, the fewest
// that span a nominal diameter: the gap that keeps the DEM's cells at the outlet out of reach of
// those at the inlet through the box's period.
TEST(Scene, TheFeederOutgrowsTheVesselByTheFewestWholeLayersSpanningADiameter) {
  Vessel v;
  v.diameter = 100e-6;
  v.length = 600e-6;
  EXPECT_EQ(feeder_axial_cells(v, 24), 28);  // 25 um layers: 4 span 100 um
  EXPECT_DOUBLE_EQ(feeder_length(v, 24), 700e-6);
  EXPECT_EQ(feeder_axial_cells(v, 30), 35);  // 20 um: 5
  EXPECT_EQ(feeder_axial_cells(v, 7), 9);    // 85.7 um: 2 (one falls short)
  v.length = 100e-6;
  EXPECT_EQ(feeder_axial_cells(v, 2), 4);  // 50 um: 2
  for (int n : {2, 7, 24, 30, 64}) {
    v.length = 600e-6;
    const double dz = v.length / n;
    const double gap = feeder_length(v, n) - v.length;
    EXPECT_GE(gap, v.diameter * (1 - 1e-12)) << n;
    EXPECT_LT(gap - dz, v.diameter) << n;
  }
}

// The feeder lies beside the vessel, clear of it: the split between them is midway between the
// vessel's widest wall and the feeder's, and a feeder point stands for the inlet-plane point at
// the same offset from the axis.
TEST(Scene, TheFeederLayoutSplitsTheBoxBetweenTheTwoWalls) {
  Vessel v;
  v.diameter = 100e-6;
  v.length = 600e-6;
  v.ends = "open";
  const FeederLayout straight = feeder_layout(v, 24);
  EXPECT_DOUBLE_EQ(straight.period, 700e-6);
  EXPECT_DOUBLE_EQ(straight.axis_x, 150e-6);
  EXPECT_DOUBLE_EQ(straight.radius, 50e-6);
  EXPECT_DOUBLE_EQ(straight.split_x, 75e-6);
  const particles::Vec3 p(160e-6, 20e-6, 300e-6);
  EXPECT_TRUE(straight.in_feeder(p.x()));
  const particles::Vec3 q = straight.in_vessel_frame(p);
  EXPECT_NEAR(q.x(), 10e-6, 1e-18);
  EXPECT_EQ(q.y(), 20e-6);
  EXPECT_EQ(q.z(), 0.0);
  const particles::Vec3 inside(40e-6, 0, 300e-6);
  EXPECT_EQ(straight.in_vessel_frame(inside), inside);
  v.inlet = "poiseuille";
  EXPECT_THROW(feeder_layout(v, 24), std::invalid_argument);
}

// Both nodes take a scene's layout from feeder_layout(scene): for the O-grid, the vessel's with
// mesh.axial_cells to the bit (the inlet's centre the origin), whatever the shape; and the
// surface vessels' rule for the feeder's axis, the widest x plus the feeder's diameter, is the
// O-grid's 3 R0 for the straight tube.
TEST(Scene, TheScenesFeederLayoutIsTheOGridsToTheBit) {
  for (const std::string shape :
       {"", "shape = \"stenosis\"\nstenosis_area_reduction = 0.5\nstenosis_length_um = 300\n"}) {
    const Scene s =
        load_scene(test::write_temp("[vessel]\ndiameter_um = 100\nlength_um = 600\nends = \"open\"\n" + shape +
                                    "[mesh]\naxial_cells = 30\n[driving]\nwall_shear_rate_per_s = 799\n"));
    const FeederLayout a = feeder_layout(s), b = feeder_layout(s.vessel, 30);
    const std::vector<std::pair<double, double>> fields{{a.vessel_length, b.vessel_length},
                                                        {a.period, b.period},
                                                        {a.axis_x, b.axis_x},
                                                        {a.split_x, b.split_x},
                                                        {a.radius, b.radius}};
    for (const auto& [x, y] : fields) EXPECT_EQ(std::memcmp(&x, &y, sizeof x), 0) << shape;
    EXPECT_EQ(a.inlet_x, 0.0);
    EXPECT_EQ(a.inlet_y, 0.0);
    EXPECT_EQ(a.inlet_z, 0.0);
    EXPECT_EQ(a.layers, feeder_axial_cells(s.vessel, 30));
    EXPECT_EQ(a.layers, 35);
  }
  Vessel v;
  v.diameter = 100e-6;
  v.length = 600e-6;
  for (const double d : {100e-6, 30e-6, 7.3e-6, 1.0 / 3}) {
    v.diameter = d;
    const double by_rule = feeder_axis_x(v.radius(), v.radius()), o_grid = feeder_axis_x(v);
    EXPECT_EQ(std::memcmp(&by_rule, &o_grid, sizeof by_rule), 0) << d;
  }
  EXPECT_THROW(feeder_layout(load_scene(test::write_temp(test::kMinimalScene))), std::invalid_argument);
}

// vessel.ends (periodic by default) and vessel.inlet (the feeder by default; periodic ends ignore
// it), each a registered name (model/vessel_ends.h).
TEST(Scene, VesselEndsArePeriodicByDefaultAndOpenOnesTakeAnInlet) {
  const Scene plain = load_scene(test::write_temp(test::kMinimalScene));
  EXPECT_EQ(plain.vessel.ends, "periodic");
  EXPECT_FALSE(open_ends(plain.vessel));
  EXPECT_FALSE(fed_by_feeder(plain.vessel));
  auto with = [](const std::string& lines) {
    return "[vessel]\ndiameter_um = 100\nlength_um = 600\n" + lines + "\n[driving]\nwall_shear_rate_per_s = 799\n";
  };
  const Scene fed = load_scene(test::write_temp(with("ends = \"open\"")));
  EXPECT_TRUE(open_ends(fed.vessel));
  EXPECT_EQ(fed.vessel.inlet, "feeder");
  EXPECT_TRUE(fed_by_feeder(fed.vessel));
  const Scene parabola = load_scene(test::write_temp(with("ends = \"open\"\ninlet = \"poiseuille\"")));
  EXPECT_TRUE(open_ends(parabola.vessel));
  EXPECT_FALSE(fed_by_feeder(parabola.vessel));
  EXPECT_EQ(vessel_inlet(parabola.vessel.inlet).profile, VesselInlet::Profile::parabola);
  EXPECT_TRUE(problems_of(with("inlet = \"uniform\"")).empty());  // ignored by periodic ends
  EXPECT_TRUE(problems_of(with("ends = \"open\"\nshape = \"stenosis\"\nstenosis_length_um = 300")).empty());
  for (const auto& [line, key, known] : {std::tuple{"ends = \"closed\"", "vessel.ends", "known: periodic, open"},
                                         std::tuple{"ends = \"open\"\ninlet = \"plug\"", "vessel.inlet",
                                                    "known: feeder, feeder_at_q, poiseuille, uniform"}}) {
    const auto ps = problems_of(with(line));
    ASSERT_EQ(ps.size(), 1u) << line;
    EXPECT_EQ(ps[0].key, key);
    EXPECT_NE(ps[0].message.find(known), std::string::npos) << ps[0].message;
  }
}

// Cells enter an open vessel from its feeder: red cells or platelets in one fed by the feeder (the
// default inlet) are fine, in one with a fixed inlet profile one problem, on vessel.inlet, naming
// both ways out; species given at zero are fine with any inlet.
TEST(Scene, CellsEnterAnOpenVesselOnlyFromAFeeder) {
  auto with = [](const std::string& ends, const std::string& cells) {
    return "[vessel]\ndiameter_um = 100\nlength_um = 600\nends = \"" + ends +
           "\n[driving]\nwall_shear_rate_per_s = 799\n" + cells;
  };
  for (const std::string cells : {"[rbc]\nhematocrit = 0.1\n", "[platelet]\nnumber_density_per_ul = 300000\n",
                                  "[rbc]\nhematocrit = 0.1\n[platelet]\nnumber_density_per_ul = 300000\n"}) {
    EXPECT_TRUE(problems_of(with("periodic\"", cells)).empty()) << cells;
    EXPECT_TRUE(problems_of(with("open\"", cells)).empty()) << cells;
    EXPECT_TRUE(problems_of(with("open\"\ninlet = \"feeder\"", cells)).empty()) << cells;
    for (const std::string inlet : {"poiseuille", "uniform"}) {
      const auto ps = problems_of(with("open\"\ninlet = \"" + inlet + "\"", cells));
      ASSERT_EQ(ps.size(), 1u) << cells;
      EXPECT_EQ(ps[0].key, "vessel.inlet");
      EXPECT_EQ(ps[0].message.find('\n'), std::string::npos);
      EXPECT_NE(ps[0].message.find("plasma alone"), std::string::npos) << ps[0].message;
      EXPECT_NE(ps[0].message.find("vessel.inlet = \"feeder\""), std::string::npos) << ps[0].message;
    }
  }
  EXPECT_TRUE(
      problems_of(with("open\"\ninlet = \"uniform\"", "[rbc]\nhematocrit = 0\n[platelet]\nnumber_density_per_ul = 0\n"))
          .empty());
}

// dem.neighbour_rebuild = "streaming" is proven and tested on one particle rank only
// (particle-node/dem_streaming_neighbours.h): a scene asking it of more is refused, naming why.
// The streaming lists run on any number of particle ranks (the box split across the vessel), and
// only where the scene's Poiseuille profile is the flow's frame: a straight periodic tube.
TEST(Scene, StreamingNeighbourListsTakeAnyRankCountInAStraightPeriodicTube) {
  const std::string streaming = std::string(test::kMinimalScene) + "[dem]\nneighbour_rebuild = \"streaming\"\n";
  EXPECT_TRUE(problems_of(streaming).empty());
  EXPECT_TRUE(problems_of(streaming + "[run]\nparticle_ranks = 2\n").empty());
  std::string open = streaming;
  open.replace(open.find("length_um = 600\n"), 16, "length_um = 600\nends = \"open\"\n");
  const auto ps = problems_of(open);
  ASSERT_EQ(ps.size(), 1u) << open;
  EXPECT_EQ(ps[0].key, "dem.neighbour_rebuild");
  EXPECT_NE(ps[0].message.find("periodic vessel"), std::string::npos) << ps[0].message;
}

// fluid.solve_every: 1 by default; above 1 in the serial scheme with fixed intervals; one
// problem, on the key and in one line, for 0 and for each combination it cannot serve.
TEST(Scene, FluidSolveEveryIsAtLeastOneAndNeedsTheSerialSchemeAndFixedIntervals) {
  const std::string base = test::kMinimalScene;
  EXPECT_EQ(load_scene(test::write_temp(base)).fluid.solve_every, 1);
  EXPECT_TRUE(problems_of(base + "[fluid]\nsolve_every = 5\n").empty());
  for (const auto& [extra, words] :
       {std::pair<std::string, std::string>{"[fluid]\nsolve_every = 0\n", "at least 1"},
        {"[fluid]\nsolve_every = 4\n[coupling]\nscheme = \"parallel\"\n", "serial"},
        {"[fluid]\nsolve_every = 4\n[time]\ncoupling_relaxation_times = 100\n", "fixed coupling intervals"}}) {
    const auto ps = problems_of(base + extra);
    ASSERT_EQ(ps.size(), 1u) << extra;
    EXPECT_EQ(ps[0].key, "fluid.solve_every");
    EXPECT_EQ(ps[0].message.find('\n'), std::string::npos);
    EXPECT_NE(ps[0].message.find(words), std::string::npos) << ps[0].message;
  }
}

// The PISO loop's and the velocity solver's keys: today's fvSolution by default, the values a
// scene gives, and a one-line problem on the key for a value OpenFOAM could not use.
TEST(Scene, FluidSolverKeysDefaultToTodaysSettingsAndRefuseBadValues) {
  const std::string base = test::kMinimalScene;
  const auto d = load_scene(test::write_temp(base)).fluid;
  EXPECT_EQ(d.non_orthogonal_correctors, 1);
  EXPECT_EQ(d.velocity_relative_tolerance, 0.0);
  EXPECT_TRUE(d.momentum_predictor);
  const auto f = load_scene(test::write_temp(base +
                                             "[fluid]\nnon_orthogonal_correctors = 0\n"
                                             "velocity_relative_tolerance = 0.01\nmomentum_predictor = false\n"))
                     .fluid;
  EXPECT_EQ(f.non_orthogonal_correctors, 0);
  EXPECT_EQ(f.velocity_relative_tolerance, 0.01);
  EXPECT_FALSE(f.momentum_predictor);
  for (const auto& [extra, key] :
       {std::pair<std::string, std::string>{"non_orthogonal_correctors = -1", "fluid.non_orthogonal_correctors"},
        {"non_orthogonal_correctors = 1000", "fluid.non_orthogonal_correctors"},
        {"non_orthogonal_correctors = 0.5", "fluid.non_orthogonal_correctors"},
        {"velocity_relative_tolerance = 1", "fluid.velocity_relative_tolerance"},
        {"velocity_relative_tolerance = -0.1", "fluid.velocity_relative_tolerance"},
        {"momentum_predictor = \"no\"", "fluid.momentum_predictor"}}) {
    const auto ps = problems_of(base + "[fluid]\n" + extra + "\n");
    ASSERT_EQ(ps.size(), 1u) << extra;
    EXPECT_EQ(ps[0].key, key) << extra;
    EXPECT_EQ(ps[0].message.find('\n'), std::string::npos) << ps[0].message;
  }
}

// Every committed scene (scenes/*.toml and the bench suites' base) passes what `hemocosim check`
// and `run` check, its particles' placement included (the studies' and suites' scenes: ctest
// study_check.*, bench_check.*).
TEST(Scene, ShippedScenesAreValid) {
  std::vector<std::string> scenes = {std::string(HEMO_SCENES_DIR) + "/bench/base.toml"};
  for (const auto& e : std::filesystem::directory_iterator(HEMO_SCENES_DIR))
    if (e.path().extension() == ".toml") scenes.push_back(e.path().string());
  ASSERT_GE(scenes.size(), 4u);
  for (const auto& path : scenes) {
    EXPECT_NO_THROW(load_scene(path)) << path;
    try {
      load_scene(path, SceneCheck::placement);
    } catch (const SceneError& e) {
      ADD_FAILURE() << e.what();
    }
  }
}

// docs/scenes.md lists every key the code reads, with the default the code uses and the values
// its validation allows.
TEST(Scene, DocumentationListsEveryKeyWithItsDefault) {
  std::ifstream in(std::string(HEMO_SCENES_DIR) + "/../docs/scenes.md");
  ASSERT_TRUE(in);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string doc = ss.str();
  const auto keys = scene_keys();
  ASSERT_GT(keys.size(), 40u);
  for (const auto& k : keys)
    EXPECT_NE(doc.find(k.table_row() + "\n"), std::string::npos)
        << k.table_row() << " is not in docs/scenes.md: regenerate with hemocosim check --keys";
}

// test::kMinimalScene's keys, with `key = value` set too (dotted keys, so that any key can join).
static std::string minimal_with(const std::string& key, const std::string& value) {
  std::map<std::string, std::string> lines = {
      {"vessel.diameter_um", "100"}, {"vessel.length_um", "600"}, {"driving.wall_shear_rate_per_s", "799"}};
  if (key == "driving.pressure_drop_Pa") lines.erase("driving.wall_shear_rate_per_s");
  lines[key] = value;
  std::string text;
  for (const auto& [k, v] : lines) text += k + " = " + v + "\n";
  return text;
}

// docs/design.md, "Extending hemocosim": the key listing is the parser's own. Every key it lists
// is read (a scene giving it its default loads), and any other is refused.
TEST(SceneKeys, EveryListedKeyIsReadAndAnUnknownOneRefused) {
  for (const auto& k : scene_keys()) {
    if (k.default_value.rfind("required", 0) == 0) continue;  // minimal_with gives them
    const auto ps = problems_of(minimal_with(k.key, k.default_value));
    EXPECT_TRUE(ps.empty()) << k.key << " = " << k.default_value << ": " << (ps.empty() ? "" : ps[0].message);
  }
  const auto ps = problems_of(minimal_with("run.no_such_key", "1"));
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "run.no_such_key");
  EXPECT_EQ(ps[0].message, "unknown key");
}

// The names a key lists are the ones its validation offers when a name is wrong.
TEST(SceneKeys, ListedNamesAreTheValidationsNames) {
  int enumerations = 0;
  for (const auto& k : scene_keys()) {
    if (k.names.empty()) continue;
    ++enumerations;
    std::string known;
    for (const auto& n : k.names) known += (known.empty() ? "" : ", ") + n;
    const auto ps = problems_of(minimal_with(k.key, "\"no_such_name\""));
    ASSERT_FALSE(ps.empty()) << k.key;
    EXPECT_EQ(ps[0].key, k.key);
    EXPECT_EQ(ps[0].message, "unknown name 'no_such_name' (known: " + known + ")");
    EXPECT_EQ(k.allowed().rfind("one of \"" + k.names[0] + "\"", 0), 0u) << k.allowed();
  }
  EXPECT_GE(enumerations, 10);
}

// A listed range is the one the validation refuses a value beyond, in the same words.
TEST(SceneKeys, ListedRangesAreTheValidationsRanges) {
  int ranges = 0;
  for (const auto& k : scene_keys()) {
    for (const auto& rule : k.rules) {
      const auto at_most = rule.rfind("must be at most ", 0) == 0;
      const auto in = rule.rfind("must be in [", 0) == 0 && rule.back() == ']';
      if (!at_most && !in) continue;
      ++ranges;
      const double hi = std::stod(rule.substr(at_most ? rule.rfind(' ') + 1 : rule.rfind(", ") + 2));
      const std::string beyond = fmt::format("{:.0f}", hi + 1);
      const auto ps = problems_of(minimal_with(k.key, beyond));
      ASSERT_FALSE(ps.empty()) << k.key << " = " << beyond;
      EXPECT_EQ(ps[0].key, k.key);
      EXPECT_EQ(ps[0].message, rule) << k.key << " = " << beyond;
    }
  }
  EXPECT_GE(ranges, 40);
}

TEST(Scene, MissingRequiredKeyIsOneProblem) {
  auto ps = problems_of("[driving]\nwall_shear_rate_per_s = 799\n[vessel]\nlength_um = 60\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "vessel.diameter_um");
  EXPECT_EQ(ps[0].message, "missing");
}

// coupling.momentum: every form of the table is a scene value, listed by `hemocosim check` with
// whose it is; the key it replaced is refused with one line naming the new one.
TEST(Scene, MomentumFormsAreTheTablesAndTheOldKeyPointsAtTheNewOne) {
  for (const MomentumForm& form : momentum_forms()) {
    const Scene s = load_scene(
        test::write_temp(std::string(test::kMinimalScene) + "[coupling]\nmomentum = \"" + form.name + "\"\n"));
    EXPECT_EQ(s.momentum, form.name);
    bool listed = false;
    for (const auto& r : numerical_readings(s))
      if (r.key == "coupling.momentum") listed = r.value == form.name && r.reading == form.reading;
    EXPECT_TRUE(listed) << form.name;
    // A form that claims the exact balance puts the particles' share on them or on the plasma.
    if (form.exact_balance) {
      EXPECT_TRUE(form.pressure_force || !form.pressure_on_fraction) << form.name;
    }
  }
  EXPECT_EQ(momentum_forms().front().name, Scene{}.momentum);
  const auto ps = problems_of(std::string(test::kMinimalScene) + "[coupling]\npressure_gradient_force = true\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "coupling.pressure_gradient_force");
  EXPECT_NE(ps[0].message.find("replaced by coupling.momentum"), std::string::npos) << ps[0].message;
  EXPECT_EQ(ps[0].message.find('\n'), std::string::npos);
}

// plasma.suspension_viscosity (beyond the paper): "none", the paper's equations, by default; each
// closure a scene value, listed by `hemocosim check` with whose relation it is when chosen; the relations at
// their published forms: Einstein's 1 + 2.5 phi, Krieger & Dougherty's (1 - phi/0.64)^(-1.6),
// which starts as Einstein's, grows faster and stays finite past close packing.
TEST(Scene, SuspensionViscositiesAreTheTablesAndNoneIsTheDefault) {
  EXPECT_EQ(suspension_viscosities().front().name, Scene{}.plasma.suspension_viscosity);
  EXPECT_FALSE(suspension_viscosity("none").adds_stress());
  for (const SuspensionViscosity& closure : suspension_viscosities()) {
    const Scene s = load_scene(test::write_temp(std::string(test::kMinimalScene) +
                                                "[plasma]\nsuspension_viscosity = \"" + closure.name + "\"\n"));
    EXPECT_EQ(s.plasma.suspension_viscosity, closure.name);
    bool listed = false;
    for (const auto& r : numerical_readings(s))
      if (r.key == "plasma.suspension_viscosity") listed = r.value == closure.name && r.reading == closure.reading;
    EXPECT_EQ(listed, closure.adds_stress()) << closure.name;  // listed when chosen, beyond the paper
    EXPECT_DOUBLE_EQ(closure.relative(0), 1) << closure.name;
  }
  const auto& einstein = suspension_viscosity("einstein");
  const auto& kd = suspension_viscosity("krieger_dougherty");
  EXPECT_DOUBLE_EQ(einstein.relative(0.3), 1.75);
  EXPECT_NEAR(kd.relative(0.3), std::pow(1 - 0.3 / 0.64, -2.5 * 0.64), 1e-12);
  EXPECT_NEAR((kd.relative(1e-6) - 1) / 1e-6, 2.5, 1e-4);  // Einstein's slope at phi -> 0
  double previous = 1;
  for (double phi = 0.05; phi < 0.64; phi += 0.05) {
    EXPECT_GT(kd.relative(phi), std::max(previous, einstein.relative(phi))) << phi;
    previous = kd.relative(phi);
  }
  EXPECT_TRUE(std::isfinite(kd.relative(0.7)));
  EXPECT_THROW(suspension_viscosity("quemada"), std::invalid_argument);
  const auto ps = problems_of(std::string(test::kMinimalScene) + "[plasma]\nsuspension_viscosity = \"quemada\"\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "plasma.suspension_viscosity");
}

// The numerical readings the paper leaves open: ours by default, CFDEM's by name, each listed
// by `hemocosim check` with whose reading it is.
TEST(Scene, NumericalReadingsDefaultToOursAndNameCfdemsWhenChosen) {
  const Scene ours =
      load_scene(test::write_temp(std::string(test::kMinimalScene) + "[platelet]\nnumber_density_per_ul = 1000\n"));
  EXPECT_EQ(ours.fluid_velocity, FluidVelocity::reconstructed);
  EXPECT_EQ(ours.fluid_force, FluidForceUpdate::per_dem_step);
  EXPECT_EQ(ours.momentum, "paper");
  EXPECT_EQ(ours.plasma_velocity, PlasmaVelocity::face_flux);
  for (const auto& r : numerical_readings(ours))
    EXPECT_NE(r.reading.rfind("CFDEM", 0), 0u) << r.key << ": " << r.reading;  // no reading of CFDEM's alone

  const Scene cfdem = load_scene(std::string(HEMO_SCENES_DIR) + "/calibration-cfdem.toml");
  const auto readings = numerical_readings(cfdem);
  ASSERT_EQ(readings.size(), 7u);
  for (const auto& r : readings) {
    // CFDEM's fluid-side drag and the paper's orientation update do not run at the scene's steps (its comments);
    // its mesh is OpenFOAM's blockMesh's.
    if (r.key == "coupling.implicit_drag" || r.key == "platelet.orientation_integrator") continue;
    if (r.key == "mesh.wall_polygon") {
      EXPECT_NE(r.reading.find("blockMesh"), std::string::npos) << r.reading;
      continue;
    }
    EXPECT_NE(r.reading.find("CFDEM"), std::string::npos) << r.key << ": " << r.reading;
  }

  Scene paper = ours;
  paper.platelet.orientation_integrator = OrientationMethod::euler;
  EXPECT_NE(numerical_readings(paper).back().reading.find("Algorithm 1"), std::string::npos);

  std::map<std::string, std::string> by_key;
  for (auto& p :
       problems_of(std::string(test::kMinimalScene) + "[coupling]\nfluid_velocity = \"trilinear\"\nfluid_force = "
                                                      "\"explicit\"\nmomentum = \"model_A\"\n"))
    by_key[p.key] = p.message;
  EXPECT_NE(by_key["coupling.fluid_velocity"].find("reconstructed, cell"), std::string::npos);
  EXPECT_NE(by_key["coupling.fluid_force"].find("per_dem_step, held_implicit_drag, held"), std::string::npos);
  EXPECT_NE(by_key["coupling.momentum"].find("paper, cfdem_A, cfdem_B, cfdem_Bfull, plasma_driven"), std::string::npos)
      << by_key["coupling.momentum"];
  EXPECT_TRUE(problems_of(std::string(test::kMinimalScene) + "[coupling]\nplasma_velocity = \"face_flux\"\n").empty());
  EXPECT_FALSE(
      problems_of(std::string(test::kMinimalScene) + "[coupling]\nplasma_velocity = \"reconstructed\"\n").empty());
  // A held force has nothing to co-relax within the interval.
  EXPECT_FALSE(problems_of(std::string(test::kMinimalScene) +
                           "[coupling]\nfluid_force = \"held\"\nimplicit_drag = \"co_relaxed\"\n")
                   .empty());
}

// Every named option's table (model/scene_choices.h) names each value once, and a name read from
// a scene comes back as the same value: a value added to an enum without its entry, or two
// entries spelling one name, fail here.
template <class E>
void expect_choices_round_trip(int values) {
  const auto names = choice_names<E>();
  EXPECT_EQ(static_cast<int>(names.size()), values) << ChoiceTable<E>::key;
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), names.size()) << ChoiceTable<E>::key;
  for (int v = 0; v < values; ++v) {
    const E value = static_cast<E>(v);
    E read = static_cast<E>(values - 1 - v);
    ASSERT_TRUE(choice_named(name_of(value), read)) << name_of(value);
    EXPECT_EQ(read, value) << name_of(value);
    EXPECT_FALSE(choice_of(value).reading.empty()) << name_of(value);
  }
  E untouched = static_cast<E>(0);
  EXPECT_FALSE(choice_named("no such name", untouched));
}

TEST(Scene, EveryNamedOptionReadsBackAsItsValue) {
  expect_choices_round_trip<CouplingScheme>(2);
  expect_choices_round_trip<NeighbourRebuild>(2);
  expect_choices_round_trip<WallPolygon>(2);
  expect_choices_round_trip<FluidVelocity>(2);
  expect_choices_round_trip<PlasmaVelocity>(2);
  expect_choices_round_trip<OrientationMethod>(2);
  expect_choices_round_trip<FluidForceUpdate>(3);
  expect_choices_round_trip<ImplicitDrag>(3);
  expect_choices_round_trip<LoadBalance>(2);
  // and a scene spells them as the tables do
  const Scene s = load_scene(test::write_temp(std::string(test::kMinimalScene) +
                                              "[coupling]\nscheme = \"parallel\"\nplasma_velocity = \"cell_centre\"\n"));
  EXPECT_EQ(s.coupling_scheme, CouplingScheme::parallel);
  EXPECT_EQ(s.plasma_velocity, PlasmaVelocity::cell_centre);
  const auto ps = problems_of(std::string(test::kMinimalScene) + "[coupling]\nscheme = \"jacobi\"\n");
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_NE(ps[0].message.find("serial, parallel"), std::string::npos) << ps[0].message;
}
