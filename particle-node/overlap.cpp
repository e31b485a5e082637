// SPDX-License-Identifier: GPL-3.0-or-later
#include "overlap.h"

#include <spatial_hash.h>

#include <algorithm>
#include <cmath>

namespace hemo::particles {

OverlapReport measure_overlaps(const std::vector<Vec3>& x, const std::vector<double>& d, double radius, double length,
                               double z0) {
  OverlapReport rep;
  if (x.empty()) return rep;
  const double d_max = *std::max_element(d.begin(), d.end());
  SpatialHash grid(radius, length, z0, d_max);
  for (std::size_t i = 0; i < x.size(); ++i) {
    Vec3 xi = x[i];
    xi.z() = z0 + std::fmod(std::fmod(xi.z() - z0, length) + length, length);
    const double wall = std::hypot(xi.x(), xi.y()) + d[i] / 2 - radius;
    if (wall > 0) {
      ++rep.contacts;
      rep.max_relative = std::max(rep.max_relative, wall / d[i]);
    }
    grid.any_near(xi, [&](int j) {
      Vec3 dx = x[static_cast<std::size_t>(j)] - xi;
      dx.z() -= length * std::round(dx.z() / length);
      const double delta = (d[i] + d[static_cast<std::size_t>(j)]) / 2 - dx.norm();
      if (delta > 0) {
        ++rep.contacts;
        rep.max_relative = std::max(rep.max_relative, delta / std::min(d[i], d[static_cast<std::size_t>(j)]));
      }
      return false;
    });
    grid.insert(xi, static_cast<int>(i));
  }
  return rep;
}

}  // namespace hemo::particles
