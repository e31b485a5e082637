// The largest overlap among spheres in the periodic vessel, relative to the smaller diameter
// of the pair (or the sphere's diameter for the wall): a health check of the contact model.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <vec.h>

#include <vector>

namespace hemo::particles {

struct OverlapReport {
  double max_relative = 0;  // max over pairs and wall contacts of overlap / diameter; 0 if none
  long contacts = 0;        // pairs and wall contacts with a positive overlap
};

OverlapReport measure_overlaps(const std::vector<Vec3>& positions, const std::vector<double>& diameters, double radius,
                               double length, double z0);

}  // namespace hemo::particles
