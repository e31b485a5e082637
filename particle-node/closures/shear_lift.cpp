// SPDX-License-Identifier: GPL-3.0-or-later
#include "shear_lift.h"

#include <cmath>
#include <stdexcept>

namespace hemo::particles {

ShearLift::ShearLift(const ClosureParams& p) : params_(p) {
  if (!(p.viscosity > 0) || !(p.diameter > 0) || !(p.fluid_density > 0) || !(p.vessel_diameter > p.diameter))
    throw std::invalid_argument("shear_lift needs a positive viscosity, density, diameter and a wider vessel");
  confinement_ = p.diameter / p.vessel_diameter;
}

double ShearLift::lift_coefficient(double s, double re, double confinement) const {
  return kA * confinement * s + kB * re * re * s * s + kC * confinement * s * s * s;
}

Vec3 ShearLift::force(const ParticleFlow& flow) const {
  const double u_max = flow.centreline_speed;
  const double speed = flow.velocity.norm();
  if (!(u_max > 0) || !(speed > 0) || !(flow.shear_rate > 0)) return Vec3::Zero();
  const Vec3 ga = flow.gradient * (flow.velocity / speed);
  const double ga_norm = ga.norm();
  if (!(ga_norm > 0)) return Vec3::Zero();
  // The vessel's local diameter where the shape gives one: the confinement of a narrowing vessel.
  const double D = flow.vessel_diameter > 0 ? flow.vessel_diameter : params_.vessel_diameter, d = params_.diameter;
  const double s = D / (4 * u_max) * flow.shear_rate;
  const double cl = lift_coefficient(s, params_.reynolds(flow.slip), d / D);
  const double magnitude = 0.125 * params_.fluid_density * u_max * u_max * std::pow(d, 4) / (D * D) * cl;
  return -magnitude / ga_norm * ga;
}

}  // namespace hemo::particles
