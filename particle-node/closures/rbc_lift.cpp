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
  return scale_ * shear_factor(flow) * ga.squaredNorm() * ga;
}

double RbcLift::shear_factor(const ParticleFlow& flow) const {
  // The power is the costliest part of the lift and depends on the cell alone: every red cell
  // in a fluid cell shares it (the memo is keyed by the shear rate itself, so a new fluid state
  // needs no invalidation).
  if (flow.cell < 0) return std::pow(flow.shear_rate, -0.63);
  if (static_cast<std::size_t>(flow.cell) >= memo_.size()) memo_.resize(flow.cell + 1);
  Memo& m = memo_[flow.cell];
  if (m.shear_rate != flow.shear_rate) m = {flow.shear_rate, std::pow(flow.shear_rate, -0.63)};
  return m.factor;
}

}  // namespace hemo::particles
