// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_species.h"

#include <algorithm>
#include <stdexcept>

namespace hemo::particles {

namespace {

const Species& species_of(const Scene& s, int sp) { return sp == kRbc ? s.rbc : s.platelet; }

}  // namespace

DemSpecies::DemSpecies(const Scene& dem, const Scene& physical) {
  const Vec3 gravity(physical.gravity.x, physical.gravity.y, physical.gravity.z);
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    const Species& s = species_of(dem, sp);  // masses x dem_mass_scaling
    if (!s.present) continue;
    if (!(s.diameter > 0) || !(s.mass > 0) || !(s.volume > 0))
      throw std::invalid_argument(s.name + ": diameter, mass and volume must be positive");
    forces[sp] = std::make_unique<SpeciesForces>(s, dem);
    if (forces[sp]->needs_orientation()) {
      if (!(s.semi_axis_a > 0) || !(s.semi_axis_c > 0))
        throw std::invalid_argument(s.name + ": an oblate closure needs the semi-axes a and c");
      rotation[sp] = make_orientation_integrator(s.orientation_integrator,
                                                 SymmetricTop::oblate_spheroid(s.mass, s.semi_axis_a, s.semi_axis_c));
      any_orientation = true;
    }
    volume[sp] = s.volume;
    diameter[sp] = s.diameter;
    mass[sp] = s.mass;
    weight[sp] = species_of(physical, sp).mass * gravity;  // the physical weight, whatever the DEM mass
    d_max = std::max(d_max, s.diameter);
    d_min = d_min == 0 ? s.diameter : std::min(d_min, s.diameter);
  }
  if (d_max == 0) throw std::invalid_argument("the scene has no particle species");
}

}  // namespace hemo::particles
