// The particle ranks' slabs moved to follow their particles (dem.load_balance =
// "particle_count"). LIGGGHTS 3.8 has neither LAMMPS's `balance` command nor `fix balance`, but
// it keeps LAMMPS's non-uniform sub-domains: the cuts of the `processors 1 1 P` grid along z are
// Comm::zsplit (fractions of the box), which Domain::set_local_box reads at every set-up, and a
// set-up's Comm::exchange moves each atom to the rank whose slab holds it. So a balance is the
// cuts, chosen as LAMMPS's `balance shift z` chooses them (each rank as many particles), then the
// rebuild a checkpoint already does between two runs (dem_checkpoint.h: the forces, torques and
// fixes' values the next run carries put back): the same atoms and contacts, on other ranks,
// summed in another order (round-off).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <mpi.h>

#include <vector>

namespace LAMMPS_NS {
class LAMMPS;
}

namespace hemo::particles {

// The ranks' particle counts: the largest over the mean (1: even); 1 without particles. Collective.
double particle_imbalance(const LAMMPS_NS::LAMMPS& lmp, MPI_Comm comm);

// The z cuts (fractions of the box, P - 1 of them, ascending) that leave each of the P slabs as
// many particles as can be (bisection on the count below each cut, summed over the ranks), each
// cut kept between its neighbours' present cuts (so an atom moves at most to the next rank, all
// that one exchange along z carries) and every slab at least `min_width` (m) thick. Collective;
// the same on every rank.
std::vector<double> particle_count_cuts(const LAMMPS_NS::LAMMPS& lmp, double min_width, MPI_Comm comm);

// Sets the cuts (fractions) and this rank's sub-domain from them (LIGGGHTS's next set-up moves
// the atoms); true when they differ from the present ones.
bool set_z_cuts(LAMMPS_NS::LAMMPS& lmp, const std::vector<double>& cuts);
// The present cuts when they are not LIGGGHTS's equal slabs, else none.
std::vector<double> z_cuts(const LAMMPS_NS::LAMMPS& lmp);

}  // namespace hemo::particles
