// Shear-induced lift of the spherical platelet surrogate (docs/model.md §3.2; McLaughlin, Mei,
// Loth & Dorgan, semi-empirical), toward the Segre–Silberberg equilibrium radius:
//
//   |F_L| = 0.125 rho |u_max|^2 d^4 / D^2 |C_L|
//   C_L   = a beta s + b Re^2 s^2 + c beta s^3,   s = (D / (4 |u_max|)) gamma_dot
//   a = 110.88, b = 0.00206, c = -302.345,  beta = d / D
//
// D the vessel's diameter at the particle (its local 2 R(z) on a shape that narrows), u_max the centre-line velocity (the engine takes the largest cell
// velocity of the fluid state, scaled to the local section in a vessel that narrows), gamma_dot the local shear rate, Re = d |u_r| / nu the particle
// Reynolds number (our reading; at these Re the b term is negligible either way).
// In Poiseuille flow s = r/R, and C_L > 0 for s < sqrt(a/|c|) = 0.606, < 0 beyond.
// SIGN: C_L > 0 pushes the particle down the velocity gradient, toward slower plasma (toward
// the wall): F_L = -C_L 0.125 rho u_max^2 d^4/D^2 (G.a)/|G.a|, with (G.a)_i = a_j du_j/dx_i and
// a = u/|u| as for the RBC lift (in Poiseuille flow G.a = (du/dr) e_r, du/dr < 0, so -G.a/|G.a|
// = e_r: outward). So a sphere inside 0.6 R drifts out, one outside drifts in: it settles near
// 0.6 R. Zero on the axis (no gradient), at rest, and without a centre-line speed.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#ifdef HEMO_CLOSURE
HEMO_CLOSURE(lift, "shear_lift", ShearLift)
#endif

#include "closure.h"

namespace hemo::particles {

class ShearLift final : public LiftClosure {
 public:
  explicit ShearLift(const ClosureParams& p);
  Vec3 force(const ParticleFlow& flow) const override;
  bool needs_centreline_speed() const override { return true; }
  // C_L at s and Re, in the nominal vessel; and at confinement beta = d / D.
  double lift_coefficient(double s, double re) const { return lift_coefficient(s, re, confinement_); }
  double lift_coefficient(double s, double re, double confinement) const;

  static constexpr double kA = 110.88, kB = 0.00206, kC = -302.345;

 private:
  ClosureParams params_;
  double confinement_;  // beta = d / D in the nominal vessel
};

}  // namespace hemo::particles
