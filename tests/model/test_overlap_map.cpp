// The overlap map (model/overlap_map.h) on slab meshes of box cells, where which cells a box
// meets and which cells are neighbours follow from the cell indices alone: the reference here
// works on indices and never on points, so it shares nothing with the map's own search.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <overlap_map.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <stdexcept>

using hemo::AxialPeriod;
using hemo::Box;
using hemo::CellPoints;
using hemo::FluidDecomposition;
using hemo::OverlapMap;
using hemo::ParticleDecomposition;
using hemo::particles::Vec3;

namespace {

constexpr double kH = 1e-5;  // cell edge, m

// nx x ny x nz cubes of edge kH from the origin; cell (i, j, k) is i + nx (j + ny k). The points
// of the upper end plane are points of their own, as in a mesh with cyclic patches.
struct Slab {
  int nx, ny, nz;
  int cell(int i, int j, int k) const { return i + nx * (j + ny * k); }
  int count() const { return nx * ny * nz; }
  double length() const { return nz * kH; }
  CellPoints mesh() const {
    CellPoints m;
    auto point = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
    for (int k = 0; k <= nz; ++k)
      for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) m.points.emplace_back(i * kH, j * kH, k * kH);
    m.cells.resize(static_cast<std::size_t>(count()));
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
          for (int c = 0; c < 8; ++c)
            m.cells[static_cast<std::size_t>(cell(i, j, k))].push_back(
                point(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2)));
    return m;
  }
  // Fluid ranks as equal slabs along z (nz a multiple of `ranks`).
  FluidDecomposition split_along_z(int ranks) const {
    FluidDecomposition d{ranks, {}};
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) d.owner.push_back(k / (nz / ranks));
    return d;
  }
  // Particle ranks as equal slabs along z across the whole section.
  std::vector<Box> boxes_along_z(int ranks) const {
    std::vector<Box> boxes;
    for (int r = 0; r < ranks; ++r)
      boxes.push_back({Vec3(0, 0, r * length() / ranks), Vec3(nx * kH, ny * kH, (r + 1) * length() / ranks)});
    return boxes;
  }
};

// The cells of one axis (n of them, edge kH) whose closed interval meets [a, b].
std::vector<int> meeting(int n, double a, double b) {
  std::vector<int> out;
  for (int i = 0; i < n; ++i)
    if (i * kH <= b && (i + 1) * kH >= a) out.push_back(i);
  return out;
}

// What the map must hold for one particle rank, from indices: the cells its grown box (and its
// images a period up and down) meets, then every cell within one index of them in each axis (in
// z across the period's ends).
std::set<int> reference_needed(const Slab& s, const Box& box, double margin, bool periodic, std::set<int>* touched) {
  std::set<std::array<int, 3>> hit;
  std::vector<double> shifts{0};
  if (periodic) shifts = {-s.length(), 0, s.length()};
  for (const double shift : shifts)
    for (int i : meeting(s.nx, box.lo.x() - margin, box.hi.x() + margin))
      for (int j : meeting(s.ny, box.lo.y() - margin, box.hi.y() + margin))
        for (int k : meeting(s.nz, box.lo.z() - margin + shift, box.hi.z() + margin + shift)) hit.insert({i, j, k});
  std::set<int> out;
  for (const auto& [i, j, k] : hit) {
    if (touched) touched->insert(s.cell(i, j, k));
    for (int di = -1; di <= 1; ++di)
      for (int dj = -1; dj <= 1; ++dj)
        for (int dk = -1; dk <= 1; ++dk) {
          const int a = i + di, b = j + dj;
          int c = k + dk;
          if (periodic) c = (c + s.nz) % s.nz;
          if (a < 0 || a >= s.nx || b < 0 || b >= s.ny || c < 0 || c >= s.nz) continue;
          out.insert(s.cell(a, b, c));
        }
  }
  return out;
}

