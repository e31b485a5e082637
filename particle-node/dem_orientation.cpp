// DemEngine's platelet orientations: each DEM step, in the force callback, a platelet's quaternion
// and angular momentum (kept in a fix property/atom) drift to the step, turn the symmetry axis
// its closures see, take the step's kick from the fluid and contact torques, and hand LIGGGHTS
// the angular velocity its contacts see (see dem_engine.h, orientation.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include <atom.h>
#include <fmt/format.h>

#include <stdexcept>

#include "dem_engine.h"

namespace hemo::particles {

namespace {

constexpr double kMaxTurnPerStep = 1.0;  // rad: a platelet's spin beyond this per DEM step is an unstable update

}  // namespace

DemEngine::Spin DemEngine::spin_at_step(int i, int tag, const OrientationIntegrator& rotation, bool drift) const {
  const double* rot = per_atom(rotation_fix_)[i];
  Spin s;
  s.q = Quat(rot[0], rot[1], rot[2], rot[3]);
  s.l = Vec3(rot[4], rot[5], rot[6]);
  if (!pending_orientation_.empty()) {
    const auto it = pending_orientation_.find(tag);
    if (it != pending_orientation_.end()) s.q = it->second;
  }
  if (drift) rotation.drift(s.q, s.l, rotation_dt_);
  return s;
}

void DemEngine::kick_and_store_spin(const ForceStep& step, int i, int tag, const OrientationIntegrator& rotation,
                                    Spin& s, const Vec3& fluid_torque) {
  double* contact_torque = lmp_->atom->torque[i];
  double* omega = lmp_->atom->omega[i];
  double* rot = per_atom(rotation_fix_)[i];
  Quat& q = s.q;
  Vec3& l = s.l;
  const Vec3 torque = fluid_torque + Vec3(contact_torque[0], contact_torque[1], contact_torque[2]);
  if (step.advance) rotation.kick(q, l, torque, dt_);
  Vec3 w = rotation.top().angular_velocity(q, l);
  // A platelet turning by a radian in one DEM step (the flow turns it by ~gamma dt / 2,
  // 3e-3 rad at the calibration point) has an unstable orientation update (the explicit
  // "euler" one pumps energy into the spin): stop the run naming it, with its spin taken
  // away meanwhile so that LIGGGHTS's contacts stay finite until the run's end.
  if (!(w.norm() * dt_ < kMaxTurnPerStep) || !q.coeffs().allFinite()) {
    note_problem(tag,
                 fmt::format("platelet {} spins at {:.3g} rad/s ({:.2g} rad per DEM step of {:.3g} s) at coupling "
                             "step {} (DEM step {}): the orientation update '{}' is unstable here (try \"splitting\")",
                             tag, w.norm(), w.norm() * dt_, dt_, coupling_step_, step.ntimestep, rotation.name()));
    if (!q.coeffs().allFinite()) q = Quat::Identity();
    l = Vec3::Zero();
    w = Vec3::Zero();
  }
  rot[0] = q.w();
  rot[1] = q.x();
  rot[2] = q.y();
  rot[3] = q.z();
  for (int d = 0; d < 3; ++d) {
    rot[4 + d] = l[d];
    omega[d] = w[d];        // the contacts of the next step see the platelet's own rotation
    contact_torque[d] = 0;  // and nve/sphere leaves omega alone
  }
}

void DemEngine::finish_rotation_step(const ForceStep& step) {
  if (step.advance) {
    last_rotation_step_ = step.ntimestep;
    rotation_dt_ = dt_;
  }
  pending_orientation_.clear();
}

void DemEngine::set_orientation(long id, const Quat& q) {
  if (rotation_fix_ == nullptr) throw std::logic_error("no particle of this scene tracks an orientation");
  // Taken at the next force evaluation: LIGGGHTS re-initialises property/atom values of
  // existing atoms when it sets up a run, so a value written between runs may not survive.
  pending_orientation_[static_cast<int>(id)] = q.normalized();
}

}  // namespace hemo::particles
