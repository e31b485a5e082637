// Driving a run: the lockstep from start-up to the stop order, and around it the restarts of
// lost nodes and the restarts and swaps asked for (docs/design.md "Checkpoint, restart, swap").
// `hemocosim run` and `hemocosim resume` (run.cpp) are thin wrappers around drive(); the
// runtime's unit tests (tests/coordinator/) call it with fake nodes.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "node_launcher.h"
#include "run_directory.h"
#include "scene.h"

#include <functional>
#include <string>

namespace hemo {

// Where the lockstep begins and ends.
struct Span {
  long first = 0;  // the step the nodes start from (0, or the checkpoint resumed)
  long last = 0;   // the step after which they stop at the latest (--stop-after-step; else no bound)
};

// Where a run got to.
struct Reached {
  long step = 0;
  double time_s = 0;
  bool end = false;  // the scene's end time
  int restarts = 0;  // of nodes lost (not those asked for)
};

// Drives the span, restarting both nodes from their last common checkpoint when one dies or
// stops answering (at most run.max_restarts times), or when asked to on the run's CONTROL
// channel. `interrupted` is asked once per step: true stops the run after that step, with a
// checkpoint, and ends the restarts. Throws a one-line error when the run cannot go on
// (NodeLost, UnstableRun, a failed step, a timeout).
Reached drive(const Scene& scene, RunDirectory& dir, const RunContext& ctx, Span span, NodeLauncher& launcher,
              const std::function<bool()>& interrupted);

// A node swapped for another program (`hemocosim swap`, kept in run.toml) runs as that one.
void use_swapped_programs(const RunDirectory& dir, Scene& scene);

// Tells where to go on from after a run stopped before its end (appended to its error).
std::string resume_hint(const RunDirectory& dir);

}  // namespace hemo