// The map against the reference for every particle rank: the same cells, each from its owner,
// and every fluid rank's readers exactly the particle ranks that take one of its cells.
void expect_map_is_reference(const Slab& s, const FluidDecomposition& fluid, const ParticleDecomposition& particles,
                             bool periodic) {
  const auto map = hemo::overlap_map(s.mesh(), fluid, particles,
                                     periodic ? std::optional(AxialPeriod{0, s.length()}) : std::nullopt);
  ASSERT_EQ(map.from.size(), particles.boxes.size());
  std::vector<std::set<int>> readers(static_cast<std::size_t>(fluid.ranks));
  for (std::size_t p = 0; p < particles.boxes.size(); ++p) {
    std::set<int> touched;
    const auto want = reference_needed(s, particles.boxes[p], particles.margin, periodic, &touched);
    const auto got = map.needed(static_cast<int>(p));
    EXPECT_EQ(std::set<int>(got.begin(), got.end()), want) << "particle rank " << p;
    EXPECT_EQ(got.size(), want.size()) << "a cell taken twice by particle rank " << p;
    EXPECT_EQ(std::set<int>(map.touched[p].begin(), map.touched[p].end()), touched) << "particle rank " << p;
    for (const auto& [f, cells] : map.from[p]) {
      EXPECT_FALSE(cells.empty()) << "fluid rank " << f << " listed for particle rank " << p << " with no cell";
      for (const int c : cells) EXPECT_EQ(fluid.owner[static_cast<std::size_t>(c)], f) << "cell " << c;
    }
    for (const int c : want)
      readers[static_cast<std::size_t>(fluid.owner[static_cast<std::size_t>(c)])].insert(static_cast<int>(p));
  }
  for (int f = 0; f < fluid.ranks; ++f)
    EXPECT_EQ(
        std::set<int>(map.readers[static_cast<std::size_t>(f)].begin(), map.readers[static_cast<std::size_t>(f)].end()),
        readers[static_cast<std::size_t>(f)])
        << "fluid rank " << f;
}

// The z layers (k) among `cells` of slab `s`.
std::set<int> layers(const Slab& s, const std::vector<int>& cells) {
  std::set<int> out;
  for (const int c : cells) out.insert(c / (s.nx * s.ny));
  return out;
}

}  // namespace

TEST(OverlapMap, SlabInTwoAlongZWithBoxesOverlappingTheBoundary) {
  const Slab s{2, 2, 8};
  ParticleDecomposition particles{s.boxes_along_z(2), 0.3 * kH};
  expect_map_is_reference(s, s.split_along_z(2), particles, false);
  // By hand: particle rank 0's grown box ends 0.3 cells into fluid rank 1's first layer (4),
  // whose halo adds layer 5; it needs nothing of fluid rank 1 beyond.
  const auto map = hemo::overlap_map(s.mesh(), s.split_along_z(2), particles);
  EXPECT_EQ(layers(s, map.from[0].at(1)), (std::set<int>{s.nz / 2, s.nz / 2 + 1}));
  EXPECT_EQ(layers(s, map.from[1].at(0)), (std::set<int>{s.nz / 2 - 2, s.nz / 2 - 1}));
  EXPECT_EQ(map.readers[0], (std::vector<int>{0, 1}));
  EXPECT_EQ(map.readers[1], (std::vector<int>{0, 1}));
  // Without a margin the box still meets the layer across its face (a particle on the face is in
  // either cell).
  particles.margin = 0;
  expect_map_is_reference(s, s.split_along_z(2), particles, false);
}

TEST(OverlapMap, SlabInFourAlongZTwoParticleRanksReadThreeFluidRanksEach) {
  const Slab s{3, 2, 16};
  ParticleDecomposition particles{s.boxes_along_z(2), 0.5 * kH};
  expect_map_is_reference(s, s.split_along_z(4), particles, false);
  const auto map = hemo::overlap_map(s.mesh(), s.split_along_z(4), particles);
  // Fluid ranks own 4 layers each; the particle ranks' boundary is fluid ranks 1 and 2's.
  EXPECT_EQ(map.from[0].size(), 3u);
  EXPECT_EQ(map.from[1].size(), 3u);
  EXPECT_EQ(map.readers[0], std::vector<int>{0});
  EXPECT_EQ(map.readers[3], std::vector<int>{1});
  EXPECT_EQ(map.readers[1], (std::vector<int>{0, 1}));
  // Fluid rank 1's halo: the layer below it and the one above, whole.
  EXPECT_EQ(layers(s, map.fluid_halo[1]), (std::set<int>{3, 8}));
  EXPECT_EQ(map.fluid_halo[1].size(), static_cast<std::size_t>(2 * s.nx * s.ny));
}

