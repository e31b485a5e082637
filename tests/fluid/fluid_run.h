// Running the real fluid node under the coordinator from tests, with a prescribed or real
// particle node, and reading back what the run wrote (metrics.csv, recorded fluid states).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "run_command.h"

#include <map>
#include <string>
#include <vector>

namespace hemo::fluidtest {

using hemo::test::bin;
using hemo::test::CommandResult;
using hemo::test::error_line;
using hemo::test::fresh_run_dir;
using hemo::test::last;
using hemo::test::Metrics;
using hemo::test::read_metrics;
using hemo::test::run;

// A scene for a fluid verification run. Text, so tests can vary anything.
struct SceneSpec {
  std::string name = "fluid-test";
  double diameter_um = 100, length_um = 600;
  std::string vessel;  // more [vessel] keys (the shape and its parameters)
  int core = 4, ring = 3, axial = 2;
  std::string mesh;    // more [mesh] keys (a surface vessel's cell size)
  std::string wall_polygon = "circumscribed";  // mesh.wall_polygon
  std::string driving = "wall_shear_rate_per_s = 799";
  double dt = 2e-3;
  long steps = 20;
  long every_steps = 100000;
  double relaxation_times = 0;   // time.coupling_relaxation_times (0: fixed intervals)
  std::string particle_command;  // empty: the real particle node
  std::string fluid_command;     // empty: the real fluid node
  std::string extra;             // more TOML (species, run keys)
  std::string text() const;
};

struct RunResult {
  std::string dir;
  CommandResult command;
};

// Writes the scene next to the run directory and runs `hemocosim run` on it.
RunResult run_scene(const SceneSpec& spec, const std::string& extra_cli = "");

// A fluid state recorded by hemocosim-prescribed-particles --record.
struct CellState {
  double x, y, z, volume, phi;
  double u[3];
  double grad[9];
  double pressure_gradient[3];  // Pa/m (zeros when the state carried none)
  double viscous[3];            // N/m^3, div tau (likewise)
};
std::vector<CellState> read_state(const std::string& csv_path);

}  // namespace hemo::fluidtest
