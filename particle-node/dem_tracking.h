// What the engine follows per particle across DEM steps, indexed by LIGGGHTS's atom tag rather
// than kept with the atom: its z unwrapped over the periodic crossings (LIGGGHTS wraps it into
// the box), and the locate cache of its fluid cell; packed for one cache line per particle.
// Every rank holds every tag, and the rank that has an atom keeps its crossing record current. An
// atom that moves to another rank takes its record along in LIGGGHTS's own exchange: our fix
// `hemo/tracking` packs and unpacks the two values with the atom (pack_exchange), so only the
// atoms that change ranks carry records, at the moment they change. A checkpoint makes every
// rank's view whole first (share_all). The locate cache is each rank's own guess (a stale one
// costs a search). In an open vessel tags come and go (dem_open_ends.h): each tag is present or
// free, and a tag given again starts afresh.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "engine_state.h"
#include "placement.h"
#include "vec.h"

#include <mpi.h>

#include <vector>

namespace LAMMPS_NS {
class LAMMPS;
class Fix;
}  // namespace LAMMPS_NS

namespace hemo::particles {

class ParticleTracking {
 public:
  explicit ParticleTracking(const CellLocator& locator) : locator_(&locator) {}

  // Tags 1..N for the particles in `order`, where they start.
  void start(const std::vector<const PlacedParticle*>& order);
  // An open end's events: a tag freed, a tag given (again) to a new particle made at z (m, as
  // made: below the box when before the inlet, so that its z unwraps to the vessel's frame).
  void leave(int tag) { present_[tag] = 0; }
  void enter(int tag, double z);
  // Per tag (index = tag, 0 unused): whether a particle has it.
  const std::vector<char>& present() const { return present_; }

  // z unwrapped over the crossings of the periodic ends since the start; `z` as LIGGGHTS has
  // it now (counts a crossing when it jumped by more than half the period since last seen).
  double unwrap_z(int tag, double z);
  // The fluid cell of a particle: exact, else the wall cell whose gap it is in, else -1.
  int cell_of(int tag, const Vec3& x, bool* in_wall_gap = nullptr);

  // Every record from the rank that has its atom, on every rank (collective; `tag` are this
  // rank's `nlocal` atoms): before a checkpoint.
  void share_all(int nlocal, const int* tag, MPI_Comm comm);
  // An atom's record as it moves to another rank (LIGGGHTS's exchange): kRecordValues doubles.
  static constexpr int kRecordValues = 2;
  void pack(int tag, double* buf) const;
  void unpack(int tag, const double* buf);

  void save(EngineState& state) const;
  // The state's `tracked` holds `tags` + 1 tags (checked by the caller).
  void restore(const EngineState& state, long tags);

 private:
  struct Tracked {
    LocateCache where;     // fluid cell
    double last_z = 0;     // z when last seen (as LIGGGHTS had it); NaN: not yet seen
    double crossings = 0;  // periodic crossings along +z (integer valued)
  };

  const CellLocator* locator_;
  std::vector<Tracked> tracked_;  // index = LIGGGHTS atom tag, 0 unused
  std::vector<char> present_;     // the same indices
};

namespace dem {

// The fix that carries each atom's record to its new rank (the style and the id the session
// gives it); attach_tracking hands it the engine's tracking before any atom moves.
constexpr const char* kTrackingStyle = "hemo/tracking";
constexpr const char* kTrackingFix = "hemo_tracking";
LAMMPS_NS::Fix* create_tracking_fix(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg);
void attach_tracking(LAMMPS_NS::Fix* fix, ParticleTracking* tracking);

}  // namespace dem

}  // namespace hemo::particles
