// A study: one base scene and one swept parameter (docs/model.md §4), as a small TOML file:
//
//   name = "shear-rate"                       # optional; default: the file's stem
//   title = "..."                             # optional, one line for the report
//   expectation = "..."                       # optional, what the paper reports (for the report)
//   base = "../calibration.toml"              # relative to the study file
//
//   [sweep]
//   key = "driving.wall_shear_rate_per_s"     # a scene key, dotted
//   values = [150, 236, 377]                  # one run per value
//   labels = ["low", "mid", "high"]           # optional names of the runs
//
// Several keys that change together (the shape study's closures) give `keys` instead of `key`
// and one array per run in `values`:
//
//   [sweep]
//   keys = ["platelet.drag", "platelet.lift"]
//   values = [["oblate", "oblate"], ["schiller_naumann", "loth_dorgan"]]
//   labels = ["oblate", "spherical"]
//
// An optional [set] table (scene-shaped: [set.time] coupling_steps = 10) overrides base keys
// in every run. Expansion writes one scene per value and validates each with the scene loader,
// so a swept key that is no scene key, or a value of the wrong kind, is refused before anything
// runs.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"

#include <toml++/toml.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace hemo {

class StudyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// --reduced: every scene of a study shrunk so that a whole study runs in a couple of minutes on
// two cores. Defined here, once; describe() is what the report states.
struct Reduction {
  double diameter_factor = 0.5;  // vessel diameter x this (the swept diameters too)
  double length_um = 60;         // vessel length (if the scene's is longer)
  int core_cells = 2;            // mesh: 2 x 2 core, ring 2 (20 cells per section) ...
  int ring_cells = 2;
  int axial_cells = 3;       // ... 3 axial cells (20 um at 60 um). Unresolved coupling needs cells
                             // larger than an RBC: at d = 50 um the smallest cell is (6.3 um)^3.
  double end_time_s = 0.02;  // physical time (if the scene's is longer), at the scene's coupling interval
  int snapshots = 20;        // particle snapshots over the run
  std::string describe() const;
  void apply(toml::table& scene) const;  // on a parsed scene (keys as in the scene file)
};

struct Study {
  std::string path;  // the study file
  std::string name;
  std::string title;
  std::string expectation;
  std::string base;                              // base scene path, resolved against the study file's folder
  std::vector<std::string> keys;                 // swept keys (one, or several that change together)
  std::vector<std::vector<std::string>> values;  // per run, per key: the value as TOML text
  std::vector<std::string> labels;               // per run: a name ([A-Za-z0-9._-] only)
  std::string set_toml;                          // the [set] table as TOML text ("" if none)
  std::size_t size() const { return values.size(); }
  // The swept value(s) of run i for tables: "799" or "oblate, oblate".
  std::string value_text(std::size_t i) const;
};

// Reads a study file; throws StudyError with one line naming the file and what is wrong.
Study load_study(const std::string& path);

// A study named on the command line: an existing file, or NAME.toml in ./scenes/studies, in the
// source tree this binary was built from, or in <exe dir>/../share/hemocosim/scenes/studies.
std::string resolve_study(const std::string& name_or_file);

// One run of a study: its scene written to a file and validated.
struct StudyCase {
  std::size_t index = 0;  // 0-based
  std::string label;      // e.g. "799"
  std::string dir_name;   // e.g. "05-799": runs/<dir_name>, scenes/<dir_name>.toml
  std::string scene_path;
  std::string scene_text;  // exactly what was written
};

// Writes the scenes of all runs into `scenes_dir` (created) and validates each with the scene
// loader, as far as `check` says (SceneCheck::placement: also that its particles can be placed,
// as `hemocosim run` checks before it starts the nodes); throws StudyError naming the run and the
// problem (an unknown swept key says so).
std::vector<StudyCase> expand_study(const Study& study, const std::string& scenes_dir, const Reduction* reduction,
                                    SceneCheck check = SceneCheck::values);

// Sets a dotted key in a parsed TOML table to a value given as TOML text ("799", "\"oblate\"",
// "[1, 2]"), creating tables on the way; throws StudyError if a part of the path is a value.
void set_dotted(toml::table& root, const std::string& dotted_key, const std::string& value_toml);

}  // namespace hemo
