// Running hemocosim from tests and reading what a run wrote.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <map>
#include <string>
#include <vector>

namespace hemo::test {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
  double seconds = 0;
};

// Runs a shell command, capturing its output.
CommandResult run(const std::string& command);

std::string bin(const std::string& program);              // path of a built program
std::string scene(const std::string& name);               // path of a test scene
std::string fresh_run_dir(const std::string& name);       // an empty path under the test temp dir

// metrics.csv of a run: (node, name) -> step -> value
using Metrics = std::map<std::pair<std::string, std::string>, std::map<long, double>>;
Metrics read_metrics(const std::string& run_dir);

// One particle snapshot of particles.h5.
struct Snapshot {
  double time_s = 0;
  std::vector<long long> id;
  std::vector<signed char> species;
  std::vector<double> position, velocity;  // N x 3, row-major
};
std::vector<std::string> snapshot_names(const std::string& h5_path);
Snapshot read_snapshot(const std::string& h5_path, const std::string& name);

}  // namespace hemo::test
