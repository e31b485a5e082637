// The DEM time step, derived from physics (docs/model.md §2, docs/design.md "Speed and accuracy"):
//
//   dt <= t_Hertz / time.dem_steps_per_contact            (default 10)
//   dt <= time.dem_step_max_relaxation_times x tau_drag   (default 0: no limit)
//
// t_Hertz is the shortest Hertz contact time among the contacts that can happen (same species,
// RBC-platelet, each species with the wall), at an impact velocity of the shear velocity scale
// gamma_w d; tau_drag = m / beta(Re -> 0) the shortest drag relaxation time of the scene's drag
// closures (an oblate platelet broadside-on). The drag update is exponential
// (closures/exponential_drag.h), stable at any dt / tau; particle-node/README.md gives what a
// step above tau costs in accuracy. The Rayleigh time is reported too.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <scene.h>

#include <string>

namespace hemo::particles {

// Hertz contact duration of two elastic spheres (mass kg, radius m, Young's modulus Pa,
// Poisson ratio) colliding at normal velocity v (m/s):
//   t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5)
// with 1/m* = 1/m1 + 1/m2, 1/R* = 1/r1 + 1/r2, 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2.
// A wall is mass = radius = infinity.
double hertz_contact_time(double m1, double r1, double e1, double nu1, double m2, double r2, double e2, double nu2,
                          double v);

// Rayleigh time pi r sqrt(rho / G) / (0.1631 nu + 0.8766), G = E / (2 (1 + nu)).
double rayleigh_time(double radius, double density, double youngs, double poisson);

// The factor the DEM multiplies a species' mass by: its own mass_scaling, else time.mass_scaling.
double dem_mass_scaling(const Scene& scene, const Species& species);

// The scene as the DEM integrates it: every species' mass times dem_mass_scaling (the rest is
// the scene's). derive_dem_timing and DemEngine take the physical scene and apply it themselves.
Scene dem_scene(const Scene& scene);

// The wall shear rate of a scene: given, or from the pressure drop d dP / (4 mu l).
double wall_shear_rate(const Scene& scene);

struct DemTiming {
  double contact_time = 0;          // s, shortest Hertz contact time
  double rayleigh_time = 0;         // s, shortest, for information
  double relaxation_time = 0;       // s, shortest drag relaxation time m / beta(0) of the drag closures
  double dt = 0;                    // s, the DEM step actually used (coupling_interval / substeps)
  int substeps = 0;                 // DEM steps per coupling interval
  std::string limiting;             // which contact set contact_time
  bool relaxation_limited = false;  // the relaxation-time bound was the tighter one
};

// The DEM timing for a coupling interval, of the DEM's masses (dem_scene); `substeps_override` > 0 fixes the substep
// count (scene time.dem_substeps). Throws std::invalid_argument when the scene has no particle.
DemTiming derive_dem_timing(const Scene& scene, double coupling_interval, int substeps_override = 0);

}  // namespace hemo::particles
