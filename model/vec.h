// Small vector types of the particle node and of the placement it shares with the coordinator
// (model/placement.h): Eigen, fixed size, SI units.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <Eigen/Dense>

namespace hemo::particles {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// Species index used in outputs and per-particle data (also the order of placement).
enum SpeciesIndex : int { kRbc = 0, kPlatelet = 1, kSpeciesCount = 2 };

}  // namespace hemo::particles
