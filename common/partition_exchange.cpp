// SPDX-License-Identifier: GPL-3.0-or-later
#include "partition_exchange.h"

#include "cell_fields.h"

#include <cell_partition.h>
#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

namespace hemo {

CellPoints cell_points_of(const mesh_t& mesh) {
  std::vector<particles::Vec3> points;
  points.reserve(mesh.points.size());
  for (const auto& p : mesh.points) points.emplace_back(p[0], p[1], p[2]);
  const std::vector<int> offsets(mesh.face_offsets.begin(), mesh.face_offsets.end());
  const std::vector<int> face_points(mesh.face_points.begin(), mesh.face_points.end());
  const std::vector<int> owner(mesh.owner.begin(), mesh.owner.end());
  const std::vector<int> neighbour(mesh.neighbour.begin(), mesh.neighbour.end());
  return cell_points_from_faces(points, mesh.n_cells, offsets, face_points, owner, neighbour);
}

std::optional<AxialPeriod> period_of(const mesh_t& mesh) {
  if (std::find(mesh.patch_types.begin(), mesh.patch_types.end(), "cyclic") == mesh.patch_types.end() ||
      mesh.points.empty())
    return std::nullopt;
  double z0 = mesh.points.front()[2];
  for (const auto& p : mesh.points) z0 = std::min(z0, p[2]);
  return AxialPeriod{z0, mesh.vessel_length_m};
}

namespace {

void require_mesh(const std::string& hash, const mesh_t& mesh, const char* what) {
  if (hash != mesh.mesh_hash)
    throw std::runtime_error(
        fmt::format("the {} is for mesh '{}', not the mesh received ('{}')", what, hash, mesh.mesh_hash));
}

}  // namespace

fluid_decomposition_t decomposition_message(const std::string& mesh_hash, const FluidDecomposition& fluid) {
  fluid_decomposition_t m;
  m.mesh_hash = mesh_hash;
  m.ranks = fluid.ranks;
  m.n_cells = static_cast<std::int32_t>(fluid.owner.size());
  m.owner.assign(fluid.owner.begin(), fluid.owner.end());
  return m;
}

FluidDecomposition fluid_decomposition_of(const fluid_decomposition_t& msg, const mesh_t& mesh) {
  require_mesh(msg.mesh_hash, mesh, "fluid's decomposition (PARTITION)");
  if (msg.n_cells != mesh.n_cells || static_cast<int>(msg.owner.size()) != mesh.n_cells || msg.ranks < 1)
    throw std::runtime_error(fmt::format("the fluid's decomposition (PARTITION) gives {} owners on {} ranks for {} cells",
                                         msg.owner.size(), msg.ranks, mesh.n_cells));
  FluidDecomposition d{msg.ranks, std::vector<int>(msg.owner.begin(), msg.owner.end())};
  for (std::size_t c = 0; c < d.owner.size(); ++c)
    if (d.owner[c] < 0 || d.owner[c] >= d.ranks)
      throw std::runtime_error(fmt::format("the fluid's decomposition (PARTITION) gives cell {} to rank {} of {}", c,
                                           d.owner[c], d.ranks));
  return d;
}

particle_domain_t domain_message(const std::string& mesh_hash, const ParticleDecomposition& particles) {
  particle_domain_t m;
  m.mesh_hash = mesh_hash;
  m.margin_m = particles.margin;
  m.ranks = static_cast<std::int32_t>(particles.boxes.size());
  for (const Box& b : particles.boxes) {
    m.lo.push_back({b.lo.x(), b.lo.y(), b.lo.z()});
    m.hi.push_back({b.hi.x(), b.hi.y(), b.hi.z()});
  }
  return m;
}

ParticleDecomposition particle_decomposition_of(const particle_domain_t& msg, const mesh_t& mesh) {
  require_mesh(msg.mesh_hash, mesh, "particles' domain (DOMAIN)");
  if (msg.ranks < 1 || static_cast<int>(msg.lo.size()) != msg.ranks || static_cast<int>(msg.hi.size()) != msg.ranks)
    throw std::runtime_error(fmt::format("the particles' domain (DOMAIN) has {} boxes for {} ranks", msg.lo.size(),
                                         msg.ranks));
  ParticleDecomposition d;
  d.margin = msg.margin_m;
  for (int r = 0; r < msg.ranks; ++r)
    d.boxes.push_back({particles::Vec3(msg.lo[r][0], msg.lo[r][1], msg.lo[r][2]),
                       particles::Vec3(msg.hi[r][0], msg.hi[r][1], msg.hi[r][2])});
  return d;
}

fluid_partition_t slice_partition(const fluid_state_t& local, const std::vector<int>& cells,
                                  const std::vector<int>& local_index, int fluid_rank, int particle_rank) {
  fluid_partition_t m;
  m.mesh_hash = local.mesh_hash;
  m.time_s = local.time_s;
  m.fluid_rank = fluid_rank;
  m.particle_rank = particle_rank;
  m.n_cells = static_cast<std::int32_t>(cells.size());
  m.cells.assign(cells.begin(), cells.end());
  m.velocity = slice_cells(local.velocity, kVectorValues, local_index);
  m.velocity_gradient = slice_cells(local.velocity_gradient, kTensorValues, local_index);
  if (!local.pressure_gradient.empty())
    m.pressure_gradient = slice_cells(local.pressure_gradient, kVectorValues, local_index);
  if (!local.viscous_force.empty()) m.viscous_force = slice_cells(local.viscous_force, kVectorValues, local_index);
  m.n_velocity_values = static_cast<std::int32_t>(m.velocity.size());
  m.n_gradient_values = static_cast<std::int32_t>(m.velocity_gradient.size());
  m.n_pressure_gradient_values = static_cast<std::int32_t>(m.pressure_gradient.size());
  m.n_viscous_values = static_cast<std::int32_t>(m.viscous_force.size());
  return m;
}

namespace {

// A pair message's cell ids (a state partition's or a feedback partition's), as many as it says
// and exactly the ones the overlap map expects from that rank; `cells` takes them.
template <class PairMessage>
std::string pair_cells(const PairMessage& msg, const std::vector<int>& expected, const std::string& from,
                       std::vector<int>& cells) {
  if (static_cast<int>(msg.cells.size()) != msg.n_cells)
    return fmt::format("{}: {} cell ids for {} cells", from, msg.cells.size(), msg.n_cells);
  cells.assign(msg.cells.begin(), msg.cells.end());
  if (std::string why = cell_list_problem(cells, expected); !why.empty())
    return fmt::format("{}: {} ({} cells received, {} expected by the overlap map)", from, why, cells.size(),
                       expected.size());
  return {};
}

}  // namespace

std::string take_partition(const fluid_partition_t& msg, const std::vector<int>& expected, int fluid_rank,
                           int particle_rank, fluid_state_t& whole) {
  const std::string from = fmt::format("fluid rank {} -> particle rank {}", fluid_rank, particle_rank);
  if (msg.fluid_rank != fluid_rank || msg.particle_rank != particle_rank)
    return fmt::format("{}: the message is fluid rank {}'s for particle rank {}", from, msg.fluid_rank,
                       msg.particle_rank);
  if (msg.mesh_hash != whole.mesh_hash)
    return fmt::format("{}: the state is for mesh '{}', not the mesh received ('{}')", from, msg.mesh_hash,
                       whole.mesh_hash);
  std::vector<int> cells;
  if (std::string why = pair_cells(msg, expected, from, cells); !why.empty()) return why;
  std::string why = flat_size_problem("velocity", msg.n_velocity_values, msg.velocity, kVectorValues, msg.n_cells);
  if (why.empty())
    why = flat_size_problem("velocity gradient", msg.n_gradient_values, msg.velocity_gradient, kTensorValues,
                            msg.n_cells);
  const bool gradp = msg.n_pressure_gradient_values != 0 || !msg.pressure_gradient.empty();
  const bool viscous = msg.n_viscous_values != 0 || !msg.viscous_force.empty();
  if (why.empty() && gradp)
    why = flat_size_problem("pressure gradient", msg.n_pressure_gradient_values, msg.pressure_gradient,
                            kVectorValues, msg.n_cells);
  if (why.empty() && viscous)
    why = flat_size_problem("viscous force", msg.n_viscous_values, msg.viscous_force, kVectorValues, msg.n_cells);
  if (!why.empty()) return from + ": " + why;
  try {
    assemble_cells(cells, msg.velocity, kVectorValues, whole.velocity);
    assemble_cells(cells, msg.velocity_gradient, kTensorValues, whole.velocity_gradient);
    // The optional fields: there as soon as one partition carries them (every rank's do or none).
    if (gradp) {
      whole.pressure_gradient.resize(static_cast<std::size_t>(kVectorValues) * whole.n_cells, 0.0);
      whole.n_pressure_gradient_values = kVectorValues * whole.n_cells;
      assemble_cells(cells, msg.pressure_gradient, kVectorValues, whole.pressure_gradient);
    }
    if (viscous) {
      whole.viscous_force.resize(static_cast<std::size_t>(kVectorValues) * whole.n_cells, 0.0);
      whole.n_viscous_values = kVectorValues * whole.n_cells;
      assemble_cells(cells, msg.viscous_force, kVectorValues, whole.viscous_force);
    }
  } catch (const std::invalid_argument& e) {
    return from + ": " + e.what();
  }
  whole.time_s = msg.time_s;
  return {};
}

feedback_partition_t slice_feedback(const particle_feedback_t& whole, const std::vector<int>& cells, int fluid_rank,
                                    int particle_rank) {
  feedback_partition_t m;
  m.mesh_hash = whole.mesh_hash;
  m.fluid_rank = fluid_rank;
  m.particle_rank = particle_rank;
  m.n_cells = static_cast<std::int32_t>(cells.size());
  m.cells.assign(cells.begin(), cells.end());
  m.solid_fraction = slice_cells(whole.solid_fraction, 1, cells);
  m.drag_coefficient = slice_cells(whole.drag_coefficient, 1, cells);
  m.source_explicit = slice_cells(whole.source_explicit, kVectorValues, cells);
  m.n_source_values = static_cast<std::int32_t>(m.source_explicit.size());
  return m;
}

std::string add_feedback_partition(const feedback_partition_t& msg, const std::vector<int>& expected, int fluid_rank,
                                   int particle_rank, particle_feedback_t& sum) {
  const std::string from = fmt::format("particle rank {} -> fluid rank {}", particle_rank, fluid_rank);
  if (msg.fluid_rank != fluid_rank || msg.particle_rank != particle_rank)
    return fmt::format("{}: the message is particle rank {}'s for fluid rank {}", from, msg.particle_rank,
                       msg.fluid_rank);
  if (msg.mesh_hash != sum.mesh_hash)
    return fmt::format("{}: the feedback is for mesh '{}', not this mesh ('{}')", from, msg.mesh_hash, sum.mesh_hash);
  std::vector<int> cells;
  if (std::string why = pair_cells(msg, expected, from, cells); !why.empty()) return why;
  std::string why = flat_size_problem("solid fraction", msg.n_cells, msg.solid_fraction, 1, msg.n_cells);
  if (why.empty()) why = flat_size_problem("drag coefficient", msg.n_cells, msg.drag_coefficient, 1, msg.n_cells);
  if (why.empty())
    why = flat_size_problem("explicit source", msg.n_source_values, msg.source_explicit, kVectorValues, msg.n_cells);
  if (!why.empty()) return from + ": " + why;
  try {
    add_cells(cells, msg.solid_fraction, 1, sum.solid_fraction);
    add_cells(cells, msg.drag_coefficient, 1, sum.drag_coefficient);
    add_cells(cells, msg.source_explicit, kVectorValues, sum.source_explicit);
  } catch (const std::invalid_argument& e) {
    return from + ": " + e.what();
  }
  return {};
}

}  // namespace hemo
