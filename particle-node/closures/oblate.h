// The oblate-spheroid platelet closures (docs/model.md §3.1, §7.1): drag, lift and torque on
// a rigid oblate spheroid of aspect ratio lambda = c / a < 1 with symmetry axis n, carried by a
// placeholder sphere of diameter d (Re = d |u_r| / nu and the reference areas use d).
//
// phi is the incidence angle between the slip u_r = u - v and n: cos phi = n.e, e = u_r/|u_r|
// (phi = 0: flow along n, broadside-on, largest drag). A = (pi/4) d^2.
//
// Drag, along u_r (beta = |F_D| / |u_r| with the 1/Re cancelled analytically):
//   C_D    = C_D,0 cos^2 phi + C_D,90 sin^2 phi
//   C_D,0  = 24/Re (K_0  + 0.15 lambda^95.91 Re^0.687 + 0.2927 (1 - lambda)^0.4374 Re^0.7512)
//   C_D,90 = 24/Re (K_90 + 0.15 lambda^100.7 Re^0.687 + 0.1411 (1 - lambda^24.75) Re^0.7143)
//   beta   = 3 pi mu d (f_0 cos^2 phi + f_90 sin^2 phi),  f = the bracket after 24/Re
//
// Lift, perpendicular to u_r in the plane of u_r and n:
//   |F_L|  = |C_L| 1/2 rho |u_r|^2 A
//   C_L    = [ (C_D,0 - C_D,90) + 2 ((1 - lambda)/lambda)^0.542 / (1 + lambda)^7.85 Re^0.1516 ] sin phi cos phi
//   SIGN: F_L = C_L' 1/2 rho |u_r|^2 A (n.e) (n - (n.e) e), C_L' the bracket: for C_L' > 0 the
//   lift points to the side of u_r where n leans (n.e > 0), and the same for -n (the body is
//   symmetric). This is the sign of the Stokes resistance tensor
//   F = 3 pi mu d [K_90 u_r + (K_0 - K_90)(n.u_r) n], whose part normal to u_r is
//   3 pi mu d (K_0 - K_90)(n.u_r)(n - (n.e) e) with K_0 > K_90 (docs/model.md §7.1), and the paper's
//   C_L tends to exactly that at Re -> 0.
//
// Torque:
//   |T|    = |C_T| 1/2 rho |u_r|^2 (pi/8) d^3,   C_T = 1.85 ((1 - lambda)/lambda)^0.832 / Re^0.146 sin phi cos phi
//   SIGN: T = C_T' 1/2 rho |u_r|^2 (pi/8) d^3 (n.e)(n x e), C_T' = 1.85 (...)^0.832 / Re^0.146 > 0:
//   about the axis n x u_r (the paper's "axis u_r x n" up to the sign, which we fix physically):
//   it rotates n toward +-e, i.e. turns the platelet broadside-on (phi -> 0), the stable
//   orientation of an oblate body at finite Re. d(n.e)^2/dt >= 0 under this torque.
//
// All three vanish at phi = 0 and 90 deg (lift, torque), flip with phi -> -phi, and go to zero
// with the slip (drag ~ |u_r|, lift ~ |u_r|, torque ~ |u_r|^1.854); finite at u_r = 0.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#ifdef HEMO_CLOSURE
HEMO_CLOSURE(drag, "oblate", OblateDrag)
HEMO_CLOSURE(lift, "oblate", OblateLift)
HEMO_CLOSURE(torque, "oblate", OblateTorque)
#endif

#include "closure.h"

namespace hemo::particles {

// Stokes drag correction factors of an oblate spheroid (docs/model.md §7.1, Happel & Brenner),
// relative to the volume-equivalent sphere: motion along the axis (K_0, broadside) and across it
// (K_90, edgewise). Series about lambda = 1 where the closed forms lose precision; lambda in (0, 1].
double oblate_k0(double lambda);
double oblate_k90(double lambda);

class OblateDrag final : public DragClosure {
 public:
  explicit OblateDrag(const ClosureParams& p);
  double coefficient(const ParticleFlow& flow) const override;
  bool needs_orientation() const override { return true; }
  // f_0 and f_90 at Re (the brackets of C_D,0 and C_D,90).
  double f0(double re) const;
  double f90(double re) const;

 private:
  ClosureParams params_;
  double stokes_, k0_, k90_;
  double c0_a_, c0_b_, c90_a_, c90_b_;  // lambda-dependent factors of the Re terms
};

class OblateLift final : public LiftClosure {
 public:
  explicit OblateLift(const ClosureParams& p);
  Vec3 force(const ParticleFlow& flow) const override;
  bool needs_orientation() const override { return true; }

 private:
  ClosureParams params_;
  OblateDrag drag_;
  double shape_;  // 2 ((1 - lambda)/lambda)^0.542 / (1 + lambda)^7.85
};

class OblateTorque final : public TorqueClosure {
 public:
  explicit OblateTorque(const ClosureParams& p);
  Vec3 torque(const ParticleFlow& flow) const override;
  bool needs_orientation() const override { return true; }

 private:
  ClosureParams params_;
  double scale_;  // 1.85 ((1 - lambda)/lambda)^0.832 1/2 rho (pi/8) d^3
};

}  // namespace hemo::particles
