// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_run.h"

#include <sys/wait.h>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

namespace hemo::fluidtest {

std::string SceneSpec::text() const {
  std::ostringstream s;
  s.precision(17);
  s << "[run]\nname = \"" << name << "\"\nnode_timeout_s = 30\n";
  if (!particle_command.empty()) s << "particle_command = \"" << particle_command << "\"\n";
  if (!fluid_command.empty()) s << "fluid_command = \"" << fluid_command << "\"\n";
  s << "\n[vessel]\ndiameter_um = " << diameter_um << "\nlength_um = " << length_um << "\n" << vessel << "\n"
    << "\n[mesh]\ncore_cells = " << core << "\nring_cells = " << ring << "\naxial_cells = " << axial
    << "\nwall_polygon = \"" << wall_polygon << "\"\n" << mesh << "\n"
    << "\n[driving]\n"
    << driving << "\n"
    << "\n[time]\ncoupling_interval_s = " << dt << "\ncoupling_steps = " << steps << "\n"
    << (relaxation_times > 0 ? "coupling_relaxation_times = " + std::to_string(relaxation_times) + "\n" : "")
    << "\n[output]\nevery_steps = " << every_steps << "\n\n"
    << extra << "\n";
  return s.str();
}

RunResult run_scene(const SceneSpec& spec, const std::string& extra_cli) {
  RunResult r;
  r.dir = fresh_run_dir(spec.name);
  const std::string scene = r.dir + ".toml";
  std::ofstream(scene) << spec.text();
  r.command = run(bin("hemocosim") + " run " + scene + " --out " + r.dir + " " + extra_cli);
  return r;
}

std::vector<CellState> read_state(const std::string& csv_path) {
  std::ifstream in(csv_path);
  if (!in) throw std::runtime_error("no recorded fluid state " + csv_path);
  std::vector<CellState> cells;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string item;
    std::vector<double> v;
    while (std::getline(ss, item, ',')) v.push_back(std::stod(item));
    if (v.size() != 24) throw std::runtime_error("bad line in " + csv_path + ": " + line);
    CellState c{};
    c.x = v[1];
    c.y = v[2];
    c.z = v[3];
    c.volume = v[4];
    c.phi = v[5];
    for (int k = 0; k < 3; ++k) c.u[k] = v[6 + k];
    for (int k = 0; k < 9; ++k) c.grad[k] = v[9 + k];
    for (int k = 0; k < 3; ++k) c.pressure_gradient[k] = v[18 + k];
    for (int k = 0; k < 3; ++k) c.viscous[k] = v[21 + k];
    cells.push_back(c);
  }
  return cells;
}

}  // namespace hemo::fluidtest
