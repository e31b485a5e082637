// Study files: parsing, sweep expansion (each value lands on the swept key and nowhere else),
// refusals (unknown swept key, malformed files), [set], --reduced, and the shipped studies.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "scene.h"
#include "study_file.h"
#include "synthetic_run.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

using namespace hemo;
using namespace hemo::studytest;
namespace fs = std::filesystem;

namespace {

// A scratch folder with base.toml and a study file of the given text.
struct Fixture {
  ScratchDir dir;
  std::string study;
  explicit Fixture(const std::string& name, const std::string& study_text) : dir(name) {
    write_text(dir.str() + "/base.toml", kSmallBaseScene);
    study = dir.str() + "/" + name + ".toml";
    write_text(study, study_text);
  }
  std::string scenes() const { return dir.str() + "/scenes"; }
};

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const StudyError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(StudyFile, ParsesOneSweptKey) {
  Fixture fx("shear",
             "base = \"base.toml\"\n[sweep]\nkey = \"driving.wall_shear_rate_per_s\"\nvalues = [150, 799.5, 1650]\n");
  const Study s = load_study(fx.study);
  EXPECT_EQ(s.name, "shear");  // the file's stem
  EXPECT_EQ(s.base, fs::path(fx.dir.str() + "/base.toml").lexically_normal().string());
  ASSERT_EQ(s.keys, std::vector<std::string>{"driving.wall_shear_rate_per_s"});
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s.values[1], std::vector<std::string>{"799.5"});
  EXPECT_EQ(s.labels, (std::vector<std::string>{"150", "799.5", "1650"}));
  EXPECT_EQ(s.value_text(2), "1650");
}

TEST(StudyFile, EachValueLandsOnTheSweptKeyOnly) {
  Fixture fx(
      "shear",
      "name = \"sr\"\nbase = \"base.toml\"\n[sweep]\nkey = \"driving.wall_shear_rate_per_s\"\nvalues = [150, 1650]\n");
  const auto cases = expand_study(load_study(fx.study), fx.scenes(), nullptr);
  ASSERT_EQ(cases.size(), 2u);
  const double want[] = {150, 1650};
  for (std::size_t i = 0; i < cases.size(); ++i) {
    EXPECT_EQ(cases[i].dir_name, i == 0 ? "01-150" : "02-1650");
    EXPECT_TRUE(fs::exists(cases[i].scene_path));
    const Scene sc = load_scene(cases[i].scene_path);
    EXPECT_DOUBLE_EQ(sc.driving.wall_shear_rate, want[i]);
    // dP follows from the swept shear rate: 4 mu l gamma / d.
    EXPECT_NEAR(sc.driving.pressure_drop, 4 * sc.plasma.viscosity * 60e-6 * want[i] / 40e-6, 1e-12);
    // Everything else as in the base.
    EXPECT_DOUBLE_EQ(sc.vessel.diameter, 40e-6);
    EXPECT_DOUBLE_EQ(sc.rbc.hematocrit, 0.1);
    EXPECT_EQ(sc.time.coupling_steps, 100);
    EXPECT_EQ(sc.run.seed, 3u);  // same initial conditions in every run
    EXPECT_EQ(sc.run.name, i == 0 ? "sr-150" : "sr-1650");
  }
}

TEST(StudyFile, SeveralKeysChangeTogether) {
  Fixture fx("pair", R"(base = "base.toml"
[sweep]
keys = ["rbc.hematocrit", "vessel.diameter_um"]
values = [[0.2, 50], [0.3, 70]]
labels = ["a", "b c"]
)");
  const Study s = load_study(fx.study);
  EXPECT_EQ(s.labels, (std::vector<std::string>{"a", "b_c"}));  // made safe for file names
  EXPECT_EQ(s.value_text(1), "0.3, 70");
  const auto cases = expand_study(s, fx.scenes(), nullptr);
  const Scene b = load_scene(cases[1].scene_path);
  EXPECT_DOUBLE_EQ(b.rbc.hematocrit, 0.3);
  EXPECT_DOUBLE_EQ(b.vessel.diameter, 70e-6);
  EXPECT_EQ(cases[1].dir_name, "02-b_c");
}

