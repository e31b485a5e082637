// The LIGGGHTS fixes the DEM engine defines and the per-atom values they carry, and the engine's
// reductions over ranks. Private to the engine's units, with LIGGGHTS's headers (dem_session.cpp
// defines the fixes, dem_fluid_force.cpp and dem_orientation.cpp fill them every DEM step,
// dem_checkpoint.cpp carries them over): a column's meaning is spelled once, here.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <fix.h>
#include <mpi.h>

#include <cstdint>
#include <type_traits>
#include <vector>

namespace hemo::particles::dem {

constexpr const char* kFluidFix = "hemo_fluid";
// Its style, ours (registered by register_fix_styles): at each post_force, and at a run's set-up,
// it calls the callback set on it with LIGGGHTS's own per-atom force array, to which the callback
// adds the fluid force. (`fix external pf/callback` had the callback fill an array of the fix's,
// carried between ranks with every atom, and added it to the forces in a second pass over the
// atoms: one more array read and written per atom and DEM step, the same sums.)
constexpr const char* kFluidForceStyle = "hemo/fluid_force";
using FluidForceCallback = void (*)(void* target, std::int64_t ntimestep, int nlocal, int* tag, double** x, double** f);
LAMMPS_NS::Fix* create_fluid_force_fix(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg);
void set_fluid_force_callback(LAMMPS_NS::Fix* fix, FluidForceCallback callback, void* target);
constexpr const char* kImpulseFix = "hemo_impulse";
constexpr const char* kRotationFix = "hemo_rotation";
constexpr const char* kClosureFix = "hemo_closures";
constexpr const char* kWallFix = "hemo_wall";
constexpr const char* kWallMeshFix = "hemo_wall_mesh";  // a shape's wall as triangles (fix mesh/surface)
// LIGGGHTS's name of the fix property/atom where fix wall/gran keeps a primitive wall's contact
// history per atom (checkpoints save it). A mesh wall keeps its history elsewhere (fix
// contacthistory/mesh), which checkpoints do not carry.
constexpr const char* kWallHistoryFix = "history_hemo_wall";
// An open vessel's feeder's wall (a primitive cylinder) and its history.
constexpr const char* kFeederWallFix = "hemo_feeder_wall";
constexpr const char* kFeederWallHistoryFix = "history_hemo_feeder_wall";

// The per-atom closure values held between evaluations (time.closure_every_dem_steps > 1, or
// a held coupling.fluid_force). kCell: the fluid cell they were evaluated in (where the
// co-relaxed plasma answers), which moves with the atom to another rank as the per-tag locate
// cache does not. kDrag: the drag held as a constant (coupling.fluid_force = "held"). kStress:
// the plasma's stress on the particle's volume, F_p + F_v (coupling.momentum).
enum ClosureSlot {
  kBeta = 0,
  kRatio = 1,
  kVelocity = 2,
  kLift = 5,
  kTorque = 8,
  kCell = 11,
  kDrag = 12,
  kStress = 15,
  kClosureSlots = 18
};
constexpr int kImpulseValues = 8;   // F dt (3), beta dt, last F (3), last beta
constexpr int kRotationValues = 7;  // q (w, x, y, z), L (3)

// This rank's rows of a per-atom fix (null: no fix).
inline double** per_atom(LAMMPS_NS::Fix* fix) { return fix != nullptr ? fix->array_atom : nullptr; }

inline double sum_all(double v, MPI_Comm comm) {
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_SUM, comm);
  return v;
}

// Every rank's values (int or double), in rank order, on every rank.
template <class T>
std::vector<T> gather_all(const std::vector<T>& mine, MPI_Comm comm) {
  static_assert(std::is_same_v<T, int> || std::is_same_v<T, double>);
  const MPI_Datatype type = std::is_same_v<T, int> ? MPI_INT : MPI_DOUBLE;
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  std::vector<int> sizes(ranks), offsets(ranks, 0);
  const int n = static_cast<int>(mine.size());
  MPI_Allgather(&n, 1, MPI_INT, sizes.data(), 1, MPI_INT, comm);
  for (int r = 1; r < ranks; ++r) offsets[r] = offsets[r - 1] + sizes[r - 1];
  std::vector<T> all(offsets.back() + sizes.back());
  MPI_Allgatherv(mine.data(), n, type, all.data(), sizes.data(), offsets.data(), type, comm);
  return all;
}

}  // namespace hemo::particles::dem
