// Running hemocosim from tests and reading what a run wrote.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "run_command.h"

#include <future>
#include <map>
#include <string>
#include <vector>

namespace hemo::test {

std::string scene(const std::string& name);  // path of a test scene

// The small coupled test scene with another number of coupling steps, `run_keys` added to its
// [run] table and `more` (whole tables) appended.
std::string small_scene_text(long coupling_steps, const std::string& run_keys = "", const std::string& more = "");

// Waits (up to `timeout_s`) until the run in `dir` is stepping: both nodes have reported steps
// in metrics.csv (about 60 rows a step), not merely started. True if it got there.
bool wait_until_stepping(const std::string& dir, double timeout_s = 120);

// The number after `marker` in `text` (-1: no marker).
long step_after(const std::string& text, const std::string& marker);
// Waits (up to a minute) until the run in `dir` has reported `step` in metrics.csv.
void wait_for_step(const std::string& dir, long step);

// A program in the background, its stdout and stderr in files (FILES.out, FILES.err), its pid
// known; interrupted (SIGINT) and waited for when it goes out of scope.
struct Background {
  std::string out, err;
  std::future<CommandResult> done;
  long pid = 0;

  Background(const std::string& command, const std::string& files);
  void signal(int sig) const;
  ~Background();
};

// One particle snapshot of particles.h5.
struct Snapshot {
  double time_s = 0;
  std::vector<long long> id;
  std::vector<signed char> species;
  std::vector<double> position, velocity;  // N x 3, row-major
  std::vector<double> orientation;         // N x 4 (w, x, y, z); empty when the file has none
};
std::vector<std::string> snapshot_names(const std::string& h5_path);
Snapshot read_snapshot(const std::string& h5_path, const std::string& name);
// The two runs wrote the same snapshots, bit for bit (gtest expectations).
void expect_same_snapshots(const std::string& a_dir, const std::string& b_dir);

}  // namespace hemo::test
