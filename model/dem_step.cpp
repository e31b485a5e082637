// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_step.h"

#include "units.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

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

double dem_mass_scaling(const Scene& scene, const Species& species) {
  return species.mass_scaling > 0 ? species.mass_scaling : scene.time.mass_scaling;
}

Scene dem_scene(const Scene& scene) {
  Scene s = scene;
  for (Species* sp : {&s.rbc, &s.platelet}) sp->mass *= dem_mass_scaling(scene, *sp);
  return s;
}

bool timed_species(const Species& sp) { return sp.present && sp.diameter > 0 && sp.mass > 0; }

ContactTime shortest_contact_time(const Scene& s, double shear) {
  std::vector<const Species*> bodies;
  for (const Species* sp : {&s.rbc, &s.platelet})
    if (timed_species(*sp)) bodies.push_back(sp);
  const auto& c = s.contact;
  const double inf = std::numeric_limits<double>::infinity();
  auto impact = [&](double d) { return shear > 0 ? shear * d : 1e-3; };
  ContactTime t{inf, {}};
  auto consider = [&](double tc, const std::string& what) {
    if (tc < t.time) {
      t.time = tc;
      t.limiting = what;
    }
  };
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const Species& a = *bodies[i];
    const double ra = a.diameter / 2;
    for (std::size_t j = i; j < bodies.size(); ++j) {
      const Species& b = *bodies[j];
      const double rb = b.diameter / 2;
      consider(hertz_contact_time(a.mass, ra, c.cell_youngs_modulus, c.cell_poisson_ratio, b.mass, rb,
                                  c.cell_youngs_modulus, c.cell_poisson_ratio, impact(2 * std::max(ra, rb))),
               a.name + "-" + b.name);
    }
    consider(hertz_contact_time(a.mass, ra, c.cell_youngs_modulus, c.cell_poisson_ratio, inf, inf,
                                c.wall_youngs_modulus, c.wall_poisson_ratio, impact(2 * ra)),
             a.name + "-wall");
  }
  return t;
}

double dem_substeps(double coupling_interval, double dt_max) {
  return std::max(1.0, std::ceil(coupling_interval / dt_max * (1 - 1e-12)));
}

}  // namespace hemo::particles