TEST(OverlapMap, BoxesSplitAcrossTheSectionAndAlongZ) {
  // Four particle ranks as 2 x 2 blocks in (x, z), fluid in four slabs along z: each particle
  // rank takes only part of a section.
  const Slab s{6, 3, 8};
  std::vector<Box> boxes;
  for (int bz = 0; bz < 2; ++bz)
    for (int bx = 0; bx < 2; ++bx)
      boxes.push_back({Vec3(bx * 3 * kH, 0, bz * 4 * kH), Vec3((bx + 1) * 3 * kH, 3 * kH, (bz + 1) * 4 * kH)});
  expect_map_is_reference(s, s.split_along_z(4), {boxes, 0.25 * kH}, false);
  expect_map_is_reference(s, s.split_along_z(4), {boxes, 0.25 * kH}, true);
}

TEST(OverlapMap, APeriodicVesselJoinsItsEnds) {
  const Slab s{2, 2, 8};
  const auto fluid = s.split_along_z(4);
  // A box reaching past the upper end: with the period it meets layer 0, and takes it and its
  // halo (layer 1) from fluid rank 0; without, fluid rank 0 is none of its business.
  ParticleDecomposition past_the_end{{{Vec3(0, 0, 6 * kH), Vec3(2 * kH, 2 * kH, s.length())}}, 0.4 * kH};
  expect_map_is_reference(s, fluid, past_the_end, true);
  expect_map_is_reference(s, fluid, past_the_end, false);
  const auto wrapped = hemo::overlap_map(s.mesh(), fluid, past_the_end, AxialPeriod{0, s.length()});
  EXPECT_EQ(layers(s, wrapped.from[0].at(0)), (std::set<int>{0, 1}));
  const auto open = hemo::overlap_map(s.mesh(), fluid, past_the_end);
  EXPECT_EQ(open.from[0].count(0), 0u);

  // A box inside the last layer: it touches that layer alone, and the halo alone crosses the
  // joined end planes (the cells sharing the upper plane's points with it are layer 0's).
  ParticleDecomposition inside{{{Vec3(0, 0, 7.2 * kH), Vec3(kH, kH, 7.8 * kH)}}, 0};
  expect_map_is_reference(s, fluid, inside, true);
  const auto halo = hemo::overlap_map(s.mesh(), fluid, inside, AxialPeriod{0, s.length()});
  EXPECT_EQ(layers(s, halo.touched[0]), std::set<int>{7});
  EXPECT_EQ(layers(s, halo.from[0].at(0)), std::set<int>{0});
  EXPECT_EQ(hemo::overlap_map(s.mesh(), fluid, inside).from[0].count(0), 0u);
  // The fluid ranks at the ends are each other's halo.
  EXPECT_EQ(layers(s, halo.fluid_halo[0]), (std::set<int>{2, 7}));
}

TEST(OverlapMap, EveryPointAParticleRankCanReachIsInACellItTakesWithItsNeighbours) {
  // Points on a fine lattice through each grown box, wrapped into the period, located by index:
  // the cell holding each and all of that cell's neighbours must be among the cells the rank
  // takes, and come from the cells' owners.
  const Slab s{4, 3, 12};
  const auto fluid = s.split_along_z(3);
  std::vector<Box> boxes = {{Vec3(0, 0, -0.5 * kH), Vec3(2.5 * kH, 3 * kH, 5.3 * kH)},
                            {Vec3(1.7 * kH, 0.2 * kH, 4.1 * kH), Vec3(4 * kH, 3 * kH, 12.6 * kH)}};
  const double margin = 0.35 * kH;
  const auto map = hemo::overlap_map(s.mesh(), fluid, {boxes, margin}, AxialPeriod{0, s.length()});
  constexpr int kSamples = 23;
  for (std::size_t p = 0; p < boxes.size(); ++p) {
    const auto got = map.needed(static_cast<int>(p));
    const std::set<int> needed(got.begin(), got.end());
    const Vec3 lo = boxes[p].lo - Vec3::Constant(margin), hi = boxes[p].hi + Vec3::Constant(margin);
    int checked = 0;
    for (int a = 0; a <= kSamples; ++a)
      for (int b = 0; b <= kSamples; ++b)
        for (int c = 0; c <= kSamples; ++c) {
          const Vec3 x = lo + (hi - lo).cwiseProduct(Vec3(a, b, c) / kSamples);
          const int i = static_cast<int>(std::floor(x.x() / kH)), j = static_cast<int>(std::floor(x.y() / kH));
          if (i < 0 || i >= s.nx || j < 0 || j >= s.ny) continue;  // outside the mesh's section
          const int k = (static_cast<int>(std::floor(x.z() / kH)) % s.nz + s.nz) % s.nz;
          for (int di = -1; di <= 1; ++di)
            for (int dj = -1; dj <= 1; ++dj)
              for (int dk = -1; dk <= 1; ++dk) {
                if (i + di < 0 || i + di >= s.nx || j + dj < 0 || j + dj >= s.ny) continue;
                const int cell = s.cell(i + di, j + dj, (k + dk + s.nz) % s.nz);
                ASSERT_TRUE(needed.count(cell))
                    << "particle rank " << p << " misses cell " << cell << " near " << x.transpose();
                const auto& from_owner = map.from[p].at(fluid.owner[static_cast<std::size_t>(cell)]);
                EXPECT_TRUE(std::binary_search(from_owner.begin(), from_owner.end(), cell));
              }
          ++checked;
        }
    EXPECT_GT(checked, kSamples * kSamples) << "particle rank " << p;
  }
}