TEST(StudyFile, StringValuesStayStrings) {
  Fixture fx("drag", "base = \"base.toml\"\n[sweep]\nkey = \"platelet.drag\"\nvalues = [\"stokes\"]\n");
  const auto cases = expand_study(load_study(fx.study), fx.scenes(), nullptr);
  EXPECT_EQ(load_scene(cases[0].scene_path).platelet.drag, "stokes");
  EXPECT_EQ(cases[0].label, "stokes");
}

TEST(StudyFile, UnknownSweptKeyIsRefused) {
  Fixture fx("bad", "base = \"base.toml\"\n[sweep]\nkey = \"vessel.colour\"\nvalues = [1, 2]\n");
  const std::string e = error_of([&] { expand_study(load_study(fx.study), fx.scenes(), nullptr); });
  EXPECT_NE(e.find("'vessel.colour' is not a scene key"), std::string::npos) << e;
}

TEST(StudyFile, ValueOfTheWrongKindIsRefused) {
  Fixture fx("kind", "base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [\"lots\"]\n");
  const std::string e = error_of([&] { expand_study(load_study(fx.study), fx.scenes(), nullptr); });
  EXPECT_NE(e.find("rbc.hematocrit: expected a number (the swept key)"), std::string::npos) << e;
}

// `hemocosim study` and `bench` (but for stress suites) expand with SceneCheck::placement: a run
// whose particles cannot be placed refuses the study before any run starts, as `hemocosim run`
// would refuse that run.
TEST(StudyFile, ParticlesThatCannotBePlacedAreRefusedNamingTheRun) {
  Fixture fx("dense", "base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1, 0.58]\n");
  EXPECT_NO_THROW(expand_study(load_study(fx.study), fx.scenes(), nullptr));  // values only: left to each run
  const std::string e =
      error_of([&] { expand_study(load_study(fx.study), fx.scenes(), nullptr, SceneCheck::placement); });
  EXPECT_NE(e.find("run 02-0.58 (0.58)"), std::string::npos) << e;
  EXPECT_NE(e.find("rbc.hematocrit: cannot be placed: "), std::string::npos) << e;
  EXPECT_NE(e.find("(the swept key)"), std::string::npos) << e;
}

TEST(StudyFile, ImpossibleValueIsRefusedNamingTheRun) {
  Fixture fx("neg", "base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1, 0.9]\n");
  const std::string e = error_of([&] { expand_study(load_study(fx.study), fx.scenes(), nullptr); });
  EXPECT_NE(e.find("run 02-0.9 (0.9)"), std::string::npos) << e;
  EXPECT_NE(e.find("must be in [0, 0.6)"), std::string::npos) << e;
}

