// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_forces.h"

#include "closures/exponential_drag.h"

#include <cmath>

#include <algorithm>
#include <stdexcept>

namespace hemo::particles {

SpeciesForces::SpeciesForces(const Species& s, const Scene& scene)
    : params_(closure_params(s, scene)), mass_(s.mass) {
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

FluidForce SpeciesForces::evaluate(const ParticleFlow& flow, const Vec3& other, double dt) const {
  FluidForce f;
  f.beta = beta_fixed_ >= 0 ? beta_fixed_ : drag_->coefficient(flow);
  f.reynolds = params_.reynolds(flow.slip);
  if (lift_) f.lift = lift_->force(flow);
  if (torque_) f.torque = torque_->torque(flow);
  // The exponential ratio of the usual beta is computed once per step size (the same bits).
  if (f.beta == beta_rest_) {
    if (dt != ratio_dt_) {
      ratio_rest_ = exponential_drag_ratio(mass_, beta_rest_, dt);
      ratio_dt_ = dt;
    }
    f.drag = (ratio_rest_ * f.beta) * flow.slip + (ratio_rest_ - 1) * (other + f.lift);
  } else {
    f.drag = exponential_drag_force(mass_, f.beta, flow.slip, other + f.lift, dt);
  }
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
