// Drag applied over one DEM step with the exponential integrator.
//
// Under drag alone a particle relaxes as v(t) = u - (u - v0) exp(-t / tau), tau = m / beta.
// Over a step dt the velocity change is (u - v0)(1 - exp(-dt / tau)); the constant force that
// gives exactly that change is
//   F = m (u - v0) (1 - exp(-dt / tau)) / dt
// which tends to beta (u - v0) for dt << tau and never overshoots u for dt >> tau (platelets:
// tau ~ 0.3 us, below the contact-limited DEM step). The fluid receives the same F with the
// opposite sign, so momentum is conserved exactly whatever dt is.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "../vec.h"

#include <cmath>

namespace hemo::particles {

// beta_eff = m (1 - exp(-dt beta / m)) / dt, with F = beta_eff (u - v); beta_eff <= beta.
inline double exponential_drag_coefficient(double mass, double beta, double dt) {
  if (!(beta > 0)) return 0.0;
  if (!(dt > 0)) return beta;
  return -mass * std::expm1(-dt * beta / mass) / dt;
}

inline Vec3 exponential_drag_force(double mass, double beta, const Vec3& slip, double dt) {
  return exponential_drag_coefficient(mass, beta, dt) * slip;
}

}  // namespace hemo::particles
