// Red-cell drag of the paper's fit (docs/model.md §2), on the volume-equivalent sphere of diameter d:
//
//   F    = 0.125 C_d rho pi d^2 |u_r| u_r,   Re = d |u_r| / nu
//   C_d  = 73.146 / ( Re (1 + 29.86 Re^27.079) )
//
// Linearised as F = beta u_r with the 1/Re cancelled analytically:
//
//   beta = 0.125 * 73.146 pi mu d / (1 + 29.86 Re^27.079)
//
// finite at Re = 0 (3.048 x the Stokes drag 3 pi mu d there), and never a division by zero.
// The fit holds for Re <~ 0.5 (max_reynolds: the engine warns once per run above it); above
// Re ~ 0.9 the correction term explodes and the drag collapses, as printed.
// Sign: F along u_r = u - v.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#ifdef HEMO_CLOSURE
HEMO_CLOSURE(drag, "rbc_fit", RbcFitDrag)
#endif

#include "closure.h"

namespace hemo::particles {

class RbcFitDrag final : public DragClosure {
 public:
  explicit RbcFitDrag(const ClosureParams& p);
  double coefficient(const ParticleFlow& flow) const override {
    // Most cells are far inside the Stokes range: no square root for them.
    if (flow.slip.squaredNorm() < stokes_slip_squared_) return beta0_;
    return coefficient(params_.reynolds(flow.slip));
  }
  double coefficient(double reynolds) const;
  double max_reynolds() const override { return 0.5; }
  // C_d at Re > 0 as printed (for tests).
  static double drag_coefficient(double reynolds);

 private:
  ClosureParams params_;
  double beta0_;                // N s/m, at Re = 0
  double stokes_slip_squared_;  // (m/s)^2: |u_r|^2 below it is Re < kStokesBelow, beta = beta0
};

}  // namespace hemo::particles
