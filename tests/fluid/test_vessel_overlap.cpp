// The overlap map (model/overlap_map.h) on the fluid's own O-grid vessel mesh: its faces read
// as the MESH message carries them, its periodic ends joined by point as its cyclic patches join
// them by face.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "overlap_map.h"
#include "vessel_mesh.h"

#include <algorithm>
#include <set>
#include <vector>

namespace {

struct Read {
  hemo::PolyMesh poly;
  hemo::CellPoints mesh;
};

// The paper's vessel (100 um x 600 um) on a small O-grid, read back face by face.
Read vessel_read_as_faces() {
  hemo::MeshSpec spec;
  spec.core_cells = 2;
  spec.ring_cells = 2;
  spec.axial_cells = 12;
  Read r{hemo::make_vessel_mesh(hemo::Vessel{100e-6, 600e-6}, spec), {}};
  std::vector<hemo::particles::Vec3> points;
  for (const auto& p : r.poly.points) points.emplace_back(p[0], p[1], p[2]);
  std::vector<int> offsets, flat;
  for (const auto& f : r.poly.faces) {
    offsets.push_back(static_cast<int>(flat.size()));
    flat.insert(flat.end(), f.begin(), f.end());
  }
  r.mesh = hemo::cell_points_from_faces(points, r.poly.n_cells, offsets, flat, r.poly.owner, r.poly.neighbour);
  return r;
}

bool contains(const std::vector<int>& sorted, int x) { return std::binary_search(sorted.begin(), sorted.end(), x); }

}  // namespace

// Every pair of cells across an internal face are point neighbours; across the cyclic pair
// (inlet face i is outlet face i's partner) they are exactly when the period joins the ends.
TEST(VesselOverlap, PointNeighboursFollowTheFacesAndTheCyclicPair) {
  const Read r = vessel_read_as_faces();
  const hemo::AxialPeriod period{0, 600e-6};
  const auto joined = hemo::point_neighbours(r.mesh, period), open = hemo::point_neighbours(r.mesh, std::nullopt);
  for (int f = 0; f < r.poly.n_internal_faces(); ++f) {
    const int a = r.poly.owner[static_cast<std::size_t>(f)], b = r.poly.neighbour[static_cast<std::size_t>(f)];
    EXPECT_TRUE(contains(joined[static_cast<std::size_t>(a)], b)) << "face " << f;
    EXPECT_TRUE(contains(joined[static_cast<std::size_t>(b)], a)) << "face " << f;
  }
  const auto& inlet = r.poly.patch(hemo::patch_name::inlet);
  const auto& outlet = r.poly.patch(hemo::patch_name::outlet);
  ASSERT_EQ(inlet.type, "cyclic");
  ASSERT_EQ(inlet.size, outlet.size);
  for (int i = 0; i < inlet.size; ++i) {
    const int a = r.poly.owner[static_cast<std::size_t>(inlet.start + i)];
    const int b = r.poly.owner[static_cast<std::size_t>(outlet.start + i)];
    EXPECT_TRUE(contains(joined[static_cast<std::size_t>(a)], b)) << "cyclic face pair " << i;
    EXPECT_FALSE(contains(open[static_cast<std::size_t>(a)], b)) << "cyclic face pair " << i;
  }
}

// Two fluid ranks split at mid-length, two particle ranks likewise with a margin: each particle
// rank takes from both fluid ranks (the far one through the periodic ends), and the cells at the
// inlet, which particle rank 1 does not meet, come to it as the halo of the outlet's cells.
TEST(VesselOverlap, ParticleRanksOfAPeriodicVesselTakeTheHaloAcrossItsEnds) {
  const Read r = vessel_read_as_faces();
  const double length = 600e-6, dz = length / 12;
  const auto geo = hemo::compute_geometry(r.poly);
  hemo::FluidDecomposition fluid{2, {}};
  for (const auto& c : geo.cell_centres) fluid.owner.push_back(c[2] < length / 2 ? 0 : 1);
  const double half = 60e-6;
  hemo::ParticleDecomposition particles;
  particles.boxes = {{{-half, -half, 0}, {half, half, length / 2 - 0.6 * dz}},
                     {{-half, -half, length / 2 + 0.6 * dz}, {half, half, length - 0.6 * dz}}};
  particles.margin = 0.1 * dz;
  const auto map = hemo::overlap_map(r.mesh, fluid, particles, hemo::AxialPeriod{0, length});
  EXPECT_EQ(map.from[0].size(), 2u);
  EXPECT_EQ(map.from[1].size(), 2u);
  const auto& inlet = r.poly.patch(hemo::patch_name::inlet);
  const auto needed = map.needed(1);
  for (int i = 0; i < inlet.size; ++i) {
    const int cell = r.poly.owner[static_cast<std::size_t>(inlet.start + i)];
    EXPECT_FALSE(contains(map.touched[1], cell)) << "inlet cell " << cell;
    EXPECT_TRUE(contains(needed, cell)) << "inlet cell " << cell;
  }
  // Without the period, the inlet is none of particle rank 1's business.
  const auto open = hemo::overlap_map(r.mesh, fluid, particles);
  const auto open_needed = open.needed(1);
  for (int i = 0; i < inlet.size; ++i)
    EXPECT_FALSE(contains(open_needed, r.poly.owner[static_cast<std::size_t>(inlet.start + i)]));
}
