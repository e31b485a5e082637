// `hemocosim study` without the nodes: a stand-in runner writes synthetic runs, so that resume
// (finished runs skipped, unfinished and failed ones redone), the analysis of every run and the
// report can be checked in a second.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "study.h"
#include "synthetic_run.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>

using namespace hemo;
using namespace hemo::studytest;
namespace fs = std::filesystem;

namespace {

// Counts calls per run label and writes a synthetic run, or fails for the labels in `fail`.
struct FakeRunner {
  std::map<std::string, int> calls;
  std::set<std::string> fail;
  std::set<std::string> resumed;  // runs whose directory the study left for `hemocosim resume`
  SceneRunner runner() {
    return [this](const std::string& scene, const std::string& run_dir, const std::string& log,
                  const std::function<void(const std::string&)>&) {
      const std::string label = fs::path(run_dir).filename().string();
      ++calls[label];
      // `hemocosim run` refuses a non-empty directory: the study must have cleared it, unless
      // the run goes on from its checkpoint.
      if (fs::exists(run_dir)) {
        EXPECT_TRUE(fs::exists(run_dir + "/checkpoints")) << run_dir;
        resumed.insert(label);
        fs::remove_all(run_dir);  // what `hemocosim resume` leaves is a whole run again
      }
      write_text(log, "fake run of " + scene + "\n");
      if (fail.count(label)) {
        fs::create_directories(run_dir);
        fs::copy_file(scene, run_dir + "/scene.toml");
        write_text(log, "hemocosim: error: particle node failed at step 3: made up\n");
        return 1;
      }
      SyntheticRun spec;
      spec.seed = static_cast<unsigned>(calls.size());
      write_synthetic_run(run_dir, scene, spec);
      return 0;
    };
  }
  int total() const {
    int n = 0;
    for (const auto& [k, v] : calls) n += v;
    return n;
  }
};

struct StudyFixture {
  ScratchDir dir;
  StudyOptions opt;
  FakeRunner fake;
  explicit StudyFixture(const std::string& name, bool plot = false) : dir(name) {
    write_text(dir.str() + "/base.toml", kSmallBaseScene);
    write_text(dir.str() + "/ht.toml",
               "title = \"test\"\nexpectation = \"nothing in particular\"\nbase = \"base.toml\"\n"
               "[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1, 0.15, 0.2]\nlabels = [\"a\", \"b\", \"c\"]\n");
    opt.study = dir.str() + "/ht.toml";
    opt.out = dir.str() + "/out";
    opt.quiet = true;
    opt.no_plot = !plot;
  }
  StudyResult run() {
    opt.runner = fake.runner();
    return run_study(opt);
  }
  std::string run_dir(const std::string& d) const { return opt.out + "/runs/" + d; }
};

std::vector<StudyRunStatus::State> states(const StudyResult& r) {
  std::vector<StudyRunStatus::State> s;
  for (const auto& x : r.runs) s.push_back(x.state);
  return s;
}

using State = StudyRunStatus::State;

}  // namespace

TEST(StudyResume, FinishedRunsAreNotRunAgain) {
  StudyFixture fx("finished");
  auto r = fx.run();
  EXPECT_EQ(fx.fake.total(), 3);
  EXPECT_EQ(states(r), (std::vector<State>{State::ran, State::ran, State::ran}));
  for (const char* d : {"01-a", "02-b", "03-c"}) EXPECT_TRUE(fs::exists(fx.run_dir(d) + "/" + kFinishedMarker)) << d;

  r = fx.run();
  EXPECT_EQ(fx.fake.total(), 3);  // nothing ran again
  EXPECT_EQ(states(r), (std::vector<State>{State::skipped, State::skipped, State::skipped}));
  EXPECT_EQ(r.failed(), 0);
}

TEST(StudyResume, UnfinishedRunIsRedone) {
  StudyFixture fx("unfinished");
  fx.run();
  // A run that was stopped half-way: its directory exists but holds no marker.
  fs::remove(fx.run_dir("02-b") + "/" + kFinishedMarker);
  const auto r = fx.run();
  EXPECT_EQ(fx.fake.calls["01-a"], 1);
  EXPECT_EQ(fx.fake.calls["02-b"], 2);
  EXPECT_EQ(fx.fake.calls["03-c"], 1);
  EXPECT_EQ(states(r), (std::vector<State>{State::skipped, State::ran, State::skipped}));
  EXPECT_NE(r.runs[1].why.find("unfinished"), std::string::npos) << r.runs[1].why;
}

// An unfinished run of the same scene with a complete checkpoint (both nodes, sealed) is left for the
// runner to go on from; one whose particles never completed theirs is redone from scratch.
TEST(StudyResume, UnfinishedRunWithACheckpointGoesOnFromIt) {
  StudyFixture fx("checkpointed");
  fx.run();
  for (const char* d : {"02-b", "03-c"}) {
    fs::remove(fx.run_dir(d) + "/" + kFinishedMarker);
    fs::create_directories(fx.run_dir(d) + "/checkpoints/step-7/fluid");
  }
  fs::create_directories(fx.run_dir("02-b") + "/checkpoints/step-7/particles");
  std::ofstream(fx.run_dir("02-b") + "/checkpoints/step-7/SHA256SUMS") << "\n";  // sealed by the coordinator
  fs::create_directories(fx.run_dir("03-c") + "/checkpoints/step-7/particles.partial");
  const auto r = fx.run();
  EXPECT_EQ(states(r), (std::vector<State>{State::skipped, State::ran, State::ran}));
  EXPECT_EQ(fx.fake.resumed, std::set<std::string>{"02-b"});
  EXPECT_NE(r.runs[1].why.find("goes on from its checkpoint of step 7"), std::string::npos) << r.runs[1].why;
  EXPECT_NE(r.runs[2].why.find("unfinished (no"), std::string::npos) << r.runs[2].why;
}

