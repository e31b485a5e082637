// A run directory: the scene copy, the run's identity on the bus, logs and results.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"

#include <string>

namespace hemo {

struct RunDirectory {
  std::string path;
  std::string scene_copy() const { return path + "/scene.toml"; }
  std::string info_file() const { return path + "/run.toml"; }
  std::string secret_file() const { return path + "/secret"; }
  std::string metrics_file() const { return path + "/metrics.csv"; }
  std::string log(const std::string& node) const { return path + "/" + node + ".log"; }

  // Creates a fresh run directory (refusing to reuse a non-empty one), copies the scene,
  // and draws a run id, a bus URL of its own and a secret readable by the user only.
  static std::pair<RunDirectory, RunContext> create(const std::string& path, const std::string& scene_path);
  // Reads the identity of an existing run (for the monitor).
  static std::pair<RunDirectory, RunContext> open(const std::string& path);
};

}  // namespace hemo