TEST(StudyFile, MalformedStudyFilesAreRefusedInOneLine) {
  const std::pair<const char*, const char*> cases[] = {
      {"[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1]\n", "base: missing"},
      {"base = \"nowhere.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1]\n", "does not exist"},
      {"base = \"base.toml\"\n", "[sweep]: missing"},
      {"base = \"base.toml\"\n[sweep]\nvalues = [0.1]\n", "give exactly one of key"},
      {"base = \"base.toml\"\n[sweep]\nkey = \"a.b\"\nkeys = [\"a.b\"]\nvalues = [1]\n", "give exactly one of key"},
      {"base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = []\n", "sweep.values: missing or empty"},
      {"base = \"base.toml\"\n[sweep]\nkeys = [\"a.b\", \"c.d\"]\nvalues = [[1]]\n", "expected an array of 2 values"},
      {"base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1, 0.2]\nlabels = [\"x\"]\n",
       "1 labels for 2 values"},
      {"base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1, 0.2]\nlabels = [\"x\", \"x\"]\n",
       "same label"},
      {"base = \"base.toml\"\nswept = 1\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1]\n", "unknown key 'swept'"},
      {"base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalue = [0.1]\n", "sweep.value: unknown key"},
      {"base = \"base.toml\"\n[sweep]\nkey = \"run.name\"\nvalues = [\"x\"]\n", "cannot be swept"},
      {"base = \"base.toml\"\n[sweep\n", "line 2"},
  };
  int i = 0;
  for (const auto& [text, want] : cases) {
    Fixture fx("malformed" + std::to_string(i++), text);
    const std::string e = error_of([&] { load_study(fx.study); });
    EXPECT_NE(e.find(want), std::string::npos) << "study:\n" << text << "\nerror: " << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
  EXPECT_NE(error_of([] { load_study("/nonexistent/study.toml"); }).find("no such study file"), std::string::npos);
}

TEST(StudyFile, SetTableOverridesTheBaseInEveryRun) {
  Fixture fx("set", R"(base = "base.toml"
[sweep]
key = "rbc.hematocrit"
values = [0.1, 0.2]
[set.time]
coupling_steps = 7
[set.output]
every_steps = 7
)");
  for (const auto& c : expand_study(load_study(fx.study), fx.scenes(), nullptr)) {
    const Scene sc = load_scene(c.scene_path);
    EXPECT_EQ(sc.time.coupling_steps, 7);
    EXPECT_EQ(sc.output.every_steps, 7);
  }
}

TEST(StudyFile, ReductionShrinksEveryScene) {
  Fixture fx("reduced", R"(base = "base.toml"
[sweep]
key = "vessel.diameter_um"
values = [100, 200]
[set]
vessel.length_um = 600
time.coupling_steps = 200000
)");
  const Reduction red;
  const auto cases = expand_study(load_study(fx.study), fx.scenes(), &red);
  const double d[] = {100e-6, 200e-6};
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Scene sc = load_scene(cases[i].scene_path);
    EXPECT_NEAR(sc.vessel.diameter, d[i] * red.diameter_factor, 1e-15);  // the sweep's ratios kept
    EXPECT_NEAR(sc.vessel.length, red.length_um * 1e-6, 1e-15);
    EXPECT_EQ(sc.mesh.core_cells, red.core_cells);
    EXPECT_EQ(sc.mesh.ring_cells, red.ring_cells);
    EXPECT_EQ(sc.mesh.axial_cells, red.axial_cells);
    EXPECT_NEAR(sc.time.coupling_steps * sc.time.coupling_interval, red.end_time_s, 1e-12);
    EXPECT_EQ(sc.output.every_steps, sc.time.coupling_steps / red.snapshots);
    EXPECT_NE(cases[i].scene_text.find("reduced (--reduced)"), std::string::npos);
  }
  // A scene already shorter than the reduction keeps its own length and time.
  Fixture small("reduced-small", "base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1]\n");
  const Scene sc = load_scene(expand_study(load_study(small.study), small.scenes(), &red)[0].scene_path);
  EXPECT_NEAR(sc.vessel.length, std::min(60.0, red.length_um) * 1e-6, 1e-15);
  EXPECT_EQ(sc.time.coupling_steps, 100);
}

TEST(StudyFile, ReducedRefusesToSweepAKeyItSets) {
  Fixture fx("mesh", "base = \"base.toml\"\n[sweep]\nkey = \"mesh.axial_cells\"\nvalues = [6, 12]\n");
  const Reduction red;
  EXPECT_NE(error_of([&] { expand_study(load_study(fx.study), fx.scenes(), &red); }).find("one that --reduced sets"),
            std::string::npos);
  EXPECT_NO_THROW(expand_study(load_study(fx.study), fx.scenes(), nullptr));
}

