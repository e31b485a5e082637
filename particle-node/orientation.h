// Orientation of the oblate platelets (docs/model.md §3.3): a unit quaternion q = (w, x, y, z)
// rotating body -> world, the body z axis along the symmetry axis n, and the angular momentum L
// in the world frame (omega = R I^-1 R^T L; the engine hands omega to LIGGGHTS for contacts). The body is a symmetric
// top, I_xx = I_yy = m (a^2 + c^2)/5, I_zz = 2 m a^2 / 5.
//
// One DEM step from t_n to t_{n+1} is a kick and a drift (the engine calls kick at t_n with the
// torque at q_n, then drift to t_{n+1}):
//
//   "splitting" (default, second order, symplectic):
//      kick   L += dt tau                       (torque at q_n)
//      drift  exact torque-free rotation of a symmetric top over dt:
//             R(t) = exp(t [L/I_xx]x) R_0 exp(t (1/I_zz - 1/I_xx) L_3 [e_z]x),  L_3 = n.L
//      (a kick-drift-kick leapfrog once steps follow each other). Torque-free motion is exact
//      to round-off; with a torque the error is O(dt^2) (tests/particles/test_orientation.cpp).
//   "euler" (the paper's algorithm as printed, first order):
//      kick   omega_b = R^T omega, tau_b = R^T tau,
//             omega_b += dt I^-1 (tau_b - omega_b x (I omega_b)),  omega = R omega_b
//      drift  q += dt/2 (0, omega) * q,  q normalised; omega kept (L follows it)
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <scene_choices.h>
#include <vec.h>

#include <Eigen/Geometry>

#include <memory>
#include <string>

namespace hemo::particles {

using Quat = Eigen::Quaterniond;

struct SymmetricTop {
  double i_equatorial = 0;  // I_xx = I_yy, kg m^2
  double i_axial = 0;       // I_zz
  // The oblate spheroid of mass m, semi-axes a (equatorial), c (axial).
  static SymmetricTop oblate_spheroid(double mass, double a, double c) {
    return {mass * (a * a + c * c) / 5, 2 * mass * a * a / 5};
  }
  // World-frame quantities at orientation q.
  Vec3 angular_momentum(const Quat& q, const Vec3& omega) const;
  Vec3 angular_velocity(const Quat& q, const Vec3& angular_momentum) const;
  double kinetic_energy(const Quat& q, const Vec3& omega) const { return 0.5 * omega.dot(angular_momentum(q, omega)); }
};

// The symmetry axis n = R(q) e_z.
inline Vec3 symmetry_axis(const Quat& q) { return q * Vec3::UnitZ(); }

class OrientationIntegrator {
 public:
  explicit OrientationIntegrator(const SymmetricTop& top) : top_(top) {}
  virtual ~OrientationIntegrator() = default;
  virtual OrientationMethod method() const = 0;
  // L changed by a torque (world frame, N m) acting for dt, at orientation q.
  virtual void kick(const Quat& q, Vec3& angular_momentum, const Vec3& torque, double dt) const = 0;
  // q (and L where the scheme says so) advanced over dt without torque.
  virtual void drift(Quat& q, Vec3& angular_momentum, double dt) const = 0;
  const SymmetricTop& top() const { return top_; }

 protected:
  SymmetricTop top_;
};

class SplittingIntegrator final : public OrientationIntegrator {
 public:
  using OrientationIntegrator::OrientationIntegrator;
  OrientationMethod method() const override { return OrientationMethod::splitting; }
  void kick(const Quat& q, Vec3& l, const Vec3& torque, double dt) const override;
  void drift(Quat& q, Vec3& l, double dt) const override;
};

class EulerIntegrator final : public OrientationIntegrator {
 public:
  using OrientationIntegrator::OrientationIntegrator;
  OrientationMethod method() const override { return OrientationMethod::euler; }
  void kick(const Quat& q, Vec3& l, const Vec3& torque, double dt) const override;
  void drift(Quat& q, Vec3& l, double dt) const override;
};

// "splitting" or "euler"; throws std::invalid_argument otherwise.
std::unique_ptr<OrientationIntegrator> make_orientation_integrator(OrientationMethod method, const SymmetricTop& top);

}  // namespace hemo::particles
