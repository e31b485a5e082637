// The streamwise momentum balance by which the paper fixes the wall shear stress of its periodic
// vessel: in a steady state the wall takes up the whole driving, τ_w 2πR l = ΔP πR², so
//   τ_w,imposed = d ΔP / (4 l) = µ γ̇_w      (γ̇_w = d ΔP / (4 µ l); both in driving.h)
// whatever the cells do. `hemocosim analyze`, the monitor and the run's closing summary hold
// the fluid node's `wall_shear_stress_Pa` against it (docs/model.md §5 "Momentum balance").
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "driving.h"
#include "scene.h"
#include "units.h"

namespace hemo {

// τ_w,imposed of the scene's driving, Pa.
inline double imposed_wall_shear_stress(const Scene& s) {
  return wall_shear_stress_of(s.vessel.diameter, s.driving.pressure_drop, s.vessel.length);
}

// The τ_w / τ_w,imposed an exact balance reaches on the scene's mesh: the wall carries
// (ΔP/l) A / P = τ_w,imposed D_h / d, D_h = 4A/P its cross-section's hydraulic diameter — 1 on
// the default circumscribed polygon, cos(π/n) on the inscribed one (0.981 on the paper's 16-gon,
// measured to 1e-11 in a steady single-phase run, docs/fluid-verification.md §2).
inline double mesh_balance_ratio(const Scene& s) { return s.mesh.hydraulic_diameter_ratio(); }

}  // namespace hemo
