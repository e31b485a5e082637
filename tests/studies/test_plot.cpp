// `hemocosim plot` on synthetic run directories: the PNGs exist and are not empty, analysis runs
// first when needed, and the errors are one clear line.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "plot.h"
#include "synthetic_run.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <thread>

using namespace hemo;
using namespace hemo::studytest;
namespace fs = std::filesystem;

namespace {

std::string scene_with_shear(const std::string& dir, double shear) {
  const std::string path = dir + "/scene-" + std::to_string(static_cast<int>(shear)) + ".toml";
  write_text(path,
             "[vessel]\ndiameter_um = 40\nlength_um = 60\n[mesh]\ncore_cells = 2\nring_cells = 2\naxial_cells = "
             "6\n[driving]\nwall_shear_rate_per_s = " +
                 std::to_string(shear) + "\n[rbc]\nhematocrit = 0.1\n[platelet]\nnumber_density_per_ul = 300000\n");
  return path;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

void expect_png(const std::string& path) {
  ASSERT_TRUE(fs::exists(path)) << path;
  EXPECT_GT(fs::file_size(path), 1000u) << path;
  EXPECT_EQ(read_text(path).substr(1, 3), "PNG") << path;
}

}  // namespace

TEST(Plot, FindsItsScriptAndAPythonWithMatplotlib) {
  EXPECT_TRUE(fs::exists(find_plot_script()));
  EXPECT_NO_THROW(find_python());
}

TEST(Plot, OneRunGivesProfilesAndMsd) {
  ScratchDir dir("plot-one");
  const std::string run = dir.str() + "/run-a";
  write_synthetic_run(run, scene_with_shear(dir.str(), 800));
  PlotOptions opt;
  opt.run_dirs = {run};
  opt.quiet = true;
  const auto files = plot_runs(opt);
  EXPECT_EQ(files, (std::vector<std::string>{run + "/figures/run-a_profiles.png", run + "/figures/run-a_msd.png",
                                             run + "/figures/run-a_balance.png"}));
  for (const auto& f : files) expect_png(f);
  EXPECT_TRUE(fs::exists(run + "/analysis.json"));  // analysed first
  EXPECT_TRUE(fs::exists(run + "/profiles.csv"));
}

// A bifurcation's run has no radial profiles: its figures are the outlets' shares (over time and
// against the blood's) and its branches' layer, H_D and platelet flux.
TEST(Plot, ASurfaceRunGivesItsPhaseSeparationAndBranches) {
  ScratchDir dir("plot-surface");
  const std::string scene = dir.str() + "/bifurcation.toml";
  write_text(scene,
             "[vessel]\ndiameter_um = 40\nlength_um = 80\nshape = \"bifurcation\"\ndaughter_length_um = 120\nends = "
             "\"open\"\n[mesh]\nsurface_cell_size_um = 8\n[driving]\nwall_shear_rate_per_s = 800\n[rbc]\nhematocrit "
             "= 0.1\n[platelet]\nnumber_density_per_ul = 300000\n");
  const std::string run = dir.str() + "/bif";
  write_synthetic_run(run, scene);
  PlotOptions opt;
  opt.run_dirs = {run};
  opt.quiet = true;
  const auto files = plot_runs(opt);
  EXPECT_EQ(files,
            (std::vector<std::string>{run + "/figures/bif_phase_separation.png", run + "/figures/bif_branches.png"}));
  for (const auto& f : files) expect_png(f);
  EXPECT_FALSE(ensure_analysis(run));  // a surface run's analysis is current without a tube's parts
}

TEST(Plot, SeveralRunsGiveTheSweepAndComparisons) {
  ScratchDir dir("plot-sweep");
  PlotOptions opt;
  for (double shear : {150.0, 799.0, 1650.0}) {
    const std::string run = dir.str() + "/runs/g" + std::to_string(static_cast<int>(shear));
    SyntheticRun spec;
    spec.drift = shear / 2000;
    write_synthetic_run(run, scene_with_shear(dir.str(), shear), spec);
    opt.run_dirs.push_back(run);
  }
  opt.out = dir.str() + "/figures";
  opt.quiet = true;
  const auto files = plot_runs(opt);  // the swept key is found: the one that differs
  EXPECT_EQ(files.size(), 3u * 3 + 3);
  for (const char* f : {"sweep.png", "compare_profiles.png", "compare_msd.png", "g799_profiles.png", "g1650_msd.png"})
    expect_png(opt.out + "/" + f);
  // With an explicit key and labels too.
  opt.key = "driving.wall_shear_rate_per_s";
  opt.labels = {"low", "mid", "high"};
  EXPECT_EQ(plot_runs(opt).size(), 12u);
}

TEST(Plot, RunsWithTheSameNameDoNotOverwriteEachOther) {
  ScratchDir dir("plot-same");
  PlotOptions opt;
  for (const char* parent : {"x", "y"}) {
    const std::string run = dir.str() + "/" + parent + "/run";
    write_synthetic_run(run, scene_with_shear(dir.str(), 800));
    opt.run_dirs.push_back(run);
  }
  opt.out = dir.str() + "/figures";
  opt.quiet = true;
  plot_runs(opt);
  expect_png(opt.out + "/01-run_profiles.png");
  expect_png(opt.out + "/02-run_profiles.png");
}

TEST(Plot, AnalysisIsRedoneOnlyWhenStale) {
  ScratchDir dir("plot-stale");
  const std::string run = dir.str() + "/run";
  write_synthetic_run(run, scene_with_shear(dir.str(), 800));
  EXPECT_TRUE(ensure_analysis(run));
  EXPECT_FALSE(ensure_analysis(run));
  // A newer particles.h5 (the run was redone) makes the analysis stale.
  fs::last_write_time(run + "/particles.h5", fs::last_write_time(run + "/analysis.json") + std::chrono::seconds(2));
  EXPECT_TRUE(ensure_analysis(run));
  EXPECT_TRUE(ensure_analysis(run, /*force=*/true));
  // An analysis.json of an older hemocosim, without the declaration the sweep figure is drawn
  // from, is redone even when it is newer than the run.
  fs::last_write_time(run + "/particles.h5", fs::last_write_time(run + "/analysis.json") - std::chrono::seconds(10));
  EXPECT_FALSE(ensure_analysis(run));
  auto json = nlohmann::json::parse(read_text(run + "/analysis.json"));
  json.erase("observables");
  write_text(run + "/analysis.json", json.dump(2));
  EXPECT_TRUE(ensure_analysis(run));
  EXPECT_TRUE(nlohmann::json::parse(read_text(run + "/analysis.json")).contains("observables"));
  EXPECT_FALSE(ensure_analysis(run));
  // So is one without the momentum balance over time (the balance figure's data).
  json = nlohmann::json::parse(read_text(run + "/analysis.json"));
  json["momentum_balance"].erase("over_time");
  write_text(run + "/analysis.json", json.dump(2));
  EXPECT_TRUE(ensure_analysis(run));
  EXPECT_FALSE(ensure_analysis(run));
}

TEST(Plot, ErrorsAreOneClearLine) {
  ScratchDir dir("plot-errors");
  PlotOptions opt;
  opt.quiet = true;
  opt.run_dirs = {dir.str() + "/missing"};
  EXPECT_EQ(error_of([&] { plot_runs(opt); }), dir.str() + "/missing: no such run directory");

  const std::string empty = dir.str() + "/no-snapshots";
  SyntheticRun none;
  none.snapshots = 0;
  write_synthetic_run(empty, scene_with_shear(dir.str(), 800), none);
  opt.run_dirs = {empty};
  const std::string e = error_of([&] { plot_runs(opt); });
  EXPECT_NE(e.find("no snapshots"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;

  const std::string bare = dir.str() + "/bare";
  fs::create_directories(bare);
  opt.run_dirs = {bare};
  EXPECT_NE(error_of([&] { plot_runs(opt); }).find("not a run directory"), std::string::npos);

  opt.run_dirs = {empty, bare};
  opt.labels = {"one"};
  EXPECT_NE(error_of([&] { plot_runs(opt); }).find("1 labels for 2 runs"), std::string::npos);
}
