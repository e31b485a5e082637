// SPDX-License-Identifier: GPL-3.0-or-later
#include "orientation.h"

#include <cmath>
#include <stdexcept>

namespace hemo::particles {

namespace {

// The rotation by the vector theta (axis theta/|theta|, angle |theta|) as a unit quaternion.
Quat rotation(const Vec3& theta) {
  const double angle = theta.norm();
  if (!(angle > 0)) return Quat::Identity();
  return Quat(Eigen::AngleAxisd(angle, theta / angle));
}

}  // namespace

Vec3 SymmetricTop::angular_momentum(const Quat& q, const Vec3& omega) const {
  const Vec3 wb = q.conjugate() * omega;
  return q * Vec3(i_equatorial * wb.x(), i_equatorial * wb.y(), i_axial * wb.z());
}

Vec3 SymmetricTop::angular_velocity(const Quat& q, const Vec3& l) const {
  const Vec3 lb = q.conjugate() * l;
  return q * Vec3(lb.x() / i_equatorial, lb.y() / i_equatorial, lb.z() / i_axial);
}

void SplittingIntegrator::kick(const Quat&, Vec3& l, const Vec3& torque, double dt) const { l += dt * torque; }

void SplittingIntegrator::drift(Quat& q, Vec3& l, double dt) const {
  const double l3 = symmetry_axis(q).dot(l);
  // Precession of the whole body about L, then the spin about its own axis (they commute).
  const Quat precession = rotation(dt / top_.i_equatorial * l);
  const Quat spin = rotation(Vec3(0, 0, dt * (1 / top_.i_axial - 1 / top_.i_equatorial) * l3));
  q = (precession * q * spin).normalized();
}

void EulerIntegrator::kick(const Quat& q, Vec3& l, const Vec3& torque, double dt) const {
  const Vec3 i(top_.i_equatorial, top_.i_equatorial, top_.i_axial);
  const Vec3 wb = (q.conjugate() * l).cwiseQuotient(i);
  const Vec3 tb = q.conjugate() * torque;
  const Vec3 rate = (tb - wb.cross(i.cwiseProduct(wb))).cwiseQuotient(i);
  l = q * (wb + dt * rate).cwiseProduct(i);
}

void EulerIntegrator::drift(Quat& q, Vec3& l, double dt) const {
  // q' = 1/2 (0, omega) q, one explicit step; omega (the paper's state) is kept.
  const Vec3 omega = top_.angular_velocity(q, l);
  const Quat w(0, omega.x(), omega.y(), omega.z());
  const Quat dq = w * q;
  q = Quat(q.w() + 0.5 * dt * dq.w(), q.x() + 0.5 * dt * dq.x(), q.y() + 0.5 * dt * dq.y(), q.z() + 0.5 * dt * dq.z())
          .normalized();
  l = top_.angular_momentum(q, omega);
}

std::unique_ptr<OrientationIntegrator> make_orientation_integrator(OrientationMethod method, const SymmetricTop& top) {
  if (!(top.i_equatorial > 0) || !(top.i_axial > 0)) throw std::invalid_argument("a rigid body needs positive inertia");
  switch (method) {
    case OrientationMethod::splitting: return std::make_unique<SplittingIntegrator>(top);
    case OrientationMethod::euler: return std::make_unique<EulerIntegrator>(top);
  }
  throw std::invalid_argument("unknown orientation integrator");
}

}  // namespace hemo::particles
