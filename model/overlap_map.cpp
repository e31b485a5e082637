// SPDX-License-Identifier: GPL-3.0-or-later
#include "overlap_map.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

namespace hemo {

using particles::Vec3;

CellPoints cell_points_from_faces(const std::vector<Vec3>& points, int n_cells, const std::vector<int>& face_offsets,
                                  const std::vector<int>& face_points, const std::vector<int>& owner,
                                  const std::vector<int>& neighbour) {
  if (owner.size() != face_offsets.size() || neighbour.size() > owner.size())
    throw std::invalid_argument(
        fmt::format("{} faces with {} owners and {} neighbours", face_offsets.size(), owner.size(), neighbour.size()));
  CellPoints mesh;
  mesh.points = points;
  mesh.cells.resize(static_cast<std::size_t>(n_cells));
  const std::size_t n_faces = face_offsets.size();
  for (std::size_t f = 0; f < n_faces; ++f) {
    const std::size_t begin = static_cast<std::size_t>(face_offsets[f]);
    const std::size_t end = f + 1 < n_faces ? static_cast<std::size_t>(face_offsets[f + 1]) : face_points.size();
    if (begin > end || end > face_points.size())
      throw std::invalid_argument(fmt::format("face {} runs past the face points", f));
    for (const int cell : {owner[f], f < neighbour.size() ? neighbour[f] : -1}) {
      if (cell < 0) continue;
      if (cell >= n_cells) throw std::invalid_argument(fmt::format("face {} names cell {} of {}", f, cell, n_cells));
      auto& mine = mesh.cells[static_cast<std::size_t>(cell)];
      mine.insert(mine.end(), face_points.begin() + static_cast<long>(begin),
                  face_points.begin() + static_cast<long>(end));
    }
  }
  // Each point once (a hexahedron's 8, not its faces' 24): the map reads the set only, and every
  // rank holds this for the whole mesh at start-up.
  for (auto& cell : mesh.cells) {
    std::sort(cell.begin(), cell.end());
    cell.erase(std::unique(cell.begin(), cell.end()), cell.end());
    cell.shrink_to_fit();
  }
  return mesh;
}

namespace {

// Per point, the point it is one with: itself, or for a point on the period's upper end plane the
// point with the same x and y on the lower one. The tolerance is far below any cell and far above
// the round-off of a point generated one period up.
std::vector<int> joined_points(const std::vector<Vec3>& points, std::optional<AxialPeriod> period) {
  std::vector<int> same(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) same[i] = static_cast<int>(i);
  if (!period) return same;
  const double tol = 1e-9 * period->length;
  const double top = period->z0 + period->length;
  // The lower plane's points sorted by (x, y): each upper one is looked up among its neighbours.
  std::vector<int> lower;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (std::abs(points[i].z() - period->z0) <= tol) lower.push_back(static_cast<int>(i));
  auto key = [&](int i) { return std::make_tuple(points[i].x(), points[i].y()); };
  std::sort(lower.begin(), lower.end(), [&](int a, int b) { return key(a) < key(b); });
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3& p = points[i];
    if (std::abs(p.z() - top) > tol) continue;
    auto it =
        std::lower_bound(lower.begin(), lower.end(), p.x() - tol, [&](int a, double x) { return points[a].x() < x; });
    for (; it != lower.end() && points[*it].x() <= p.x() + tol; ++it) {
      if (std::abs(points[*it].y() - p.y()) <= tol) {
        same[i] = *it;
        break;
      }
    }
  }
  return same;
}

void check(const CellPoints& mesh, const FluidDecomposition& fluid, const ParticleDecomposition& particles,
           std::optional<AxialPeriod> period) {
  if (fluid.ranks < 1) throw std::invalid_argument(fmt::format("{} fluid ranks", fluid.ranks));
  if (fluid.owner.size() != mesh.cells.size())
    throw std::invalid_argument(fmt::format("the fluid decomposition has an owner for {} cells, the mesh {}",
                                            fluid.owner.size(), mesh.cells.size()));
  for (std::size_t c = 0; c < fluid.owner.size(); ++c)
    if (fluid.owner[c] < 0 || fluid.owner[c] >= fluid.ranks)
      throw std::invalid_argument(
          fmt::format("cell {} is owned by fluid rank {} of {}", c, fluid.owner[c], fluid.ranks));
  for (const auto& cell : mesh.cells)
    for (const int p : cell)
      if (p < 0 || static_cast<std::size_t>(p) >= mesh.points.size())
        throw std::invalid_argument(fmt::format("a cell names point {} of {}", p, mesh.points.size()));
  for (std::size_t r = 0; r < particles.boxes.size(); ++r)
    if (!(particles.boxes[r].lo.array() <= particles.boxes[r].hi.array()).all())
      throw std::invalid_argument(fmt::format("particle rank {}'s box has a lower corner above its upper one", r));
  if (!(particles.margin >= 0)) throw std::invalid_argument(fmt::format("a margin of {} m", particles.margin));
  if (period && !(period->length > 0)) throw std::invalid_argument(fmt::format("a period of {} m", period->length));
}

bool boxes_meet(const Box& a, const Box& b) {
  return (a.lo.array() <= b.hi.array()).all() && (b.lo.array() <= a.hi.array()).all();
}

}  // namespace