TEST(OverlapMap, CellPointsFromOpenFoamOrderedFaces) {
  // Two cubes stacked in z: 12 points, 11 faces (1 internal, then 10 boundary faces).
  std::vector<Vec3> points;
  for (int k = 0; k <= 2; ++k)
    for (int j = 0; j <= 1; ++j)
      for (int i = 0; i <= 1; ++i) points.emplace_back(i * kH, j * kH, k * kH);
  auto p = [](int i, int j, int k) { return i + 2 * (j + 2 * k); };
  std::vector<std::vector<int>> faces = {{p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1)}};  // internal
  std::vector<int> owner = {0}, neighbour = {1};
  for (int k = 0; k < 2; ++k) {
    faces.push_back({p(0, 0, k), p(0, 1, k), p(0, 1, k + 1), p(0, 0, k + 1)});
    faces.push_back({p(1, 0, k), p(1, 0, k + 1), p(1, 1, k + 1), p(1, 1, k)});
    faces.push_back({p(0, 0, k), p(0, 0, k + 1), p(1, 0, k + 1), p(1, 0, k)});
    faces.push_back({p(0, 1, k), p(1, 1, k), p(1, 1, k + 1), p(0, 1, k + 1)});
    owner.insert(owner.end(), 4, k);
  }
  faces.push_back({p(0, 0, 0), p(1, 0, 0), p(1, 1, 0), p(0, 1, 0)});
  faces.push_back({p(0, 0, 2), p(0, 1, 2), p(1, 1, 2), p(1, 0, 2)});
  owner.push_back(0);
  owner.push_back(1);
  std::vector<int> offsets, flat;
  for (const auto& f : faces) {
    offsets.push_back(static_cast<int>(flat.size()));
    flat.insert(flat.end(), f.begin(), f.end());
  }
  const auto mesh = hemo::cell_points_from_faces(points, 2, offsets, flat, owner, neighbour);
  ASSERT_EQ(mesh.cells.size(), 2u);
  for (int c = 0; c < 2; ++c) {
    std::set<int> want;
    for (int k = c; k <= c + 1; ++k)
      for (int j = 0; j <= 1; ++j)
        for (int i = 0; i <= 1; ++i) want.insert(p(i, j, k));
    EXPECT_EQ(std::set<int>(mesh.cells[c].begin(), mesh.cells[c].end()), want) << "cell " << c;
  }
  // The two cells share the internal face's points: each is the other's only neighbour.
  const auto n = hemo::point_neighbours(mesh, std::nullopt);
  EXPECT_EQ(n[0], std::vector<int>{1});
  EXPECT_EQ(n[1], std::vector<int>{0});
}

TEST(OverlapMap, RefusesDecompositionsThatDoNotFitTheMesh) {
  const Slab s{2, 2, 4};
  const auto mesh = s.mesh();
  auto fluid = s.split_along_z(2);
  const ParticleDecomposition particles{s.boxes_along_z(2), 0};
  fluid.owner.pop_back();
  EXPECT_THROW(hemo::overlap_map(mesh, fluid, particles), std::invalid_argument);
  fluid = s.split_along_z(2);
  fluid.owner[3] = 2;
  EXPECT_THROW(hemo::overlap_map(mesh, fluid, particles), std::invalid_argument);
  fluid = s.split_along_z(2);
  auto inverted = particles;
  std::swap(inverted.boxes[0].lo, inverted.boxes[0].hi);
  EXPECT_THROW(hemo::overlap_map(mesh, fluid, inverted), std::invalid_argument);
  EXPECT_THROW(hemo::overlap_map(mesh, fluid, {particles.boxes, -kH}), std::invalid_argument);
  EXPECT_THROW(hemo::overlap_map(mesh, fluid, particles, AxialPeriod{0, 0}), std::invalid_argument);
}
