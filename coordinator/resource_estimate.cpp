// SPDX-License-Identifier: GPL-3.0-or-later
#include "resource_estimate.h"

#include <fmt/format.h>
#include <sys/statvfs.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace hemo {

namespace {
// Measured on two real runs (docs/studies.md "Before a run" has the commands): SMALL is
// tests/integration/scenes/coupled_small.toml with a checkpoint every 10 steps (120 fluid
// cells, 90 particles, 40 steps, 5 outputs), LARGE the same with d = 120 um, l = 240 um,
// core 6 / ring 3 / axial 20 cells (2,160), hematocrit 0.2 (6,846 particles), 20 steps, output
// every 5 (5 outputs). Sizes are `du -b` of what each wrote; the slope per particle or cell is
// (LARGE - SMALL) / (difference of counts), the base what is left of SMALL.
//
// particles.h5: 57,376 and 3,062,310 B: 89.0 B per particle and snapshot (the layout: id 8,
// species 1, position 24, velocity 24, orientation 32) and 3.5 kB per snapshot.
constexpr double kSnapshotPerParticle = 89, kSnapshotBase = 3.5e3;
// A fluid time directory (ASCII, 12 digits: U, p, phi, alpha, K, S): 39.8 and 449.5 kB, so
// 201 B per cell and 15.7 kB; the case itself (constant/, system/, 0/): 46.5 and 462.6 kB.
constexpr double kTimeDirPerCell = 201, kTimeDirBase = 15.7e3;
constexpr double kFluidCasePerCell = 204, kFluidCaseBase = 22.0e3;
// One checkpoint: fluid 42.1 and 382.8 kB (167 B per cell, 22.1 kB), particles 81.7 and
// 2,984.7 kB (430 B per particle, 43.0 kB).
constexpr double kCheckpointPerCell = 167, kCheckpointPerParticle = 430, kCheckpointBase = 65.1e3;
// metrics.csv: 154,573 B over 40 steps and 76,647 B over 20: 3.85 kB per step (about 70 rows).
constexpr double kMetricsPerStep = 3.85e3;
// Peak memory (profile.csv, one rank each): fluid 62.6 and 68.2 MiB: 2.9 kB per cell over
// 62.3 MiB; particles 50.1 and 60.8 MiB: 1.66 kB per particle over 50.0 MiB. (The calibration
// case's 9,268 particles come out at 64.7 MiB against its 69.6 measured, docs/performance.md.)
constexpr double kMiB = 1024.0 * 1024.0;
constexpr double kFluidRankPerCell = 2.88e3, kFluidRankBase = 62.3 * kMiB;
constexpr double kParticleRankPerParticle = 1.66e3, kParticleRankBase = 50.0 * kMiB;
}  // namespace

ResourceEstimate estimate_resources(const Scene& s, long particles) {
  ResourceEstimate e;
  const double n = static_cast<double>(particles), cells = s.mesh.cells();
  e.steps = s.time.coupling_steps;
  const long every = std::max(1L, s.output.every_steps);
  // Step 0's state, every `every` steps, and the last step (CouplingClock).
  e.outputs = 1 + e.steps / every + (e.steps % every != 0);
  const double outputs = static_cast<double>(e.outputs), steps = static_cast<double>(e.steps);
  e.snapshots_bytes = outputs * (kSnapshotBase + n * kSnapshotPerParticle);
  // Step 0's fluid is the case's initial 0/ directory, not a time directory of its own.
  e.fluid_output_bytes =
      kFluidCaseBase + cells * kFluidCasePerCell + (outputs - 1) * (kTimeDirBase + cells * kTimeDirPerCell);
  const bool checkpoints = s.output.checkpoint_every_steps > 0 && e.steps >= s.output.checkpoint_every_steps;
  e.checkpoint_bytes = checkpoints ? kCheckpointBase + n * kCheckpointPerParticle + cells * kCheckpointPerCell : 0;
  e.metrics_bytes = steps * kMetricsPerStep;
  e.fluid_rank_bytes = kFluidRankBase + cells / std::max(1, s.run.fluid_ranks) * kFluidRankPerCell;
  e.particle_rank_bytes = kParticleRankBase + n / std::max(1, s.run.particle_ranks) * kParticleRankPerParticle;
  return e;
}

MachineRoom machine_room(const std::string& path) {
  MachineRoom room;
  std::filesystem::path p = std::filesystem::absolute(path.empty() ? "." : path).lexically_normal();
  if (!p.has_filename() && p.has_parent_path()) p = p.parent_path();  // "dir/" -> "dir"
  std::error_code ec;
  while (!std::filesystem::exists(p, ec) && p.has_parent_path() && p != p.parent_path()) p = p.parent_path();
  room.disk_path = p.string();
  struct statvfs fs {};
  if (::statvfs(room.disk_path.c_str(), &fs) == 0)
    room.free_disk_bytes = static_cast<double>(fs.f_bavail) * static_cast<double>(fs.f_frsize);
  std::ifstream meminfo("/proc/meminfo");
  for (std::string line; std::getline(meminfo, line);) {
    std::istringstream in(line);
    std::string key;
    double kib = 0;
    if (in >> key >> kib && key == "MemAvailable:") room.available_memory_bytes = kib * 1024;
  }
  return room;
}

std::string bytes_text(double bytes) {
  static const char* units[] = {"B", "kB", "MB", "GB", "TB", "PB", "EB"};
  int u = 0;
  while (std::abs(bytes) >= 1000 && u < 6) bytes /= 1000, ++u;
  return u == 0 ? fmt::format("{:.0f} B", bytes) : fmt::format("{:.3g} {}", bytes, units[u]);
}

}  // namespace hemo
