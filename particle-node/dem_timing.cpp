// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_timing.h"

#include "fluid_forces.h"

#include <units.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace hemo::particles {

namespace {
double inv(double v) { return std::isfinite(v) ? 1.0 / v : 0.0; }
}  // namespace

double hertz_contact_time(double m1, double r1, double e1, double nu1, double m2, double r2, double e2, double nu2,
                          double v) {
  const double m = 1.0 / (inv(m1) + inv(m2));
  const double r = 1.0 / (inv(r1) + inv(r2));
  const double e = 1.0 / ((1 - nu1 * nu1) / e1 + (1 - nu2 * nu2) / e2);
  return 2.87 * std::pow(m * m / (r * e * e * v), 0.2);
}

double rayleigh_time(double radius, double density, double youngs, double poisson) {
  const double shear_modulus = youngs / (2 * (1 + poisson));
  return units::pi * radius * std::sqrt(density / shear_modulus) / (0.1631 * poisson + 0.8766);
}

double wall_shear_rate(const Scene& s) {
  if (s.driving.wall_shear_rate > 0) return s.driving.wall_shear_rate;
  if (s.driving.pressure_drop > 0 && s.plasma.viscosity > 0 && s.vessel.length > 0)
    return s.vessel.diameter * s.driving.pressure_drop / (4 * s.plasma.viscosity * s.vessel.length);
  return 0;
}

double dem_mass_scaling(const Scene& scene, const Species& species) {
  return species.mass_scaling > 0 ? species.mass_scaling : scene.time.mass_scaling;
}

Scene dem_scene(const Scene& scene) {
  Scene s = scene;
  for (Species* sp : {&s.rbc, &s.platelet}) sp->mass *= dem_mass_scaling(scene, *sp);
  return s;
}

DemTiming derive_dem_timing(const Scene& physical, double coupling_interval, int substeps_override) {
  const Scene s = dem_scene(physical);
  if (!(coupling_interval > 0)) throw std::invalid_argument("the coupling interval must be positive");
  struct Body {
    const Species* sp;
    double r, density;
  };
  std::vector<Body> bodies;
  for (const Species* sp : {&s.rbc, &s.platelet})
    if (sp->present && sp->diameter > 0 && sp->mass > 0) {
      const double r = sp->diameter / 2;
      bodies.push_back({sp, r, sp->mass / (4.0 / 3.0 * units::pi * r * r * r)});
    }
  if (bodies.empty()) throw std::invalid_argument("the scene has no particle species to time");

  const auto& c = s.contact;
  const double inf = std::numeric_limits<double>::infinity();
  // Impact velocity: the shear velocity scale across the larger particle of the pair. Without
  // any driving, the scale of a slow flow (1 mm/s) stands in (only sets the step, weakly: ^-1/5).
  const double shear = wall_shear_rate(s);
  auto impact = [&](double d) { return shear > 0 ? shear * d : 1e-3; };

  DemTiming t;
  t.contact_time = inf;
  t.rayleigh_time = inf;
  t.relaxation_time = inf;
  auto consider = [&](double tc, const std::string& what) {
    if (tc < t.contact_time) {
      t.contact_time = tc;
      t.limiting = what;
    }
  };
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const Body& a = bodies[i];
    for (std::size_t j = i; j < bodies.size(); ++j) {
      const Body& b = bodies[j];
      consider(hertz_contact_time(a.sp->mass, a.r, c.cell_youngs_modulus, c.cell_poisson_ratio, b.sp->mass, b.r,
                                  c.cell_youngs_modulus, c.cell_poisson_ratio, impact(2 * std::max(a.r, b.r))),
               a.sp->name + "-" + b.sp->name);
    }
    consider(hertz_contact_time(a.sp->mass, a.r, c.cell_youngs_modulus, c.cell_poisson_ratio, inf, inf,
                                c.wall_youngs_modulus, c.wall_poisson_ratio, impact(2 * a.r)),
             a.sp->name + "-wall");
    t.rayleigh_time =
        std::min(t.rayleigh_time, rayleigh_time(a.r, a.density, c.cell_youngs_modulus, c.cell_poisson_ratio));
    if (s.plasma.viscosity > 0)
      t.relaxation_time = std::min(t.relaxation_time, a.sp->mass / SpeciesForces(*a.sp, s).max_coefficient_at_rest());
  }
  double dt_max = t.contact_time / s.time.steps_per_contact;
  if (s.time.relaxation_factor > 0 && s.time.relaxation_factor * t.relaxation_time < dt_max) {
    dt_max = s.time.relaxation_factor * t.relaxation_time;
    t.relaxation_limited = true;
  }
  t.substeps = substeps_override > 0
                   ? substeps_override
                   : std::max(1, static_cast<int>(std::ceil(coupling_interval / dt_max * (1 - 1e-12))));
  t.dt = coupling_interval / t.substeps;
  return t;
}

}  // namespace hemo::particles
