// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_output.h"

#include <atom.h>
#include <force.h>
#include <lammps.h>
#include <neigh_list.h>
#include <neighbor.h>
#include <pair.h>

#include <algorithm>
#include <cmath>

#include "dem_fixes.h"
#include "dem_open_ends.h"

namespace hemo::particles {

using namespace dem;

EngineDiagnostics DemOutput::diagnostics(const FluidSampler* fluid) {
  EngineDiagnostics d;
  d.particles = liggghts_.particles();
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  const int nlocal = atom.nlocal;
  const int* tag = atom.tag;
  double** x = atom.x;
  double** v = atom.v;
  double sums[5] = {0, 0, 0, 0, 0};  // count, particle v_z, fluid u_z, particles in the wall gap, in the vessel
  const auto& feeder = liggghts_.feeder();
  double max_squared_speed = 0;
  for (int i = 0; i < nlocal; ++i) {
    const Vec3 xi(x[i][0], x[i][1], x[i][2]);
    // The square root once, of the largest: sqrt is monotone and rounded correctly, so the same bits.
    max_squared_speed = std::max(max_squared_speed, Vec3(v[i][0], v[i][1], v[i][2]).squaredNorm());
    if (straddles_outside(x[i])) continue;  // not in the vessel: past an end, on its way in or out
    bool in_gap = false;
    const int cell = tracking_.cell_of(tag[i], xi, &in_gap);
    sums[3] += in_gap;
    sums[4] += !(feeder && feeder->in_feeder(xi.x()));
    if (cell < 0 || !in_core(xi, cell)) continue;
    sums[0] += 1;
    sums[1] += v[i][2];
    if (fluid != nullptr && fluid->has_state()) sums[2] += fluid->velocity(cell, locator_.wrap(xi)).z();
  }
  MPI_Allreduce(MPI_IN_PLACE, sums, 5, MPI_DOUBLE, MPI_SUM, comm_);
  d.in_vessel = static_cast<long>(sums[4]);
  d.core_particles = static_cast<long>(sums[0]);
  d.in_wall_gap = static_cast<long>(sums[3]);
  if (sums[0] > 0) {
    d.core_particle_axial_velocity = sums[1] / sums[0];
    d.core_fluid_axial_velocity = sums[2] / sums[0];
  }
  double largest[2] = {std::sqrt(max_squared_speed), local_max_overlap()};  // one reduction: a maximum is exact
  MPI_Allreduce(MPI_IN_PLACE, largest, 2, MPI_DOUBLE, MPI_MAX, comm_);
  d.max_speed = largest[0];
  d.max_overlap = largest[1];
  return d;
}

DemOutput::DemOutput(const LiggghtsSession& liggghts, ParticleTracking& tracking, const DemSpecies& species,
                     const CellLocator& locator, MPI_Comm comm)
    : liggghts_(liggghts), tracking_(tracking), species_(species), locator_(locator), comm_(comm) {
  if (locator_.axisymmetric() == nullptr) {
    facets_.emplace(locator_.dem_wall(), species_.d_max / 2);
    core_cell_.resize(static_cast<std::size_t>(locator_.n_cells()));
    for (int c = 0; c < locator_.n_cells(); ++c) {
      const VesselWall::Section s = locator_.section(locator_.centre(c));
      core_cell_[static_cast<std::size_t>(c)] = s.off_axis < 0.5 * s.radius;
    }
  }
}

bool DemOutput::straddles_outside(const double* x) const {
  const dem::FixOpenEnds* ends = liggghts_.fixes().open_ends;
  return ends != nullptr && dem::FixOpenEnds::outside(ends->place(x));
}

bool DemOutput::crosses_an_end(const double* x, double radius) const {
  const dem::FixOpenEnds* ends = liggghts_.fixes().open_ends;
  if (ends == nullptr) return false;
  const dem::FixOpenEnds::Place p = ends->place(x);
  return p.end != dem::FixOpenEnds::kNone && p.beyond > -radius;
}

bool DemOutput::in_core(const Vec3& x, int cell) const {
  if (!core_cell_.empty()) return core_cell_[static_cast<std::size_t>(cell)];
  const VesselWall::Section section = locator_.section(x);  // a feeder cell's core is the feeder's
  return section.off_axis < 0.5 * section.radius;
}

double DemOutput::local_max_overlap() const {
  // The pairs LIGGGHTS keeps for its contacts: every pair that touches is in the neighbour list
  // (LIGGGHTS's check or ours keeps it so: dem_streaming_neighbours.h) and ghosts carry this step's positions,
  // so one pass over the list finds what measure_overlaps finds with a grid of all particles.
  // Before the first run there is no list; placement leaves no overlaps (test_placement).
  const LAMMPS_NS::LAMMPS& lmp = liggghts_.lammps();
  const double* r = lmp.atom->radius;
  double** x = lmp.atom->x;
  const int nlocal = lmp.atom->nlocal;
  double worst = 0;
  const auto& feeder = locator_.feeder();
  for (int i = 0; i < nlocal; ++i) {
    const Vec3 xi(x[i][0], x[i][1], x[i][2]);
    if (crosses_an_end(x[i], r[i])) continue;  // the wall ends at an end's plane
    if (facets_ && !(feeder && feeder->in_feeder(xi.x()))) {
      const double d = facets_->distance(xi);
      if (d < r[i]) worst = std::max(worst, (r[i] - d) / (2 * r[i]));
      continue;
    }
    // Radially, from the section's radius (the shape's R(z): within R'^2 / 2 of the overlap along
    // the wall's normal). A feeder cell against the feeder's wall (a cylinder), in the vessel frame.
    const VesselWall::Section section = locator_.section(xi);
    worst = std::max(worst, (section.off_axis + r[i] - section.radius) / (2 * r[i]));
  }
  const LAMMPS_NS::NeighList* list = lmp.force->pair != nullptr ? lmp.force->pair->list : nullptr;
  if (list == nullptr || lmp.neighbor->ncalls == 0) return worst;
  for (int k = 0; k < list->inum; ++k) {
    const int i = list->ilist[k];
    const int* neighbours = list->firstneigh[i];
    for (int n = 0; n < list->numneigh[i]; ++n) {
      const int j = neighbours[n] & NEIGHMASK;
      const double squared = (x[i][0] - x[j][0]) * (x[i][0] - x[j][0]) + (x[i][1] - x[j][1]) * (x[i][1] - x[j][1]) +
                             (x[i][2] - x[j][2]) * (x[i][2] - x[j][2]);
      // Most listed pairs do not touch, and their overlap (<= 0) cannot raise `worst` (>= 0):
      // the square root only for pairs within a hair of touching (the margin keeps the test on
      // the safe side of the rounding of the squares).
      const double touch = r[i] + r[j];
      if (squared > touch * touch * (1 + 1e-9)) continue;
      worst = std::max(worst, (touch - std::sqrt(squared)) / (2 * std::min(r[i], r[j])));
    }
  }
  return worst;
}

ParticleSnapshot DemOutput::snapshot(long step, double time_s) {
  const std::size_t n = static_cast<std::size_t>(liggghts_.tag_capacity());
  // Per tag: written (1), species, position (3), velocity (3), orientation (4); summed over ranks
  // (each atom on one rank). A tag no rank has (lost, or free in an open vessel) is not written,
  // nor is an open vessel's feeder (the inlet's supply, not the vessel's blood), nor a cell whose
  // centre is past an end (straddling it on its way in or out: not in the vessel, as counted).
  constexpr int kPer = 12;
  std::vector<double> buf(kPer * n, 0.0);
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  const int nlocal = atom.nlocal;
  const int* tag = atom.tag;
  const int* type = atom.type;
  double** x = atom.x;
  double** v = atom.v;
  double** rot = per_atom(liggghts_.fixes().rotation);
  const auto& feeder = liggghts_.feeder();
  for (int i = 0; i < nlocal; ++i) {
    if ((feeder && feeder->in_feeder(x[i][0])) || straddles_outside(x[i])) continue;
    const std::size_t k = kPer * static_cast<std::size_t>(tag[i] - 1);
    const int sp = liggghts_.species_of_type(type[i]);
    buf[k] = 1;
    buf[k + 1] = sp;
    buf[k + 2] = x[i][0];
    buf[k + 3] = x[i][1];
    buf[k + 4] = tracking_.unwrap_z(tag[i], x[i][2]);
    buf[k + 5] = v[i][0];
    buf[k + 6] = v[i][1];
    buf[k + 7] = v[i][2];
    if (species_.rotation[sp])
      for (int d = 0; d < 4; ++d) buf[k + 8 + d] = rot[i][d];
    else
      buf[k + 8] = 1;
  }
  int size = 1;
  MPI_Comm_size(comm_, &size);
  if (size > 1) MPI_Allreduce(MPI_IN_PLACE, buf.data(), static_cast<int>(buf.size()), MPI_DOUBLE, MPI_SUM, comm_);
  ParticleSnapshot s;
  s.step = step;
  s.time_s = time_s;
  for (std::size_t t = 0; t < n; ++t) {
    const double* row = &buf[kPer * t];
    // A periodic vessel writes every tag (a lost one as zeros), as it always has.
    if (row[0] == 0 && feeder) continue;
    s.id.push_back(static_cast<std::int64_t>(t + 1));
    s.species.push_back(static_cast<std::int8_t>(row[1]));
    s.position.insert(s.position.end(), row + 2, row + 5);
    s.velocity.insert(s.velocity.end(), row + 5, row + 8);
    s.orientation.insert(s.orientation.end(), row + 8, row + 12);
  }
  return s;
}

}  // namespace hemo::particles
