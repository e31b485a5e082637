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
