// One reduced study end to end with the real nodes over real LCM: `hemocosim study hematocrit
// --reduced` (3 runs, ~1 min on two cores), then the same command again (all skipped).
//
// What it checks of the physics, honestly: the reduced runs cover 0.02 s of physical time, far
// too short for the cell-free layer, margination or D of docs/model.md §4 to settle, so their trends
// are not checked. What a 0.02 s run does show is checked: the tube hematocrit of each run is the
// swept one (the value reached the particle node), and the relative apparent viscosity grows with
// the hematocrit (more cells, more resistance: immediate, no migration needed).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "child_process.h"
#include "synthetic_run.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <sstream>

using namespace hemo;
using namespace hemo::studytest;
namespace fs = std::filesystem;

namespace {

struct Output {
  int exit_code = -1;
  std::string text;
  double seconds = 0;
};

Output hemocosim(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {std::string(HEMO_BIN_DIR) + "/hemocosim"};
  argv.insert(argv.end(), args.begin(), args.end());
  Output o;
  ChildOptions opt;
  opt.merge_stderr = true;
  opt.on_line = [&o](const std::string& line) { o.text += line + "\n"; };
  const auto start = std::chrono::steady_clock::now();
  o.exit_code = run_child(argv, opt).exit_code;
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return o;
}

std::vector<std::map<std::string, std::string>> read_csv(const std::string& path) {
  std::istringstream in(read_text(path));
  std::string line;
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  auto split = [](const std::string& l) {
    std::vector<std::string> v;
    std::stringstream ss(l);
    std::string x;
    while (std::getline(ss, x, ',')) v.push_back(x);
    return v;
  };
  std::getline(in, line);
  header = split(line);
  while (std::getline(in, line)) {
    const auto v = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < v.size(); ++i) row[header[i]] = v[i];
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

TEST(ReducedStudy, HematocritEndToEnd) {
  ScratchDir dir("e2e");
  const std::string out = dir.str() + "/study";
  const std::string study = std::string(HEMO_STUDIES_DIR) + "/hematocrit.toml";

  const Output first = hemocosim({"study", study, "--reduced", "--out", out});
  ASSERT_EQ(first.exit_code, 0) << first.text;
  EXPECT_LT(first.seconds, 120) << "a reduced study should take a couple of minutes at most";
  EXPECT_NE(first.text.find("[1/3 Ht10] done"), std::string::npos) << first.text;
  EXPECT_NE(first.text.find("3 of 3 runs finished"), std::string::npos) << first.text;

  // The report: the reduction stated, one row per swept value, the figures it links.
  const std::string report = read_text(out + "/report.md");
  EXPECT_NE(report.find("**reduced**"), std::string::npos);
  EXPECT_NE(report.find("| rbc.hematocrit | run |"), std::string::npos) << report;
  for (const char* row : {"| 0.1 | 01-Ht10 |", "| 0.15 | 02-Ht15 |", "| 0.2 | 03-Ht20 |"})
    EXPECT_NE(report.find(row), std::string::npos) << row << "\n" << report;
  for (const char* f :
       {"sweep.png", "compare_profiles.png", "compare_msd.png", "01-Ht10_profiles.png", "03-Ht20_msd.png"}) {
    EXPECT_NE(report.find(std::string("](figures/") + f + ")"), std::string::npos) << f;
    ASSERT_TRUE(fs::exists(out + "/figures/" + f)) << f;
    EXPECT_GT(fs::file_size(out + "/figures/" + f), 1000u) << f;
  }

  const auto rows = read_csv(out + "/summary.csv");
  ASSERT_EQ(rows.size(), 3u);
  const double ht[] = {0.10, 0.15, 0.20};
  double previous_viscosity = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    SCOPED_TRACE(rows[i].at("label"));
    EXPECT_EQ(rows[i].at("status"), "ran");
    EXPECT_NEAR(std::stod(rows[i].at("end_time_s")), 0.02, 1e-9);  // the reduction's physical time
    EXPECT_TRUE(fs::exists(rows[i].at("run_dir") + "/study-finished.toml"));
    // The swept hematocrit reached the particle node (placement rounds the count of ~200 cells).
    EXPECT_NEAR(std::stod(rows[i].at("tube_hematocrit")), ht[i], 0.01);
    // Every observable is there (a number, not empty).
    for (const char* k : {"cfl_edge_m", "cfl_profile_m", "D_m2_s", "relative_apparent_viscosity", "margination_index"})
      EXPECT_FALSE(rows[i].at(k).empty()) << k;
    // More cells, more resistance: mu_app/mu growing with Ht. Not "above 1": on the default
    // wall polygon, tangent to the circle, plasma alone's mu_app/mu is below 1 on a coarse mesh
    // (0.964 on the paper's, docs/fluid-verification.md §1).
    const double mu = std::stod(rows[i].at("relative_apparent_viscosity"));
    EXPECT_GT(mu, previous_viscosity);
    previous_viscosity = mu;
  }

  // The same command again: every run finished earlier, nothing is run, the report is rewritten.
  const Output again = hemocosim({"study", study, "--reduced", "--out", out});
  ASSERT_EQ(again.exit_code, 0) << again.text;
  EXPECT_NE(again.text.find("3 finished earlier, 0 to run"), std::string::npos) << again.text;
  EXPECT_EQ(again.text.find("running into"), std::string::npos) << again.text;
  EXPECT_LT(again.seconds, 30);
}

// The open straight tube fed by its feeder against the periodic tube, reduced (`hemocosim study
// open-tube --reduced`: d = 50 um, l = 60 um, 0.02 s). The feeder is a periodic tube at the same
// drop with the same blood, so the open vessel carries the periodic tube's suspension: its tube
// hematocrit, its plasma's mean velocity and its discharge hematocrit within a few per cent (the
// open vessel's cells come and go: measured -1.4 %, +1.4 % and -1.6 %), and each wall carries its
// drop (the open one the drop its inlet realises) to 2 %. A hand-over that failed would empty the
// vessel within the run (its cells cross it in about 0.01 s), and an inlet at the nominal Q
// instead of the feeder's own flow (vessel.inlet = "feeder_at_q") moved the plasma's mean velocity
// by -8.0 % and the tube hematocrit by +7.5 %.
TEST(ReducedStudy, OpenTubeCarriesThePeriodicTubesSuspension) {
  ScratchDir dir("open-tube");
  const std::string out = dir.str() + "/study";
  const Output run = hemocosim({"study", std::string(HEMO_STUDIES_DIR) + "/open-tube.toml", "--reduced", "--out", out});
  ASSERT_EQ(run.exit_code, 0) << run.text;
  const auto rows = read_csv(out + "/summary.csv");
  ASSERT_EQ(rows.size(), 2u);
  ASSERT_EQ(rows[0].at("label"), "periodic");
  ASSERT_EQ(rows[1].at("label"), "open");
  auto value = [&](std::size_t i, const char* key) { return std::stod(rows[i].at(key)); };
  for (const char* key : {"tube_hematocrit", "mean_velocity_m_s", "discharge_hematocrit"}) {
    const double ratio = value(1, key) / value(0, key);
    std::printf("  open / periodic - 1: %s %+.3f\n", key, ratio - 1);
    EXPECT_NEAR(ratio, 1, key == std::string("mean_velocity_m_s") ? 0.03 : 0.05) << key;
  }
  for (std::size_t i = 0; i < 2; ++i) EXPECT_NEAR(value(i, "wall_shear_stress_ratio"), 1, 0.02) << rows[i].at("label");
}
