// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_balance.h"

#include <atom.h>
#include <comm.h>
#include <domain.h>
#include <lammps.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hemo::particles {

double particle_imbalance(const LAMMPS_NS::LAMMPS& lmp, MPI_Comm comm) {
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  long counts[2] = {static_cast<long>(lmp.atom->nlocal), static_cast<long>(lmp.atom->nlocal)};
  MPI_Allreduce(MPI_IN_PLACE, &counts[0], 1, MPI_LONG, MPI_MAX, comm);
  MPI_Allreduce(MPI_IN_PLACE, &counts[1], 1, MPI_LONG, MPI_SUM, comm);
  if (counts[1] == 0) return 1;
  return static_cast<double>(counts[0]) * ranks / static_cast<double>(counts[1]);
}

std::vector<double> particle_count_cuts(const LAMMPS_NS::LAMMPS& lmp, double min_width, MPI_Comm comm) {
  const LAMMPS_NS::Comm& grid = *lmp.comm;
  const LAMMPS_NS::Domain& domain = *lmp.domain;
  if (grid.procgrid[0] != 1 || grid.procgrid[1] != 1)
    throw std::logic_error("the particle ranks' sub-domains are not slabs along z");
  const int slabs = grid.procgrid[2];
  const double lo = domain.boxlo[2], length = domain.boxhi[2] - domain.boxlo[2];
  // Each atom's z in the box: between two set-ups an atom may have crossed a periodic end.
  const LAMMPS_NS::Atom& atom = *lmp.atom;
  std::vector<double> z(static_cast<std::size_t>(atom.nlocal));
  for (int i = 0; i < atom.nlocal; ++i) {
    double f = (atom.x[i][2] - lo) / length;
    if (domain.zperiodic) f -= std::floor(f);
    z[static_cast<std::size_t>(i)] = std::clamp(f, 0.0, 1.0);
  }
  long total = static_cast<long>(z.size());
  MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPI_LONG, MPI_SUM, comm);
  const std::size_t cuts = static_cast<std::size_t>(slabs - 1);
  std::vector<double> below(cuts, 0.0), above(cuts, 1.0), mid(cuts);
  std::vector<long> count(cuts);
  // 52 halvings: a double's resolution of the box.
  for (int it = 0; it < 52; ++it) {
    for (std::size_t c = 0; c < cuts; ++c) mid[c] = 0.5 * (below[c] + above[c]);
    std::fill(count.begin(), count.end(), 0L);
    for (const double f : z)
      for (std::size_t c = 0; c < cuts; ++c) count[c] += f < mid[c];
    MPI_Allreduce(MPI_IN_PLACE, count.data(), static_cast<int>(cuts), MPI_LONG, MPI_SUM, comm);
    for (std::size_t c = 0; c < cuts; ++c) {
      // The (c + 1)-th of `slabs` equal shares of the particles lies below cut c.
      if (count[c] * slabs < static_cast<long>(c + 1) * total)
        below[c] = mid[c];
      else
        above[c] = mid[c];
    }
  }
  const double width = min_width / length;
  std::vector<double> out(cuts);
  for (std::size_t c = 0; c < cuts; ++c) {
    const double lower = std::max(grid.zsplit[c] + width, c > 0 ? out[c - 1] + width : width);
    const double upper = std::min(grid.zsplit[c + 2] - width, 1.0 - width * static_cast<double>(cuts - c));
    out[c] = std::clamp(above[c], lower, std::max(lower, upper));
  }
  return out;
}

bool set_z_cuts(LAMMPS_NS::LAMMPS& lmp, const std::vector<double>& cuts) {
  LAMMPS_NS::Comm& grid = *lmp.comm;
  if (static_cast<int>(cuts.size()) != grid.procgrid[2] - 1) throw std::logic_error("one z cut per pair of slabs");
  bool moved = false;
  for (std::size_t c = 0; c < cuts.size(); ++c) {
    moved = moved || grid.zsplit[c + 1] != cuts[c];
    grid.zsplit[c + 1] = cuts[c];
  }
  // LAMMPS's `balance` does the same: the ghost exchange then finds how many ranks away each
  // rank's ghosts lie (Comm::setup) instead of taking equal slabs.
  if (moved) grid.uniform = 0;
  lmp.domain->set_local_box();
  return moved;
}

std::vector<double> z_cuts(const LAMMPS_NS::LAMMPS& lmp) {
  const LAMMPS_NS::Comm& grid = *lmp.comm;
  if (grid.uniform) return {};
  return std::vector<double>(grid.zsplit + 1, grid.zsplit + grid.procgrid[2]);
}

}  // namespace hemo::particles
