// Schiller–Naumann drag of a sphere (docs/model.md §3.2, the spherical platelet surrogate):
//
//   |F| = C_D 1/2 rho |u_r|^2 (pi/4) d^2,   C_D = 24/Re (1 + 0.15 Re^0.687),   Re = d |u_r| / nu
//
// Linearised with the 1/Re cancelled: beta = 3 pi mu d (1 + 0.15 Re^0.687), the Stokes drag at
// Re = 0. Sign: F along u_r = u - v.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#ifdef HEMO_CLOSURE
HEMO_CLOSURE(drag, "schiller_naumann", SchillerNaumannDrag)
#endif

#include "closure.h"

#include <cmath>

namespace hemo::particles {

class SchillerNaumannDrag final : public DragClosure {
 public:
  explicit SchillerNaumannDrag(const ClosureParams& p);
  double coefficient(const ParticleFlow& flow) const override {
    return stokes_ * (1 + 0.15 * std::pow(params_.reynolds(flow.slip), 0.687));
  }
  double max_reynolds() const override { return 800; }  // the correlation's stated range

 private:
  ClosureParams params_;
  double stokes_;
};

}  // namespace hemo::particles
