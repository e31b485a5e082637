// Drag applied over one DEM step with the exponential update (stable whatever the step).
//
// Over a step dt a particle of mass m under the linearised drag beta (u - v) and other forces
// F_o (lift, contacts, gravity), all held fixed during the step, relaxes exactly as
//   v(dt) = u + F_o/beta - (u + F_o/beta - v0) exp(-dt / tau),   tau = m / beta
// The constant drag force that, together with F_o, gives exactly that velocity change is
//   F_d = r beta (u - v0) + (r - 1) F_o,        r = (1 - exp(-x)) / x,  x = dt / tau
// For dt << tau, r -> 1 and F_d -> beta (u - v0); for dt >> tau, r -> tau/dt and the particle
// lands on its terminal slip F_o/beta in one step without overshooting. The fluid receives the
// same F_d with the opposite sign, so momentum is conserved exactly whatever dt is.
// (Without F_o this is F_d = beta_eff (u - v0), beta_eff = m (1 - exp(-dt beta/m)) / dt.)
//
// Over a coupling interval of such steps, with the fluid velocity u held, the velocity's
// sensitivity s = dv/du obeys 1 - s' = exp(-x) (1 - s) from s = 0, so the interval's drag impulse
// J = sum F_d dt changes with u as
//   dJ/du = m (1 - exp(-B/m)),   B = sum beta dt  (the interval's integral of beta)
// (the other forces do not depend on u). It is what the fluid needs to treat the particles' drag
// implicitly: for B << m it is B (the particle barely moves: beta for the whole interval); for
// B >> m it is m (a particle that follows the flow takes from it no more than its own change of
// momentum, however stiff its drag).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <vec.h>

#include <cmath>

namespace hemo::particles {

// r = (1 - exp(-x)) / x with x = dt beta / m; 1 without drag or step.
inline double exponential_drag_ratio(double mass, double beta, double dt) {
  if (!(beta > 0) || !(dt > 0)) return 1.0;
  const double x = dt * beta / mass;
  return x < 1e-8 ? 1 - 0.5 * x : -std::expm1(-x) / x;
}

// beta_eff = r beta = m (1 - exp(-dt beta/m)) / dt <= beta.
inline double exponential_drag_coefficient(double mass, double beta, double dt) {
  if (!(beta > 0)) return 0.0;
  return beta * exponential_drag_ratio(mass, beta, dt);
}

inline Vec3 exponential_drag_force(double mass, double beta, const Vec3& slip, double dt) {
  return exponential_drag_coefficient(mass, beta, dt) * slip;
}

// With the other forces F_o of the step (see above), the ratio r already known.
inline Vec3 exponential_drag_force(double ratio, double beta, const Vec3& slip, const Vec3& other) {
  return (ratio * beta) * slip + (ratio - 1) * other;
}

inline Vec3 exponential_drag_force(double mass, double beta, const Vec3& slip, const Vec3& other, double dt) {
  return exponential_drag_force(exponential_drag_ratio(mass, beta, dt), beta, slip, other);
}

// dJ/du = m (1 - exp(-B/m)) (kg) for B = the interval's integral of beta dt (kg), see above.
inline double interval_drag_response(double mass, double beta_time) {
  if (!(beta_time > 0)) return 0.0;
  return -mass * std::expm1(-beta_time / mass);
}

}  // namespace hemo::particles
