// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_timing.h"

#include "fluid_forces.h"

#include <units.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace hemo::particles {

DemTiming derive_dem_timing(const Scene& physical, double coupling_interval, int substeps_override) {
  const Scene s = dem_scene(physical);
  if (!(coupling_interval > 0)) throw std::invalid_argument("the coupling interval must be positive");
  if (!timed_species(s.rbc) && !timed_species(s.platelet))
    throw std::invalid_argument("the scene has no particle species to time");

  DemTiming t;
  const ContactTime contact = shortest_contact_time(s, wall_shear_rate(s));
  t.contact_time = contact.time;
  t.limiting = contact.limiting;
  t.rayleigh_time = std::numeric_limits<double>::infinity();
  t.relaxation_time = std::numeric_limits<double>::infinity();
  for (const Species* sp : {&s.rbc, &s.platelet}) {
    if (!timed_species(*sp)) continue;
    const double r = sp->diameter / 2;
    const double density = sp->mass / (4.0 / 3.0 * units::pi * r * r * r);
    t.rayleigh_time =
        std::min(t.rayleigh_time, rayleigh_time(r, density, s.contact.cell_youngs_modulus, s.contact.cell_poisson_ratio));
    if (s.plasma.viscosity > 0)
      t.relaxation_time = std::min(t.relaxation_time, sp->mass / SpeciesForces(*sp, s).max_coefficient_at_rest());
  }
  double dt_max = t.contact_time / s.time.steps_per_contact;
  if (s.time.relaxation_factor > 0 && s.time.relaxation_factor * t.relaxation_time < dt_max) {
    dt_max = s.time.relaxation_factor * t.relaxation_time;
    t.relaxation_limited = true;
  }
  t.substeps = substeps_override > 0 ? substeps_override : static_cast<int>(dem_substeps(coupling_interval, dt_max));
  t.dt = coupling_interval / t.substeps;
  return t;
}

}  // namespace hemo::particles
