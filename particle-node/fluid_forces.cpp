// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_forces.h"

#include "closures/exponential_drag.h"

#include <cmath>

#include <algorithm>
#include <stdexcept>

namespace hemo::particles {

SpeciesForces::SpeciesForces(const Species& s, const Scene& scene) : params_(closure_params(s, scene)), mass_(s.mass) {
  if (!(s.mass > 0)) throw std::invalid_argument(s.name + ": the mass must be positive");
  try {
    drag_ = make_drag_closure(s.drag, params_);
    lift_ = make_lift_closure(s.lift, params_);
    torque_ = make_torque_closure(s.torque, params_);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(s.name + ": " + e.what());
  }
  needs_orientation_ =
      drag_->needs_orientation() || (lift_ && lift_->needs_orientation()) || (torque_ && torque_->needs_orientation());
  if (drag_->slip_independent()) beta_fixed_ = drag_->coefficient(ParticleFlow{});
  beta_rest_ = drag_->coefficient(ParticleFlow{});
}

FluidForce SpeciesForces::evaluate(const ParticleFlow& flow, const Vec3& other, double dt, double drag_scale) const {
  FluidForce f;
  f.beta = drag_scale * (beta_fixed_ >= 0 ? beta_fixed_ : drag_->coefficient(flow));
  // The exponential ratio of the usual beta is computed once per step size.
  double r;
  if (f.beta == beta_rest_) {
    if (dt != ratio_dt_) {
      ratio_rest_ = exponential_drag_ratio(mass_, beta_rest_, dt);
      ratio_dt_ = dt;
    }
    r = ratio_rest_;
  } else {
    r = exponential_drag_ratio(mass_, f.beta, dt);
  }
  // Lift and torque see the slip averaged over the step as the exponential update relaxes it,
  // u_r,mean = r u_r + (r - 1) F_o / beta (the same mean the drag impulse beta u_r,mean dt
  // implies), not the slip at its start: at dt >~ tau the start-up transient of a particle
  // would otherwise be taken as lasting the whole step. For dt << tau, r -> 1: the slip itself.
  if (lift_ || torque_) {
    ParticleFlow mean = flow;
    if (r < 1 && f.beta > 0) mean.slip = r * flow.slip + ((r - 1) / f.beta) * other;
    if (lift_) f.lift = lift_->force(mean);
    if (torque_) f.torque = torque_->torque(mean);
  }
  f.ratio = r;
  f.drag = exponential_drag_force(r, f.beta, flow.slip, other + f.lift);
  return f;
}

double SpeciesForces::max_coefficient_at_rest() const {
  if (beta_fixed_ >= 0) return beta_fixed_;
  ParticleFlow broadside, edgewise;
  broadside.slip = edgewise.slip = Vec3(0, 0, 1e-30);
  edgewise.axis = Vec3::UnitX();
  return std::max({drag_->coefficient(ParticleFlow{}), drag_->coefficient(broadside), drag_->coefficient(edgewise)});
}

std::string SpeciesForces::describe() const {
  return "drag " + drag_->name() + ", lift " + (lift_ ? lift_->name() : "none") + ", torque " +
         (torque_ ? torque_->name() : "none");
}

}  // namespace hemo::particles
