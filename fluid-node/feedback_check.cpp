// Validation of the particle feedback (see feedback_check.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "feedback_check.h"

#include "cell_fields.h"

#include <cmath>
#include <cstdio>

namespace hemo {
namespace {

std::string format(const char* fmt, long a, double b, long count) {
  char buf[256];
  std::snprintf(buf, sizeof buf, fmt, a, b, count);
  return buf;
}

}  // namespace

std::string feedback_problem(const particle_feedback_t& fb, const std::string& mesh_hash, int n_cells,
                             double max_solid_fraction) {
  const std::string step = " (step " + std::to_string(fb.envelope.step) + ")";
  if (fb.mesh_hash != mesh_hash)
    return "particle feedback is for mesh '" + fb.mesh_hash + "', the fluid mesh is '" + mesh_hash + "'" + step;
  const auto n = static_cast<std::size_t>(n_cells);
  if (fb.n_cells != n_cells || fb.solid_fraction.size() != n || fb.drag_coefficient.size() != n)
    return "particle feedback has " + std::to_string(fb.n_cells) + " cells, the fluid mesh " + std::to_string(n_cells) +
           step;
  if (std::string why =
          flat_size_problem("explicit source", fb.n_source_values, fb.source_explicit, kVectorValues, n_cells);
      !why.empty())
    return "particle feedback: " + why + step;

  long bad = 0, first = -1;
  double first_value = 0;
  auto flag = [&](std::size_t i, double v) {
    if (bad++ == 0) {
      first = static_cast<long>(i);
      first_value = v;
    }
  };
  for (std::size_t i = 0; i < n; ++i) {
    const double phi = fb.solid_fraction[i];
    if (!std::isfinite(phi) || phi < 0 || phi >= max_solid_fraction) flag(i, phi);
  }
  if (bad) {
    char range[64];
    std::snprintf(range, sizeof range, " (must be in [0, %g))", max_solid_fraction);
    // A finite value at or above the limit is physical, not a corrupt message: say what it means.
    const char* why = std::isfinite(first_value) && first_value >= max_solid_fraction
                          ? "; the particles in it hold more volume than it has: pressed together by a load or "
                            "a DEM step too long for their contacts, or a cell too small for them"
                          : "";
    return format("particle feedback: cell %ld has solid fraction %g; %ld cells out of range", first, first_value,
                  bad) +
           range + why + step;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double k = fb.drag_coefficient[i];
    if (!std::isfinite(k) || k < 0) flag(i, k);
  }
  if (bad)
    return format(
               "particle feedback: cell %ld has drag coefficient %g N s/m^4 (must be finite, >= 0); "
               "%ld cells bad",
               first, first_value, bad) +
           step;
  for (std::size_t i = 0; i < n; ++i) {
    const double* s = source_of(fb, i);
    for (int k = 0; k < kVectorValues; ++k)
      if (!std::isfinite(s[k])) {
        flag(i, s[k]);
        break;
      }
  }
  if (bad)
    return format("particle feedback: cell %ld has a non-finite explicit source (%g N/m^3); %ld cells bad", first,
                  first_value, bad) +
           step;
  return {};
}

}  // namespace hemo
