// A small run directory in the format `hemocosim run` writes (scene.toml, particles.h5,
// metrics.csv), with made-up but plausible data, for the plot and study tests.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>

namespace hemo::studytest {

struct SyntheticRun {
  int snapshots = 6;  // at t = 0, dt, 2 dt, ...
  double dt_s = 0.01;
  int rbcs = 60;
  int platelets = 20;
  double drift = 0.2;  // platelets move this fraction of the way to the wall by the end
  unsigned seed = 1;
  // A surface vessel's scene (a bifurcation): the cells sit in the far half of each branch, at
  // most 0.8 of its radius from its axis, and metrics.csv holds the ends' plasma fluxes and the
  // cells counted through them at every step: per step `rbc_in` red cells and `platelets_in`
  // platelets enter, outlet 1 takes rbc_1_early of the red cells in the run's first half and
  // rbc_1_late after, platelets_1 of the platelets, plasma_1 of the plasma; outlet 2 the rest.
  double rbc_in = 10, platelets_in = 4;
  double rbc_1_early = 3, rbc_1_late = 6, platelets_1 = 1;
  double plasma_in = 1e-11, plasma_1 = 0.4e-11;  // m^3/s
  int steps_per_snapshot = 10;
};

// Writes into `dir` (created): scene.toml copied from `scene_path`, and particles.h5 and
// metrics.csv for a tube of the scene's size. `spec.snapshots == 0` writes a particles.h5
// without snapshots.
void write_synthetic_run(const std::string& dir, const std::string& scene_path, const SyntheticRun& spec = {});

// A fresh directory under the temp dir, removed with everything in it when the object goes.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name);
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::string& str() const { return path_; }

 private:
  std::string path_;
};

// A small, valid base scene for study tests (seed 3: every run of a study keeps it).
extern const char* const kSmallBaseScene;

std::string read_text(const std::string& path);
void write_text(const std::string& path, const std::string& text);

}  // namespace hemo::studytest
