// hemocosim bench [SUITE...] [--out DIR]: run time against error (issue #6).
//
// A bench suite (scenes/bench/<name>.toml) is a study file (postprocess/study/study_file.h) with
// three more top-level keys:
//
//   reference = 40                  # the converged value of the swept key: one of sweep.values;
//                                   # every run's errors are measured against this run
//   keep_physical_time = true       # sweeping time.coupling_interval_s: derive time.coupling_steps
//                                   # and output.every_steps so the physical time and the
//                                   # snapshot times stay those of the base scene
//   stress = true                   # a stability stress test: no reference; runs the values in
//                                   # order and stops at the first that fails, recording its message
//   floor = true                    # the DEM against bare LIGGGHTS: no reference; each scene's
//                                   # coupling steps are run by hemocosim-dem-bench --floor (no
//                                   # fluid node) instead of `hemocosim run`
//
// The suite is expanded and run by the study machinery (run_study: resume markers, logs), into
// OUT/<suite>/; then every run is measured (bench_metrics.h: the error metrics, defined there
// once) and OUT/bench.csv, OUT/bench.md and OUT/figures/<suite>.png (wall time against error)
// are written. Default OUT: runs/bench.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bench_metrics.h"
#include "study.h"

#include <limits>
#include <string>
#include <vector>

namespace hemo {

struct BenchOptions {
  std::vector<std::string> suites;  // names or files; empty: every suite that is not a stress test
  std::string out = "runs/bench";
  std::string hemocosim;  // the hemocosim executable for the runs; default: this one
  bool no_plot = false;
  bool quiet = false;
  bool check_only = false;  // expand and validate every suite's scenes, print the plan, run nothing
};

struct BenchSuite {
  std::string path;  // the suite file
  std::string name;
  std::string study_path;  // the study file written for run_study (OUT/<name>/bench-study.toml)
  Study study;
  int reference = -1;  // index of the reference run; -1 for a stress or floor suite
  bool stress = false;
  bool floor = false;
};

// Reads a suite, writes its study file into out_dir/<name>/ and loads it; throws StudyError.
BenchSuite load_bench_suite(const std::string& path, const std::string& out_dir);

// A suite named on the command line: a file, scenes/bench/<name>.toml (here or in the source
// tree), or a group: every scenes/bench/<name>-*.toml ("stress"). Empty: all non-stress suites.
std::vector<std::string> resolve_bench_suites(const std::vector<std::string>& names);

struct BenchRow {
  std::string suite, keys, value, label, run_dir, status, message;
  bool reference = false;
  double wall_s = 0;
  bench::RunCost cost;
  bool measured = false;
  bench::RunMeasures measures;
  bool has_errors = false;
  bench::BenchErrors errors;
  double speedup = std::numeric_limits<double>::quiet_NaN();  // reference wall / this wall; NaN without errors
  bool has_floor = false;
  bench::DemFloor floor;  // a floor suite's run (hemocosim-dem-bench's figures)
};

struct BenchResult {
  std::vector<BenchRow> rows;
  std::vector<std::string> figures;
  int failed = 0;  // runs of non-stress suites that failed
};

BenchResult run_bench(const BenchOptions& opt);
// --check: each suite loaded and its scenes expanded (into a temporary folder, removed after)
// and validated, stress suites included; returns the plan as printable lines. Throws StudyError
// (naming the suite file) on the first bad suite or scene.
std::vector<std::string> check_bench(const BenchOptions& opt);
int bench_command(const BenchOptions& opt);

// bench.csv and the tables of bench.md (exposed for the tests).
std::string bench_csv(const std::vector<BenchRow>& rows);

}  // namespace hemo
