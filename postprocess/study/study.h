// hemocosim study NAME_OR_FILE: every scene of a study, one after the other, resuming where a
// previous attempt stopped; then the observables of each run, the figures and report.md.
//
// OUT/ (default runs/study-<name>, or runs/study-<name>-reduced):
//   study.toml               copy of the study file
//   scenes/<NN-label>.toml   the scene of each run, as generated and validated
//   runs/<NN-label>/         the run directories (`hemocosim run --out`), each with
//                            study-finished.toml once the run ended cleanly
//   feeder-develop/<sha256>/ a developed feeder (vessel.feeder_develop_s), run once for the runs
//                            whose feeder's scene is the same (`hemocosim run --feeder-cache`)
//   logs/<NN-label>.log      what `hemocosim run` printed
//   figures/                 `hemocosim plot` of all finished runs
//   summary.csv, report.md   the observables per swept value; the report with the figures
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "study_file.h"

#include <functional>
#include <string>
#include <vector>

namespace hemo {

// Runs one scene into run_dir (which does not exist yet), appending its output to log_path;
// returns the exit code (0: finished cleanly). `progress` gets the run's progress lines.
using SceneRunner =
    std::function<int(const std::string& scene_path, const std::string& run_dir, const std::string& log_path,
                      const std::function<void(const std::string&)>& progress)>;

struct StudyOptions {
  std::string study;  // name (scenes/studies/<name>.toml) or file
  std::string out;    // default runs/study-<name>[-reduced]
  bool reduced = false;
  bool no_plot = false;     // skip the figures (report without them)
  std::string hemocosim;    // the hemocosim executable for child runs; default: this one
  SceneRunner runner;       // default: `hemocosim run SCENE --out RUN_DIR` as a child process
  bool quiet = false;       // no progress lines
  bool check_only = false;  // expand and validate every scene, print the plan, run nothing
  bool no_analysis = false;  // the runner makes no coupled runs (bench floor suites): no observables
  // Whether every run's particles are placed before any run starts, a run that cannot be placed
  // refusing the study (as `hemocosim run` would refuse that run). false: each run is left to
  // refuse its own (bench stress suites, whose runs are there to find where they fail).
  bool check_placement = true;
};

// What became of one run.
struct StudyRunStatus {
  StudyCase study_case;
  std::string run_dir;
  enum class State { ran, skipped, failed } state = State::failed;
  std::string why;    // redone because..., failed because...
  double wall_s = 0;  // wall time of the run (from its marker when skipped)
};

struct StudyResult {
  std::string out;
  std::vector<StudyRunStatus> runs;
  std::string report_path;
  int failed() const;
};

// Throws StudyError on a bad study file or scene; a run that fails is recorded, the others go
// on, and the report says which failed.
StudyResult run_study(const StudyOptions& opt);
int study_command(const StudyOptions& opt);

// A folder under the system's temporary directory, named for the process, removed with all it
// holds when this goes out of scope (the scenes of a --check).
class ScratchFolder {
 public:
  explicit ScratchFolder(const std::string& prefix);
  ~ScratchFolder();
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;
  std::string path() const { return path_; }

 private:
  std::string path_;
};

// --check: the study's scenes expanded (into a temporary folder, removed after) and validated;
// returns the plan as printable lines. Throws StudyError like run_study.
std::vector<std::string> check_study(const StudyOptions& opt);

// The marker of a run that ended cleanly, and whether a run directory holds one for this scene.
inline constexpr const char* kFinishedMarker = "study-finished.toml";
void write_finished_marker(const std::string& run_dir, const std::string& scene_text, double wall_s);
// True if run_dir has the marker and it was written for exactly this scene text; `why` says
// why not ("no run yet", "unfinished", "the scene changed").
bool run_finished(const std::string& run_dir, const std::string& scene_text, std::string* why = nullptr,
                  double* wall_s = nullptr);

}  // namespace hemo
