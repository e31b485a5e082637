// The plasma's force and torque on one particle over one DEM step: the species' closures
// (closures/) at the particle's local flow, the drag applied with the exponential update
// (closures/exponential_drag.h) so that it stays stable whatever the step. One object per
// species; the engine calls it from its force callback, unit tests call it directly.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "closures/closure.h"

#include <scene.h>
#include <vec.h>

#include <memory>
#include <string>

namespace hemo::particles {

struct FluidForce {
  Vec3 drag = Vec3::Zero();    // N, on the particle, exponential update over the step
  Vec3 lift = Vec3::Zero();    // N
  Vec3 torque = Vec3::Zero();  // N m, world frame
  // N, the plasma's stress on the particle's volume, F_p + F_v = -V_p grad P + V_p div tau, as
  // the momentum form has them (coupling.momentum): applied to the particle; not in total(),
  // which is what the particle hands to the plasma in every form (drag and lift).
  Vec3 stress = Vec3::Zero();
  double beta = 0;   // N s/m, the linearised drag coefficient at this slip
  double ratio = 1;  // r of the exponential update at this beta and step (exponential_drag.h)
  Vec3 total() const { return drag + lift; }
  bool finite() const {
    return drag.allFinite() && lift.allFinite() && torque.allFinite() && stress.allFinite() && std::isfinite(beta);
  }
};

class SpeciesForces {
 public:
  // Throws std::invalid_argument when a closure name is unknown or its constants impossible.
  SpeciesForces(const Species& species, const Scene& scene);

  // `other`: the non-fluid force on the particle during the step (contacts, gravity, the plasma's
  // stress; N). `drag_scale`: a factor on the drag coefficient (1 / alpha in CFDEM's model B).
  FluidForce evaluate(const ParticleFlow& flow, const Vec3& other, double dt, double drag_scale = 1.0) const;

  double mass() const { return mass_; }
  double diameter() const { return params_.diameter; }
  const ClosureParams& params() const { return params_; }
  const DragClosure& drag() const { return *drag_; }
  bool has_lift() const { return lift_ != nullptr; }
  bool has_torque() const { return torque_ != nullptr; }
  // What the closures need to know beyond the slip (skipped otherwise).
  bool needs_orientation() const { return needs_orientation_; }
  bool needs_gradient() const { return lift_ != nullptr || torque_ != nullptr; }
  bool needs_centreline_speed() const { return lift_ && lift_->needs_centreline_speed(); }
  // The largest beta at vanishing slip over orientations (an oblate body: broadside-on), for
  // the shortest drag relaxation time m / beta.
  double max_coefficient_at_rest() const;
  std::string describe() const;  // "drag rbc_fit, lift rbc_lift, torque none"

 private:
  ClosureParams params_;
  double mass_ = 0;
  std::unique_ptr<DragClosure> drag_;
  std::unique_ptr<LiftClosure> lift_;
  std::unique_ptr<TorqueClosure> torque_;
  bool needs_orientation_ = false;
  double beta_fixed_ = -1;                         // slip-independent drag: beta, else < 0
  double beta_rest_ = 0;                           // beta at zero slip (the usual value of a Stokesian particle)
  mutable double ratio_dt_ = -1, ratio_rest_ = 1;  // exponential ratio of beta_rest_ at dt
};

}  // namespace hemo::particles
