// The small bifurcation of the surface tests (model and fluid): D_p = 30 um, L_p = L_d = 60 um,
// Murray daughters at the default angle.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <bifurcation.h>

namespace hemo::test {

inline BifurcationSpec small_bifurcation() {
  BifurcationSpec s;
  s.parent_diameter = 30e-6;
  s.parent_length = 60e-6;
  s.daughter_length = 60e-6;
  return s;
}

}  // namespace hemo::test
