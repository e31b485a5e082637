// What a scene will take of the machine, before it runs: the disk its run directory grows to and
// the peak memory of each node's ranks (`hemocosim check`; docs/studies.md "Before a run").
// The figures per particle, per cell and per step are measured on real runs (resource_estimate.cpp
// says which); an estimate is good to a factor of about two, enough to tell a scene that fits
// from one that cannot.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"

#include <string>

namespace hemo {

struct ResourceEstimate {
  long steps = 0;                  // coupling steps (adaptive intervals: at least this many)
  long outputs = 0;                // particle snapshots and fluid time directories written
  double snapshots_bytes = 0;      // particles.h5
  double fluid_output_bytes = 0;   // the fluid's time directories (fluid/<time>/)
  double checkpoint_bytes = 0;     // one checkpoint (checkpoints/ keeps the last; the next is written beside it)
  double metrics_bytes = 0;        // metrics.csv
  double fluid_rank_bytes = 0;     // peak resident memory of one fluid rank
  double particle_rank_bytes = 0;  // of one particle rank
  // The most the run directory holds: at its end, while its last checkpoint is written beside the one before.
  double disk_bytes() const { return snapshots_bytes + fluid_output_bytes + 2 * checkpoint_bytes + metrics_bytes; }
  // All ranks of both nodes, as when they share one host.
  double memory_bytes(const Scene& s) const {
    return s.run.fluid_ranks * fluid_rank_bytes + s.run.particle_ranks * particle_rank_bytes;
  }
};

// The estimate for scene `s` with `particles` particles (RBCs and platelets, as placed).
ResourceEstimate estimate_resources(const Scene& s, long particles);

// What this machine has: free space on the filesystem that holds `path` (or its nearest existing
// parent), and MemAvailable from /proc/meminfo (bytes; negative: not known).
struct MachineRoom {
  std::string disk_path;  // where the free space was measured
  double free_disk_bytes = -1;
  double available_memory_bytes = -1;
};
MachineRoom machine_room(const std::string& path);

// An estimate above this many times what the machine has is refused by `hemocosim check`, not
// merely warned about: no cleanup or swap makes it fit (a scene with its output or its step
// count off by orders of magnitude).
inline constexpr double kAbsurdFactor = 10;

std::string bytes_text(double bytes);  // "3.2 GB", "850 kB" (decimal units, as df -H)

}  // namespace hemo
