// Local flows for closure and single-particle tests: what a particle sees in Poiseuille flow.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "closures/closure.h"

#include <cmath>

namespace hemo::particles::testing {

// u_z = u_max (1 - r^2/R^2) at x, particle velocity v: slip, gradient (G[i][j] = du_j/dx_i),
// shear rate and centre-line speed filled in.
inline ParticleFlow poiseuille_flow(const Vec3& x, double R, double u_max, const Vec3& v = Vec3::Zero()) {
  ParticleFlow f;
  const double r2 = x.x() * x.x() + x.y() * x.y();
  f.velocity = Vec3(0, 0, u_max * (1 - r2 / (R * R)));
  f.slip = f.velocity - v;
  f.gradient = Mat3::Zero();
  f.gradient(0, 2) = -2 * u_max * x.x() / (R * R);
  f.gradient(1, 2) = -2 * u_max * x.y() / (R * R);
  f.shear_rate = 2 * u_max * std::sqrt(r2) / (R * R);
  f.centreline_speed = u_max;
  return f;
}

inline ClosureParams plasma_params(double diameter, double aspect_ratio = 1, double vessel_diameter = 100e-6) {
  ClosureParams p;
  p.diameter = diameter;
  p.fluid_density = 1025;
  p.viscosity = 1.2e-3;
  p.aspect_ratio = aspect_ratio;
  p.vessel_diameter = vessel_diameter;
  return p;
}

constexpr double kPi = 3.14159265358979323846;

}  // namespace hemo::particles::testing
