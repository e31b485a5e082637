// The stability guards of a run (issue #6, docs/design.md "a run never fails silently"): what a
// node's step report says about the run having gone unstable. The nodes stop themselves on what
// only they can see (a particle outside the mesh, a non-finite particle); these are the causes
// the coordinator sees in the reports of healthy nodes.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"

#include <string>
#include <vector>

namespace hemo {

// One line naming the cause and its cure, or "" when the step is within the limits:
//  - any non-finite diagnostic value (NaN or infinity), from any node;
//  - the fluid's Courant number `courant_max` above run.max_courant (over its step: with
//    fluid.solve_every > 1, whose steps report `fluid_step_s`, several coupling intervals);
//  - the particles' deepest contact overlap `max_overlap` above run.max_overlap.
std::string unstable_step(const std::string& node, long step, const std::vector<std::string>& names,
                          const std::vector<double>& values, const RunSettings& limits);

}  // namespace hemo
