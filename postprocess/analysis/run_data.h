// Reading a run directory written by `hemocosim run` into plain structs for the analysis:
//   particles.h5  /snapshots/<step, 8 digits> {attr time_s; id, species, position, velocity}
//   metrics.csv   step,time_s,node,name,value (long format)
//   scene.toml    the scene the run used
// Every failure is a RunDataError with a one-line message that names the file.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "observables.h"
#include "scene.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace hemo::analysis {

class RunDataError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SnapshotInfo {
  long step = 0;
  double time_s = 0;
};

// Snapshots of particles.h5 sorted by step. Snapshots are read one at a time: a long run's
// snapshots together do not fit in memory.
std::vector<SnapshotInfo> list_snapshots(const std::string& h5_path);
Snapshot read_snapshot(const std::string& h5_path, long step);

struct MetricSample {
  long step = 0;
  double time_s = 0;
  std::string node;
  std::string name;
  double value = 0;
};
std::vector<MetricSample> read_metrics(const std::string& csv_path);

// One metric over time (from any node that reports it).
struct MetricSeries {
  std::vector<double> time_s;
  std::vector<double> value;
  bool empty() const { return value.empty(); }
};
MetricSeries metric_series(const std::vector<MetricSample>& metrics, const std::string& name);
// The same straight from metrics.csv, keeping only that metric's samples (a long run's file
// holds millions of rows); the same checks and one-line errors as read_metrics.
MetricSeries read_metric_series(const std::string& csv_path, const std::string& name);

struct RunData {
  std::string dir;
  Scene scene;
  std::string particles_path;
  std::vector<SnapshotInfo> snapshots;
  std::vector<MetricSample> metrics;
  Snapshot load(std::size_t i) const { return read_snapshot(particles_path, snapshots.at(i).step); }
};
// Reads the scene, the metrics and the snapshot index of a run directory.
RunData open_run(const std::string& dir);

}  // namespace hemo::analysis
