// Red-cell lift of the paper (docs/model.md §2): the wall-induced migration that forms the cell-free
// layer.
//
//   F   = C_l rho d^6 |G.a|^2 (G.a) / nu,     C_l = 100.271 / (gamma_dot d^2 / nu)^0.63
//
// gamma_dot is the local shear rate sqrt(2 S:S); a = u(x_p) / |u(x_p)| is the unit vector of the
// local flow direction, and (G.a)_i = a_j d u_j / d x_i (our reading: the paper does not define
// a). Sign: F points along G.a. In Poiseuille flow u = u_z(r) e_z this is G.a = (du_z/dr) e_r
// with du_z/dr < 0: the force points to the vessel axis, grows like gamma_dot^2.37 toward the
// wall and vanishes on the axis.
// Zero when the plasma is at rest or unsheared (no direction, no shear), finite everywhere.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#ifdef HEMO_CLOSURE
HEMO_CLOSURE(lift, "rbc_lift", RbcLift)
#endif

#include "closure.h"

namespace hemo::particles {

class RbcLift final : public LiftClosure {
 public:
  explicit RbcLift(const ClosureParams& p);
  Vec3 force(const ParticleFlow& flow) const override;

 private:
  double shear_factor(const ParticleFlow& flow) const;  // gamma^-0.63, once per cell and shear rate
  struct Memo {
    double shear_rate = -1;
    double factor = 0;
  };
  mutable std::vector<Memo> memo_;  // per cell
  double scale_;                    // 100.271 rho d^6 / nu / (d^2 / nu)^0.63, so that F = scale gamma^-0.63 |Ga|^2 Ga
};

}  // namespace hemo::particles
