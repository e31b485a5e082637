// SPDX-License-Identifier: GPL-3.0-or-later
#include "driving.h"

#include "geometry.h"

#include <stdexcept>

namespace hemo {

double wall_shear_rate(const Scene& s) {
  if (s.driving.wall_shear_rate > 0) return s.driving.wall_shear_rate;
  if (s.driving.pressure_drop > 0 && s.plasma.viscosity > 0 && s.vessel.length > 0)
    return wall_shear_rate_of(s.vessel.diameter, s.driving.pressure_drop, s.plasma.viscosity, s.vessel.length);
  return 0;
}

double driving_pressure_drop(const Scene& scene) {
  // load_scene fills both from the one the file gives; prefer the pressure drop.
  if (scene.driving.pressure_drop > 0) return scene.driving.pressure_drop;
  if (scene.driving.wall_shear_rate > 0)
    return pressure_drop_of(scene.driving.wall_shear_rate, scene.vessel.diameter, scene.plasma.viscosity,
                            scene.vessel.length);
  // Neither: no driving (a scene that gives pressure_drop_Pa = 0; flow only from sources).
  if (scene.driving.pressure_drop == 0 && scene.driving.wall_shear_rate == 0) return 0;
  throw std::invalid_argument("driving: pressure_drop and wall_shear_rate must not be negative");
}

double nominal_flow_rate(const Scene& scene) { return flow_rate_of(scene.vessel.radius(), wall_shear_rate(scene)); }

double vessel_volume(const Vessel& v) {
  if (!(v.diameter > 0) || !(v.length > 0)) return 0;
  return surface_vessel(v) ? make_vessel_surface(v).volume() : make_vessel_geometry(v)->volume();
}

}  // namespace hemo
