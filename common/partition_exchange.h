// The partitioned exchange between the nodes' ranks (docs/notes/partitioned-exchange.md): the
// messages of model/overlap_map.h's inputs (the fluid's cell owners on PARTITION, the particle
// ranks' boxes on DOMAIN), of its per-(fluid rank, particle rank) state (fluid_partition_t on
// FLUID_STATE.<f>.<p>) and of the feedback's partial sums back (feedback_partition_t on
// PARTICLE_FEEDBACK.<f>.<p>), turned into and out of the engine-free map and codec
// (model/cell_partition.h). With one rank each none of it is used: the whole-mesh messages are.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <hemo/feedback_partition_t.hpp>
#include <hemo/fluid_decomposition_t.hpp>
#include <hemo/fluid_partition_t.hpp>
#include <hemo/fluid_state_t.hpp>
#include <hemo/mesh_t.hpp>
#include <hemo/particle_domain_t.hpp>
#include <hemo/particle_feedback_t.hpp>

#include <overlap_map.h>

#include <optional>
#include <string>
#include <vector>

namespace hemo {

// Whether a run of these rank counts exchanges by partition (either node on more than one rank).
inline bool partitioned(int fluid_ranks, int particle_ranks) { return fluid_ranks * particle_ranks > 1; }

// The mesh's cells as the overlap map needs them, and its period: a mesh with a cyclic patch is
// periodic along z over its length from its lowest point (messages/mesh_t.lcm).
CellPoints cell_points_of(const mesh_t& mesh);
std::optional<AxialPeriod> period_of(const mesh_t& mesh);

// The decompositions' messages; the readers throw std::runtime_error with one line when a
// message does not fit the mesh (another mesh's, a cell count or array length that is not the
// mesh's, an owner or rank count out of range).
fluid_decomposition_t decomposition_message(const std::string& mesh_hash, const FluidDecomposition& fluid);
FluidDecomposition fluid_decomposition_of(const fluid_decomposition_t& msg, const mesh_t& mesh);
particle_domain_t domain_message(const std::string& mesh_hash, const ParticleDecomposition& particles);
ParticleDecomposition particle_decomposition_of(const particle_domain_t& msg, const mesh_t& mesh);

// What fluid rank f sends particle rank p: the values of `cells` (from[p][f], global ids), taken
// from `local`, a state of f's own cells in its local order (n_cells of them), at `local_index`.
fluid_partition_t slice_partition(const fluid_state_t& local, const std::vector<int>& cells,
                                  const std::vector<int>& local_index, int fluid_rank, int particle_rank);

// Checks a received partition against what particle rank p expects of fluid rank f (`expected`,
// from[p][f]) and writes its values into `whole` (the whole mesh's arrays, sized by resize_cells;
// its optional fields sized as the message carries them). Empty when done, else one line naming
// both ranks and the first cell that is wrong (unexpected, missing, repeated or out of order),
// or the mesh or field that does not fit; `whole` is then left as it was.
std::string take_partition(const fluid_partition_t& msg, const std::vector<int>& expected, int fluid_rank,
                           int particle_rank, fluid_state_t& whole);

// What particle rank p sends fluid rank f: its partial feedback `whole` (the whole mesh's arrays,
// its own particles' sums) at `cells` (from[p][f], global ids, ascending).
feedback_partition_t slice_feedback(const particle_feedback_t& whole, const std::vector<int>& cells, int fluid_rank,
                                    int particle_rank);

// Checks a received partial against what fluid rank f expects of particle rank p (`expected`,
// from[p][f]) and adds its values into `sum` (the whole mesh's arrays, sized by resize_cells).
// Empty when done, else one line naming both ranks and the first cell or field that is wrong;
// `sum` is then left as it was.
std::string add_feedback_partition(const feedback_partition_t& msg, const std::vector<int>& expected, int fluid_rank,
                                   int particle_rank, particle_feedback_t& sum);

}  // namespace hemo
