// Running the real fluid node under the coordinator from tests, with a prescribed or real
// particle node, and reading back what the run wrote (metrics.csv, recorded fluid states).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <map>
#include <string>
#include <vector>

namespace hemo::fluidtest {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
  double seconds = 0;
};

CommandResult run(const std::string& command);
std::string bin(const std::string& program);  // a built program
std::string fresh_run_dir(const std::string& name);

// A scene for a fluid verification run. Text, so tests can vary anything.
struct SceneSpec {
  std::string name = "fluid-test";
  double diameter_um = 100, length_um = 600;
  int core = 4, ring = 3, axial = 2;
  std::string driving = "wall_shear_rate_per_s = 799";
  double dt = 2e-3;
  long steps = 20;
  long every_steps = 100000;
  std::string particle_command;   // empty: the real particle node
  std::string fluid_command;      // empty: the real fluid node
  std::string extra;              // more TOML (species, run keys)
  std::string text() const;
};

struct RunResult {
  std::string dir;
  CommandResult command;
};

// Writes the scene next to the run directory and runs `hemocosim run` on it.
RunResult run_scene(const SceneSpec& spec, const std::string& extra_cli = "");

// metrics.csv: (node, name) -> step -> value
using Metrics = std::map<std::pair<std::string, std::string>, std::map<long, double>>;
Metrics read_metrics(const std::string& run_dir);
// The last value of one series (throws when absent).
double last(const Metrics& m, const std::string& node, const std::string& name);

// A fluid state recorded by hemocosim-prescribed-particles --record.
struct CellState {
  double x, y, z, volume, phi;
  double u[3];
  double grad[9];
};
std::vector<CellState> read_state(const std::string& csv_path);

// The line of the coordinator's output that starts with "hemocosim: error:" (empty if none).
std::string error_line(const std::string& output);

}  // namespace hemo::fluidtest
