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

#include <dem_step.h>  // hertz_contact_time, dem_scene, dem_substeps: the model's
#include <driving.h>   // wall_shear_rate
#include <scene.h>

#include <string>

namespace hemo::particles {

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
