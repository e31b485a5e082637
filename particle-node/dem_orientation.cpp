// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_orientation.h"

#include <atom.h>
#include <fmt/format.h>

#include <stdexcept>

#include "dem_fixes.h"

namespace hemo::particles {

using namespace dem;

namespace {

constexpr double kMaxTurnPerStep = 1.0;  // rad: a platelet's spin beyond this per DEM step is an unstable update

}  // namespace

OrientationTracker::Step OrientationTracker::step(std::int64_t ntimestep, double dt, long coupling_step) const {
  Step step;
  step.ntimestep = ntimestep;
  step.dt = dt;
  step.coupling_step = coupling_step;
  step.advance = ntimestep > last_step_;
  step.drift = step.advance && last_step_ >= 0;
  step.spins = per_atom(liggghts_.fixes().rotation);
  return step;
}

OrientationTracker::Spin OrientationTracker::at_step(const Step& step, int i, int tag,
                                                     const OrientationIntegrator& rotation) const {
  const double* rot = step.spins[i];
  Spin s;
  s.q = Quat(rot[0], rot[1], rot[2], rot[3]);
  s.l = Vec3(rot[4], rot[5], rot[6]);
  if (!pending_.empty()) {
    const auto it = pending_.find(tag);
    if (it != pending_.end()) s.q = it->second;
  }
  if (step.drift) rotation.drift(s.q, s.l, last_dt_);
  return s;
}

void OrientationTracker::kick_and_store(const Step& step, int i, int tag, const OrientationIntegrator& rotation,
                                        Spin& s, const Vec3& fluid_torque) {
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  double* contact_torque = atom.torque[i];
  double* omega = atom.omega[i];
  double* rot = step.spins[i];
  const double dt = step.dt;
  Quat& q = s.q;
  Vec3& l = s.l;
  const Vec3 torque = fluid_torque + Vec3(contact_torque[0], contact_torque[1], contact_torque[2]);
  if (step.advance) rotation.kick(q, l, torque, dt);
  Vec3 w = rotation.top().angular_velocity(q, l);
  // A platelet turning by a radian in one DEM step (the flow turns it by ~gamma dt / 2,
  // 3e-3 rad at the calibration point) has an unstable orientation update (the explicit
  // "euler" one pumps energy into the spin): stop the run naming it, with its spin taken
  // away meanwhile so that LIGGGHTS's contacts stay finite until the run's end.
  if (!(w.norm() * dt < kMaxTurnPerStep) || !q.coeffs().allFinite()) {
    // The explicit update's cure is the stable one; the stable one's, a torque that its DEM step
    // can follow: the message names both torques so that the reader sees which.
    const std::string cure = rotation.method() == OrientationMethod::splitting
                                 ? "the torque is too large for the DEM step; raise time.dem_steps_per_contact"
                                 : "try \"" + name_of(OrientationMethod::splitting) + "\"";
    problems_.note(tag, fmt::format("platelet {} spins at {:.3g} rad/s ({:.2g} rad per DEM step of {:.3g} s) at "
                                    "coupling step {} (DEM step {}), x = ({:.4g}, {:.4g}, {:.4g}) m, torque from the "
                                    "fluid {:.3g} N m and from contacts {:.3g} N m: the orientation update '{}' is "
                                    "unstable here ({})",
                                    tag, w.norm(), w.norm() * dt, dt, step.coupling_step, step.ntimestep,
                                    atom.x[i][0], atom.x[i][1], atom.x[i][2], fluid_torque.norm(),
                                    (torque - fluid_torque).norm(), name_of(rotation.method()), cure));
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

void OrientationTracker::finish_step(const Step& step) {
  if (step.advance) {
    last_step_ = step.ntimestep;
    last_dt_ = step.dt;
  }
  pending_.clear();
}

void OrientationTracker::set(long id, const Quat& q) {
  if (liggghts_.fixes().rotation == nullptr) throw std::logic_error("no particle of this scene tracks an orientation");
  // Taken at the next force evaluation: LIGGGHTS re-initialises property/atom values of
  // existing atoms when it sets up a run, so a value written between runs may not survive.
  pending_[static_cast<int>(id)] = q.normalized();
}

void OrientationTracker::save(EngineState& s) const {
  s.last_rotation_step = last_step_;
  s.rotation_dt = last_dt_;
  for (const auto& [tag, q] : pending_) {
    s.pending_tags.push_back(tag);
    s.pending_orientations.insert(s.pending_orientations.end(), {q.w(), q.x(), q.y(), q.z()});
  }
}

void OrientationTracker::restore(const EngineState& s) {
  last_step_ = s.last_rotation_step;
  last_dt_ = s.rotation_dt;
  pending_.clear();
  for (std::size_t k = 0; k < s.pending_tags.size(); ++k) {
    const double* q = &s.pending_orientations[4 * k];
    pending_[static_cast<int>(s.pending_tags[k])] = Quat(q[0], q[1], q[2], q[3]);
  }
}

}  // namespace hemo::particles
