// The driving of the periodic vessel, written once: the mean pressure drop over its length and
// the wall shear rate it produces, gamma_w = d dP / (4 mu l) (docs/model.md §4), and the wall
// shear stress the streamwise momentum balance imposes, tau_w = d dP / (4 l) = mu gamma_w
// (momentum_balance.h). Scene loading, the fluid node, the particle node's DEM timing, the
// monitor and `hemocosim analyze` all call these; each keeps the floating-point order it has
// always had, so every figure derived from them is the same to the last bit.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"
#include "units.h"

namespace hemo {

// gamma_w = d dP / (4 mu l), 1/s: diameter m, pressure drop Pa, dynamic viscosity Pa s, length m.
inline double wall_shear_rate_of(double diameter, double pressure_drop, double viscosity, double length) {
  return diameter * pressure_drop / (4 * viscosity * length);
}

// dP = 4 mu l gamma_w / d, Pa: the inverse of wall_shear_rate_of.
inline double pressure_drop_of(double wall_shear_rate, double diameter, double viscosity, double length) {
  return 4 * viscosity * length * wall_shear_rate / diameter;
}

// Q = pi R^3 gamma_w / 4, m^3/s: the flow rate of Poiseuille flow with wall shear rate gamma_w in
// a tube of radius R (m) — what an open vessel's inlet takes in (vessel_ends.h).
inline double flow_rate_of(double radius, double wall_shear_rate) {
  return units::pi * radius * radius * radius * wall_shear_rate / 4;
}

// tau_w = d dP / (4 l), Pa: the wall shear stress that balances the driving.
inline double wall_shear_stress_of(double diameter, double pressure_drop, double length) {
  return diameter * pressure_drop / (4 * length);
}

// The wall shear rate of a scene: given (> 0), else from its pressure drop, else 0 (no driving,
// or a scene built in code without a viscosity or length).
double wall_shear_rate(const Scene& scene);

// The pressure drop a scene asks for: `driving.pressure_drop`, or 4 mu l gamma_w / d from
// `driving.wall_shear_rate` (the pressure drop wins when both are set, as load_scene does).
// Both zero: no driving, 0. Throws std::invalid_argument when either is negative.
double driving_pressure_drop(const Scene& scene);

// The flow rate the scene's driving gives in its nominal tube (radius R0, the scene's wall shear
// rate), m^3/s: an open vessel's inlet flow rate.
double nominal_flow_rate(const Scene& scene);

// The vessel's volume, m^3: its shape's (model/geometry.h; pi R^2 l for the straight tube); 0 for a
// vessel without a positive diameter and length.
double vessel_volume(const Vessel& v);

}  // namespace hemo
