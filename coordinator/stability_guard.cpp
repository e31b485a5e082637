// SPDX-License-Identifier: GPL-3.0-or-later
#include "stability_guard.h"

#include <fmt/format.h>

#include <cmath>

namespace hemo {

std::string unstable_step(const std::string& node, long step, const std::vector<std::string>& names,
                          const std::vector<double>& values, const RunSettings& limits) {
  for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) {
    const std::string& name = names[i];
    const double v = values[i];
    if (!std::isfinite(v))
      return fmt::format("{} node reported {} = {} at step {}: the run has gone unstable (a non-finite value)", node,
                         name, v, step);
    if (node == "fluid" && name == "courant_max" && v > limits.max_courant)
      return fmt::format(
          "fluid Courant number {:.3g} at step {} exceeds run.max_courant = {:g}: the flow crosses "
          "cells within one coupling interval; lower time.coupling_interval_s",
          v, step, limits.max_courant);
    if (node == "particles" && name == "max_overlap" && v > limits.max_overlap)
      return fmt::format(
          "cells overlap by {:.3g} of a diameter at step {} (run.max_overlap = {:g}): the contacts are "
          "not resolved; raise time.dem_steps_per_contact",
          v, step, limits.max_overlap);
  }
  return {};
}

}  // namespace hemo
