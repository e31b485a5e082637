// SPDX-License-Identifier: GPL-3.0-or-later
#include "rbc_lift.h"

#include <cmath>
#include <stdexcept>

namespace hemo::particles {

RbcLift::RbcLift(const ClosureParams& p) {
  if (!(p.viscosity > 0) || !(p.diameter > 0) || !(p.fluid_density > 0))
    throw std::invalid_argument("rbc_lift needs a positive viscosity, density and diameter");
  const double nu = p.kinematic_viscosity(), d = p.diameter;
  scale_ = 100.271 * p.fluid_density * std::pow(d, 6) / nu / std::pow(d * d / nu, 0.63);
}

Vec3 RbcLift::force(const ParticleFlow& flow) const {
  const double speed = flow.velocity.norm();
  if (!(speed > 0) || !(flow.shear_rate > 0)) return Vec3::Zero();
  const Vec3 ga = flow.gradient * (flow.velocity / speed);  // (G a)_i = G[i][j] a_j = a_j du_j/dx_i
  return scale_ * std::pow(flow.shear_rate, -0.63) * ga.squaredNorm() * ga;
}

}  // namespace hemo::particles
