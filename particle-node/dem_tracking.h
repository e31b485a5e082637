// What the engine follows per particle across DEM steps, indexed by LIGGGHTS's atom tag rather
// than kept with the atom: its z unwrapped over the periodic crossings (LIGGGHTS wraps it into
// the box), and the locate cache of its fluid cell; packed for one cache line per particle.
// Every rank holds every tag: after a run the crossings of each rank's own atoms are summed into
// everyone's view (sync), so that an atom that moved to another rank keeps its count. The locate
// cache is each rank's own guess (a stale one costs a search).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "engine_state.h"
#include "placement.h"
#include "vec.h"

#include <mpi.h>

#include <vector>

namespace hemo::particles {

class ParticleTracking {
 public:
  explicit ParticleTracking(const CellLocator& locator) : locator_(&locator) {}

  // Tags 1..N for the particles in `order`, where they start.
  void start(const std::vector<const PlacedParticle*>& order);

  // z unwrapped over the crossings of the periodic ends since the start; `z` as LIGGGHTS has
  // it now (counts a crossing when it jumped by more than half the period since last seen).
  double unwrap_z(int tag, double z);
  // The fluid cell of a particle: exact, else the wall cell whose gap it is in, else -1.
  int cell_of(int tag, const Vec3& x, bool* in_wall_gap = nullptr);

  // After a run: the crossings and last z of every particle from the rank that has it
  // (collective; `tag` are this rank's `nlocal` atoms).
  void sync(int nlocal, const int* tag, MPI_Comm comm);

  void save(EngineState& state) const;
  // The state's `tracked` holds `particles` + 1 tags (checked by the caller).
  void restore(const EngineState& state, long particles);

 private:
  struct Tracked {
    LocateCache where;     // fluid cell
    double last_z = 0;     // z when last seen (as LIGGGHTS had it)
    double crossings = 0;  // periodic crossings along +z (integer valued)
  };

  const CellLocator* locator_;
  std::vector<Tracked> tracked_;  // index = LIGGGHTS atom tag, 0 unused
};

}  // namespace hemo::particles
