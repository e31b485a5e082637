// LIGGGHTS's part of a checkpoint (engine_state.h): its atoms, the per-atom values of its fixes
// and ours, the pair and wall contact histories.
//
// Between two runs LIGGGHTS holds its atoms, their fixes' values, the contact histories and its
// neighbour lists. The lists cannot be saved, so a checkpoint first rebuilds them (and the ghost
// atoms, and the periodic wrap) from the atoms, as any `run` set-up does, keeping the forces,
// torques and fix values as they are; a restored engine recreates the same atoms in the same
// order on the same ranks and rebuilds the same way. Both then go on bit for bit alike. (A run
// that writes a checkpoint differs from one that does not by that rebuild: the same contacts
// summed in another order, round-off.) A checkpoint written on another rank count is restored
// from all its ranks' states, each rank taking the atoms inside its own sub-domain: the same
// atoms, contacts and values, summed in another order (round-off).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "dem_session.h"
#include "engine_state.h"

#include <mpi.h>

#include <functional>
#include <vector>

namespace LAMMPS_NS {
class FixContactHistory;
}

namespace hemo::particles {

class LiggghtsCheckpoint {
 public:
  LiggghtsCheckpoint(LiggghtsSession& liggghts, MPI_Comm comm) : liggghts_(liggghts), comm_(comm) {}

  // Rebuilds the neighbour lists, then saves this rank's atoms in their new order, the atom
  // types, particle count, DEM step and list-build count (collective).
  void save(EngineState& state);
  // Into a box set up for the state's atom types: the atoms as saved, the DEM step and step
  // length, rebuilt the same way. Throws std::invalid_argument, on every rank alike, when the
  // state does not fit the box.
  // `listener`: an open vessel's events from then on (LiggghtsSession::first_init).
  void restore(const EngineState& state, LiggghtsSession::OpenEndsListener listener = {});
  // Rebuilds the neighbour lists, the ghosts and the atoms' ranks as a checkpoint does, after
  // `before` (new sub-domains: dem_balance.h), the carried values put back (collective).
  void rebuild(const std::function<void()>& before = {});

 private:
  // The per-atom values a rebuild must leave as they were: force, torque, impulse, rotation,
  // held closures, wall history (the fixes present), and the state's vectors in the same order.
  struct Column {
    double** values;
    int width;
  };
  std::vector<Column> carried_columns() const;
  int carried_width() const;
  template <class State>
  auto carried_fields(State& state) const;
  // Every particle's carried values by tag: gathered over the ranks, or from a checkpoint; and
  // back onto this rank's atoms.
  std::vector<double> gather_carried() const;
  std::vector<double> carried_by_tag(const EngineState& state) const;
  void scatter_carried(const std::vector<double>& by_tag);

  void save_atoms(EngineState& state) const;
  void save_contact_history(EngineState& state) const;
  // Whether a position lies in this rank's sub-domain: each point of space has one such rank.
  std::function<bool(double, double, double)> in_own_sub_domain() const;
  void check_atoms(const EngineState& state) const;
  void create_atoms_as(const EngineState& state);
  void restore_contact_history(const EngineState& state);
  LAMMPS_NS::FixContactHistory* contact_history() const;

  LiggghtsSession& liggghts_;
  MPI_Comm comm_;
};

}  // namespace hemo::particles