TEST(StudyResume, FailedRunIsReportedAndRetriedNextTime) {
  StudyFixture fx("failed");
  fx.fake.fail = {"03-c"};
  auto r = fx.run();
  EXPECT_EQ(states(r), (std::vector<State>{State::ran, State::ran, State::failed}));
  EXPECT_EQ(r.failed(), 1);
  EXPECT_FALSE(fs::exists(fx.run_dir("03-c") + "/" + kFinishedMarker));
  EXPECT_NE(r.runs[2].why.find("made up"), std::string::npos) << r.runs[2].why;
  const std::string report = read_text(r.report_path);
  EXPECT_NE(report.find("| 0.2 | 03-c |"), std::string::npos) << report;
  EXPECT_NE(report.find("failed"), std::string::npos);

  fx.fake.fail.clear();
  r = fx.run();
  EXPECT_EQ(states(r), (std::vector<State>{State::skipped, State::skipped, State::ran}));
  EXPECT_EQ(fx.fake.calls["03-c"], 2);
  EXPECT_EQ(fx.fake.calls["01-a"], 1);
}

TEST(StudyResume, ChangedSceneIsRedone) {
  StudyFixture fx("changed");
  fx.run();
  // Another hematocrit for run "b": same directory name, another scene.
  write_text(fx.opt.study, read_text(fx.opt.study).replace(read_text(fx.opt.study).find("0.15"), 4, "0.16"));
  const auto r = fx.run();
  EXPECT_EQ(states(r), (std::vector<State>{State::skipped, State::ran, State::skipped}));
  EXPECT_NE(r.runs[1].why.find("scene changed"), std::string::npos) << r.runs[1].why;
}

TEST(StudyResume, MarkerMatchesOnlyItsScene) {
  ScratchDir dir("marker");
  std::string why;
  EXPECT_FALSE(run_finished(dir.str() + "/none", "scene", &why));
  EXPECT_EQ(why, "no run yet");
  write_finished_marker(dir.str(), "scene A", 12.5);
  double wall = 0;
  EXPECT_TRUE(run_finished(dir.str(), "scene A", &why, &wall));
  EXPECT_DOUBLE_EQ(wall, 12.5);
  EXPECT_FALSE(run_finished(dir.str(), "scene B", &why));
  EXPECT_NE(why.find("scene changed"), std::string::npos);
}

TEST(StudyResume, RefusesToClearADirectoryThatIsNoRun) {
  StudyFixture fx("foreign");
  fs::create_directories(fx.run_dir("01-a"));
  write_text(fx.run_dir("01-a") + "/precious.txt", "not a run\n");
  EXPECT_THROW(fx.run(), StudyError);
  EXPECT_TRUE(fs::exists(fx.run_dir("01-a") + "/precious.txt"));
}

TEST(StudyReport, TableOfObservablesSummaryAndFigures) {
  StudyFixture fx("report", /*plot=*/true);
  const auto r = fx.run();
  ASSERT_EQ(r.failed(), 0);
  const std::string report = read_text(r.report_path);
  EXPECT_NE(report.find("# Study: ht"), std::string::npos) << report;
  EXPECT_NE(report.find("nothing in particular"), std::string::npos);
  EXPECT_NE(report.find("| rbc.hematocrit | run | t end (s) |"), std::string::npos) << report;
  for (const char* row : {"| 0.1 | 01-a |", "| 0.15 | 02-b |", "| 0.2 | 03-c |"})
    EXPECT_NE(report.find(row), std::string::npos) << row;
  EXPECT_NE(report.find("full size"), std::string::npos);
  // Figures: the comparisons first, then each run's; every one linked relative to the report.
  for (const char* f : {"figures/sweep.png", "figures/compare_profiles.png", "figures/compare_msd.png",
                        "figures/01-a_profiles.png", "figures/03-c_msd.png"}) {
    EXPECT_NE(report.find(std::string("](") + f + ")"), std::string::npos) << f;
    ASSERT_TRUE(fs::exists(fx.opt.out + "/" + f)) << f;
    EXPECT_GT(fs::file_size(fx.opt.out + "/" + f), 1000u) << f;
  }
  EXPECT_LT(report.find("sweep.png"), report.find("01-a_profiles.png"));
  const std::string csv = read_text(fx.opt.out + "/summary.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4);
  EXPECT_NE(csv.find("2,b,0.15,ran,"), std::string::npos) << csv;
  EXPECT_TRUE(fs::exists(fx.opt.out + "/study.toml"));
  EXPECT_TRUE(fs::exists(fx.opt.out + "/scenes/02-b.toml"));
}

TEST(StudyReport, ReducedStudyStatesTheReduction) {
  StudyFixture fx("reduced");
  fx.opt.reduced = true;
  const auto r = fx.run();
  const std::string report = read_text(r.report_path);
  EXPECT_NE(report.find("**reduced**"), std::string::npos) << report;
  EXPECT_NE(report.find(Reduction{}.describe()), std::string::npos);
  EXPECT_NE(report.find("Figures not drawn: --no-plot"), std::string::npos);
}
