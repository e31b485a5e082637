// The DEM's step, written once (docs/model.md §2): the Hertz contact time of the contacts a scene
// can have, and the substeps per coupling interval that resolve it. `hemocosim check` estimates
// a scene's work with them (scene.h, estimate_work) and the particle node derives its actual step
// from them (particle-node/dem_timing.h, which adds the drag relaxation bound of its closures).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"

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
// the scene's).
Scene dem_scene(const Scene& scene);

// The species the DEM times: present, with a positive diameter and mass.
bool timed_species(const Species& species);

// The shortest Hertz contact time among the contacts a scene's particles can have (same species,
// RBC-platelet, each species with the wall), at the masses the scene holds (pass dem_scene's),
// at an impact velocity of the shear velocity scale wall_shear_rate x the larger diameter of the
// pair; without driving (wall_shear_rate 0) the scale of a slow flow, 1 mm/s, stands in (it only
// sets the step, weakly: ^-1/5). Infinite, limiting empty, for a scene without timed species.
struct ContactTime {
  double time = 0;       // s
  std::string limiting;  // the contact that sets it: "rbc-platelet", "platelet-wall", ...
};
ContactTime shortest_contact_time(const Scene& scene, double wall_shear_rate);

// DEM steps per coupling interval for a step of at most dt_max: ceil(interval / dt_max), at least
// 1 (a ratio a rounding error above an integer does not add a step).
double dem_substeps(double coupling_interval, double dt_max);

}  // namespace hemo::particles
