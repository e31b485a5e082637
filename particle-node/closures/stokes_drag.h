// Stokes drag on a sphere: F = 3 pi mu d u_r, beta = 3 pi mu d (slip independent).
// Sign: F points along u_r = u - v (the fluid pulls the particle toward its own velocity).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#ifdef HEMO_CLOSURE
HEMO_CLOSURE(drag, "stokes", StokesDrag)
#endif

#include "closure.h"

namespace hemo::particles {

class StokesDrag final : public DragClosure {
 public:
  explicit StokesDrag(const ClosureParams& p);
  double coefficient(const ParticleFlow&) const override { return beta_; }
  bool slip_independent() const override { return true; }

 private:
  double beta_;
};

}  // namespace hemo::particles
