// SPDX-License-Identifier: GPL-3.0-or-later
#include "stability_guard.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace hemo {

std::string unstable_step(const std::string& node, long step, const std::vector<std::string>& names,
                          const std::vector<double>& values, const RunSettings& limits) {
  // A fluid step of several coupling intervals (fluid.solve_every > 1) reports its length.
  const bool fluid_step = std::find(names.begin(), names.end(), "fluid_step_s") != names.end();
  for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) {
    const std::string& name = names[i];
    const double v = values[i];
    if (!std::isfinite(v))
      return fmt::format("{} node reported {} = {} at step {}: the run has gone unstable (a non-finite value)", node,
                         name, v, step);
    if (node == "fluid" && name == "courant_max" && v > limits.max_courant)
      return fmt::format(
          "fluid Courant number {:.3g} at step {} exceeds run.max_courant = {:g}: the flow crosses "
          "cells within one {}",
          v, step, limits.max_courant,
          fluid_step ? "fluid step of fluid.solve_every intervals; lower fluid.solve_every"
                     : "coupling interval; lower time.coupling_interval_s");
    if (node == "particles" && name == "max_overlap" && v > limits.max_overlap)
      return fmt::format(
          "cells overlap by {:.3g} of a diameter at step {} (run.max_overlap = {:g}): the contacts are "
          "not resolved; raise time.dem_steps_per_contact",
          v, step, limits.max_overlap);
  }
  return {};
}

}  // namespace hemo
