// Stokes drag on a sphere: F = 3 pi mu d (u - v), beta = 3 pi mu d (slip independent).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "drag_closure.h"

namespace hemo::particles {

class StokesDrag final : public DragClosure {
 public:
  explicit StokesDrag(const DragParams& p);
  std::string name() const override { return "stokes"; }
  double coefficient(const Vec3&) const override { return beta_; }
  bool slip_independent() const override { return true; }

 private:
  double beta_;
};

}  // namespace hemo::particles
