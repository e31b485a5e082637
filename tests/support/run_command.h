// What the tests that run programs share: running a command, finding the built programs,
// fresh run directories, and reading a run's metrics.csv.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <map>
#include <string>
#include <vector>
#include <utility>

namespace hemo::test {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
  double seconds = 0;
};

// Runs a shell command, capturing its output.
CommandResult run(const std::string& command);

std::string bin(const std::string& program);         // a built program
std::string fresh_run_dir(const std::string& name);  // an unused path under the temp dir
std::string file_text(const std::string& path);      // a file's whole text ("" if it cannot be read)

// A `hemocosim run` that several tests read, made once a suite. gtest_discover_tests starts every
// test in a process of its own, so a run held in a function-local static was made again by each
// test that read it; this one is kept on disk (HEMO_SHARED_RUNS_DIR, under the build tree; ctest
// empties it before the first test that needs it, fixture shared_runs) under the SHA-256 of all
// that makes it: the scene's text, the options, the bytes of every hemocosim* program of the build,
// and the installed packages (dpkg's status file, by size and time: the engines, OpenFOAM and
// LIGGGHTS, come from Debian). A rebuilt program or another scene is another run. A run is made in a directory of its
// own and renamed into place once it ended well: a half-written or failed run is never taken (a
// failed one stays beside, dot-named, for a look). Runs are for reading: a test that resumes,
// restarts or otherwise changes a run makes its own.
struct SharedRun {
  std::string dir;       // the run directory
  std::string scene;     // the scene file it ran (for a later run of the same scene)
  CommandResult result;  // its `hemocosim run`, as when it was made
};
SharedRun shared_run(const std::string& scene_text, const std::string& options = "");

// metrics.csv of a run: (node, name) -> step -> value
using Metrics = std::map<std::pair<std::string, std::string>, std::map<long, double>>;
Metrics read_metrics(const std::string& run_dir);
// One series' values over the coupled steps (step 0, the start-up, left out; empty when absent).
std::vector<double> over_steps(const Metrics& m, const std::string& node, const std::string& name);
// The last value of one series (throws when absent).
double last(const Metrics& m, const std::string& node, const std::string& name);

// The line of the coordinator's output that starts with "hemocosim: error:" (empty if none).
std::string error_line(const std::string& output);

}  // namespace hemo::test