TEST(StudyFile, SetDottedRefusesToDescendIntoAValue) {
  toml::table t = toml::parse("[vessel]\ndiameter_um = 40\n");
  EXPECT_NE(error_of([&] { set_dotted(t, "vessel.diameter_um.x", "1"); }).find("is a value, not a table"),
            std::string::npos);
  set_dotted(t, "mesh.core_cells", "3");
  EXPECT_EQ(t.at_path("mesh.core_cells").value<int64_t>(), 3);
}

// The studies of docs/model.md §4 shipped in scenes/studies: every run's scene valid, full and reduced.
// (Their closure keys need the particle closures of issue #4 in model/scene.cpp.)
TEST(ShippedStudies, ExpandToValidScenes) {
  const std::map<std::string, std::size_t> want = {{"shape", 2}, {"diameter", 3}, {"shear-rate", 8}, {"hematocrit", 3}};
  for (const auto& [name, runs] : want) {
    SCOPED_TRACE(name);
    const std::string path = resolve_study(name);
    EXPECT_EQ(fs::path(path).filename(), name + ".toml");
    const Study s = load_study(path);
    EXPECT_EQ(s.size(), runs);
    EXPECT_FALSE(s.expectation.empty());
    ScratchDir dir("shipped-" + name);
    const Reduction red;
    std::vector<StudyCase> full, reduced;
    EXPECT_NO_THROW(full = expand_study(s, dir.str() + "/full", nullptr));
    EXPECT_NO_THROW(reduced = expand_study(s, dir.str() + "/reduced", &red));
    ASSERT_EQ(full.size(), runs);
    for (const auto& c : full) {
      const Scene sc = load_scene(c.scene_path);
      EXPECT_NEAR(sc.vessel.length, 600e-6, 1e-12);
      EXPECT_NEAR(sc.time.coupling_steps * sc.time.coupling_interval, 2.0, 1e-9);
    }
  }
}

// The bifurcation studies' base scenes develop their feeders first (vessel.feeder_develop_s); a
// reduced study develops them no longer than its runs last.
TEST(ShippedStudies, AReducedStudyDevelopsItsFeederNoLongerThanItsRuns) {
  const Study s = load_study(resolve_study("bifurcation-30"));
  ScratchDir dir("shipped-bifurcation-30");
  const Reduction red;
  for (const auto& c : expand_study(s, dir.str() + "/full", nullptr))
    EXPECT_DOUBLE_EQ(load_scene(c.scene_path).vessel.feeder_develop, 0.3);
  for (const auto& c : expand_study(s, dir.str() + "/reduced", &red)) {
    const Scene sc = load_scene(c.scene_path);
    EXPECT_DOUBLE_EQ(sc.vessel.feeder_develop, red.end_time_s);
    EXPECT_NEAR(sc.time.end_time(), red.end_time_s, 1e-12);
  }
}

TEST(ShippedStudies, CalibrationSceneIsThePapersCase) {
  const Scene s = load_scene(std::string(HEMO_SCENES_DIR) + "/calibration.toml");
  EXPECT_NEAR(s.vessel.diameter, 100e-6, 1e-15);
  EXPECT_NEAR(s.vessel.length, 600e-6, 1e-15);
  EXPECT_DOUBLE_EQ(s.rbc.hematocrit, 0.15);
  EXPECT_DOUBLE_EQ(s.driving.wall_shear_rate, 799);
  EXPECT_EQ(s.mesh.cells(), 1536);
  EXPECT_NEAR(s.time.coupling_steps * s.time.coupling_interval, 2.0, 1e-9);
  EXPECT_EQ(s.platelet.drag, "oblate");
  EXPECT_EQ(s.rbc.drag, "rbc_fit");
  EXPECT_EQ(s.rbc.lift, "rbc_lift");
}

TEST(StudyFile, ResolvesNamesAndSaysWhereItLooked) {
  EXPECT_NE(error_of([] { resolve_study("no-such-study"); }).find("scenes/studies/no-such-study.toml"),
            std::string::npos);
}
