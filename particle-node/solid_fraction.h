// How a particle is shared among fluid cells (scene coupling.solid_fraction): the interface of the
// solid-fraction models (deposition.h: centre_cell, sphere_overlap; gaussian_kernel.h), which
// Deposition uses to share a particle's volume, impulse and drag response, and FluidSampler, for
// a model that reads the fluid over the same cells (samples_over_shares), to average what the
// particle sees.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <vec.h>

#include <string>
#include <vector>

namespace hemo::particles {

struct CellShare {
  int cell;
  double fraction;
  // The particle's centre as seen from this cell is x + dz e_z: -/+ the period for a cell reached
  // across a cyclic face.
  double dz = 0;
};

// The share of a sphere of radius r on the inside of a plane its centre is `beyond` past (m; < 0:
// the centre inside): 1 minus the spherical cap beyond the plane; 1 from a radius inside on.
double sphere_inside_share(double beyond, double radius);

class SolidFractionModel {
 public:
  virtual ~SolidFractionModel() = default;
  virtual std::string name() const = 0;
  // Fills `out` (cleared first) with the cells among which a particle of radius r centred at x
  // (wrapped, in `cell`) is shared, the first `cell`, with fractions >= 0 summing to 1; as many
  // cells as the model reaches.
  virtual void share(int cell, const Vec3& x, double radius, std::vector<CellShare>& out) const = 0;
  // True when the fluid a particle sees is the mean, with its shares, of what its cells hold
  // (FluidSampler::seen); else the value at its centre in its own cell.
  virtual bool samples_over_shares() const { return false; }
  // How far from its centre a particle of radius r reaches the cells it is shared with (m): what
  // a rank must hold of the fluid around its particles.
  virtual double reach(double radius) const { return radius; }
  // The share of a particle of radius r, its centre `beyond` past an open end's plane (m; < 0:
  // inside), that is on the inside: what the vessel's cells take of its volume, impulse and drag
  // response while it straddles the end (the fractions of share() sum to 1 over the cells, across
  // walls; across an open end the rest is the plasma's beyond, outside the fluid's domain).
  // The sphere's; exactly 1 from reach(radius) inside on.
  virtual double inside_share(double beyond, double radius) const { return sphere_inside_share(beyond, radius); }
};

}  // namespace hemo::particles
