// Which fluid ranks' cells each particle rank needs, and which particle ranks each fluid rank
// serves: the overlap map of the partitioned exchange (issue #36, docs/scale-out.md §4), computed
// from both decompositions alone (no engine, no bus), at start-up and whenever either changes.
//
//   touched(p)  the cells whose bounding box meets particle rank p's sub-domain box grown by the
//               migration margin (in a periodic vessel also its images one period up and down):
//               every cell one of its particles can sit in or reach within a coupling interval
//   needed(p)   touched(p) and its one-cell halo, the cells sharing a point (so also those sharing
//               a face or an edge) with one of them: a sphere at the edge of the box is deposited
//               into the neighbours of its centre's cell (particle-node/deposition.h)
//   from(p, f)  needed(p) ∩ the cells fluid rank f owns: what p takes from f and sends f back
//
// Each cell is taken from its owner only, so the cells p receives from its fluid ranks are
// needed(p) exactly, each once. Periodic ends are joined by point: a point on the upper end plane
// is the point with the same x and y on the lower one, so that the halo of a cell at one end
// includes its neighbours at the other. All lengths in metres.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "vec.h"

#include <map>
#include <optional>
#include <vector>

namespace hemo {

// A mesh as far as the overlap needs it: its points and, per cell, the points of its faces (in
// any order, repeats allowed).
struct CellPoints {
  std::vector<particles::Vec3> points;
  std::vector<std::vector<int>> cells;
};

// From OpenFOAM-ordered faces as the MESH message carries them (messages/mesh_t.lcm): face i's
// points are face_points[face_offsets[i] .. face_offsets[i + 1]) (the last up to the end), its
// owner cell owner[i] and, for internal faces, neighbour[i].
CellPoints cell_points_from_faces(const std::vector<particles::Vec3>& points, int n_cells,
                                  const std::vector<int>& face_offsets, const std::vector<int>& face_points,
                                  const std::vector<int>& owner, const std::vector<int>& neighbour);

// The vessel's period along z: the end planes z0 and z0 + length are one.
struct AxialPeriod {
  double z0 = 0;
  double length = 0;
};

struct Box {
  particles::Vec3 lo = particles::Vec3::Zero(), hi = particles::Vec3::Zero();
};

struct FluidDecomposition {
  int ranks = 1;
  std::vector<int> owner;  // per cell, the fluid rank that owns it
};

struct ParticleDecomposition {
  std::vector<Box> boxes;  // per particle rank, its sub-domain
  double margin = 0;       // how far a particle of it may reach beyond its box within an interval
};

struct OverlapMap {
  // [particle rank] -> fluid rank -> the cells (ascending) it takes from that rank; only the
  // fluid ranks it needs anything of.
  std::vector<std::map<int, std::vector<int>>> from;
  // [particle rank] -> touched(p) (ascending): the cells its grown box meets.
  std::vector<std::vector<int>> touched;
  // [fluid rank] -> the particle ranks (ascending) that take any of its cells.
  std::vector<std::vector<int>> readers;
  // [fluid rank] -> its one-cell halo (ascending): the cells it does not own that share a point
  // with one it owns.
  std::vector<std::vector<int>> fluid_halo;

  // The cells of p's fluid ranks together: needed(p), ascending.
  std::vector<int> needed(int particle_rank) const;
};

// Throws std::invalid_argument with one line when the decompositions do not fit the mesh (an
// owner per cell, in 0 .. ranks - 1; a box with lo <= hi; a margin >= 0; a period > 0).
OverlapMap overlap_map(const CellPoints& mesh, const FluidDecomposition& fluid, const ParticleDecomposition& particles,
                       std::optional<AxialPeriod> period = std::nullopt);

// Per cell, the cells sharing a point with it (itself excluded, ascending), the period's end
// planes joined: the adjacency the halo is made of.
std::vector<std::vector<int>> point_neighbours(const CellPoints& mesh, std::optional<AxialPeriod> period);

}  // namespace hemo
