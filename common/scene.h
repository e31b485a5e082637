// A scene: one TOML file that says everything about a run (MODEL.md, DESIGN.md "Scenes").
// Parsed once, into SI units, with every unknown key and impossible value refused.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hemo {

struct Vessel {
  double diameter = 0;  // m
  double length = 0;    // m, periodic along z
  double radius() const { return diameter / 2; }
};

// O-grid of a disk extruded along z: a core_cells x core_cells square core and four blocks of
// core_cells x ring_cells around it; cross-section has core_cells^2 + 4 core_cells ring_cells cells.
// The paper's 1,536 cells: core 4, ring 3 (64 per section), axial 24.
struct MeshSpec {
  int core_cells = 4;
  int ring_cells = 3;
  int axial_cells = 24;
  int cells() const { return (core_cells * core_cells + 4 * core_cells * ring_cells) * axial_cells; }
};

struct Plasma {
  double density = 1025;       // kg/m^3
  double viscosity = 1.2e-3;   // Pa s (dynamic)
  double kinematic_viscosity() const { return viscosity / density; }
};

// The flow is driven by the mean pressure drop over the vessel length; a scene gives either it
// or the wall shear rate it produces, gamma_w = d dP / (4 mu l).
struct Driving {
  double pressure_drop = 0;    // Pa over the vessel length
  double wall_shear_rate = 0;  // 1/s
};

struct Species {
  std::string name;               // "rbc" or "platelet"
  bool present = false;
  double diameter = 0;            // m, placeholder sphere (contacts, Re, reference areas)
  double mass = 0;                // kg
  double volume = 0;              // m^3, the cell's own volume (deposited as solid fraction)
  double hematocrit = 0;          // rbc: volume fraction of the vessel
  double number_density = 0;      // platelet: per m^3 of blood
  std::string drag = "stokes";    // closure chosen by name
  std::string lift = "none";
};

struct Contact {
  double cell_youngs_modulus = 7.5e5;   // Pa
  double wall_youngs_modulus = 7.5e7;   // Pa
  double cell_poisson_ratio = 0.45;
  double wall_poisson_ratio = 0.18;
  double cell_cell_restitution = 0.9;
  double cell_wall_restitution = 0.85;
  double friction = 0.3;
};

struct Timing {
  double coupling_interval = 1e-5;  // s, one fluid step and N DEM substeps
  long coupling_steps = 10;
  int dem_substeps = 0;             // 0: derived from contact time and drag relaxation
};

struct Output {
  long every_steps = 10;            // particle snapshot every this many coupling steps (and last)
};

struct RunSettings {
  std::string name = "run";
  unsigned seed = 1;
  double node_timeout = 30;         // s without a heartbeat before a node is declared dead
  double startup_timeout = 120;     // s for both nodes to finish step 0
  double step_timeout = 3600;       // s for both nodes to finish any later step
  int fluid_ranks = 1;              // MPI ranks of the fluid node
  int particle_ranks = 1;           // MPI ranks of the particle node
  int drop_every = 0;               // fault injection: every process drops every n-th message it receives
  std::string fluid_command;        // empty: the built-in fluid node
  std::string particle_command;     // empty: the built-in particle node
};

struct Scene {
  std::string source_path;
  RunSettings run;
  Vessel vessel;
  MeshSpec mesh;
  Plasma plasma;
  Driving driving;
  Species rbc{"rbc"};
  Species platelet{"platelet"};
  Contact contact;
  Timing time;
  Output output;
  bool two_way = true;              // particles push back on the fluid
};

// One problem found in a scene, with where it is.
struct SceneProblem {
  std::string key;   // dotted key, e.g. "vessel.diameter_um"
  int line = 0;      // 0 when the key is missing
  std::string message;
  std::string str(const std::string& file) const;
};

class SceneError : public std::runtime_error {
 public:
  SceneError(std::string file, std::vector<SceneProblem> problems);
  const std::vector<SceneProblem>& problems() const { return problems_; }

 private:
  std::vector<SceneProblem> problems_;
};

// Reads and validates a scene file; throws SceneError listing every problem found.
Scene load_scene(const std::string& path);

}  // namespace hemo