std::vector<std::vector<int>> point_neighbours(const CellPoints& mesh, std::optional<AxialPeriod> period) {
  const auto same = joined_points(mesh.points, period);
  // Whole-mesh sized on every rank at start-up: each list holds each cell once (a cell's points
  // repeat in its faces, and all its pushes come while it is the one processed), and each
  // cell's neighbours are gathered in one scratch list and kept at their size.
  std::vector<std::vector<int>> cells_of_point(mesh.points.size());
  for (std::size_t c = 0; c < mesh.cells.size(); ++c)
    for (const int p : mesh.cells[c]) {
      auto& cells = cells_of_point[static_cast<std::size_t>(same[static_cast<std::size_t>(p)])];
      if (cells.empty() || cells.back() != static_cast<int>(c)) cells.push_back(static_cast<int>(c));
    }
  std::vector<std::vector<int>> out(mesh.cells.size());
  std::vector<int> n;
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    n.clear();
    for (const int p : mesh.cells[c]) {
      const auto& others = cells_of_point[static_cast<std::size_t>(same[static_cast<std::size_t>(p)])];
      n.insert(n.end(), others.begin(), others.end());
    }
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
    n.erase(std::remove(n.begin(), n.end(), static_cast<int>(c)), n.end());
    out[c].assign(n.begin(), n.end());
  }
  return out;
}

std::vector<int> OverlapMap::needed(int particle_rank) const {
  std::vector<int> all;
  for (const auto& [rank, cells] : from.at(static_cast<std::size_t>(particle_rank)))
    all.insert(all.end(), cells.begin(), cells.end());
  std::sort(all.begin(), all.end());
  return all;
}

OverlapMap overlap_map(const CellPoints& mesh, const FluidDecomposition& fluid, const ParticleDecomposition& particles,
                       std::optional<AxialPeriod> period) {
  check(mesh, fluid, particles, period);
  const std::size_t n_cells = mesh.cells.size();
  const auto neighbours = point_neighbours(mesh, period);

  std::vector<Box> cell_box(n_cells);
  for (std::size_t c = 0; c < n_cells; ++c) {
    Box b{Vec3::Constant(INFINITY), Vec3::Constant(-INFINITY)};
    for (const int p : mesh.cells[c]) {
      b.lo = b.lo.cwiseMin(mesh.points[static_cast<std::size_t>(p)]);
      b.hi = b.hi.cwiseMax(mesh.points[static_cast<std::size_t>(p)]);
    }
    cell_box[c] = b;
  }

  OverlapMap map;
  const std::size_t n_particle_ranks = particles.boxes.size();
  map.from.resize(n_particle_ranks);
  map.touched.resize(n_particle_ranks);
  map.readers.resize(static_cast<std::size_t>(fluid.ranks));
  map.fluid_halo.resize(static_cast<std::size_t>(fluid.ranks));

  // The grown box and, in a periodic vessel, its images a period up and down: the part of a box
  // past one end plane stands for cells at the other end.
  for (std::size_t r = 0; r < n_particle_ranks; ++r) {
    const Vec3 grow = Vec3::Constant(particles.margin);
    std::vector<Box> images{{particles.boxes[r].lo - grow, particles.boxes[r].hi + grow}};
    if (period)
      for (const double shift : {-period->length, period->length}) {
        Box image = images.front();
        image.lo.z() += shift;
        image.hi.z() += shift;
        images.push_back(image);
      }
    std::vector<char> needed(n_cells, 0);
    for (std::size_t c = 0; c < n_cells; ++c) {
      const bool meets =
          std::any_of(images.begin(), images.end(), [&](const Box& b) { return boxes_meet(b, cell_box[c]); });
      if (!meets) continue;
      map.touched[r].push_back(static_cast<int>(c));
      needed[c] = 1;
    }
    for (const int c : map.touched[r])
      for (const int n : neighbours[static_cast<std::size_t>(c)]) needed[static_cast<std::size_t>(n)] = 1;
    for (std::size_t c = 0; c < n_cells; ++c)
      if (needed[c]) map.from[r][fluid.owner[c]].push_back(static_cast<int>(c));
    for (const auto& [f, cells] : map.from[r]) map.readers[static_cast<std::size_t>(f)].push_back(static_cast<int>(r));
  }

  for (std::size_t c = 0; c < n_cells; ++c) {
    const int f = fluid.owner[c];
    for (const int n : neighbours[c])
      if (fluid.owner[static_cast<std::size_t>(n)] != f) map.fluid_halo[static_cast<std::size_t>(f)].push_back(n);
  }
  for (auto& halo : map.fluid_halo) {
    std::sort(halo.begin(), halo.end());
    halo.erase(std::unique(halo.begin(), halo.end()), halo.end());
  }
  return map;
}

}  // namespace hemo
