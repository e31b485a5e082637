// SPDX-License-Identifier: GPL-3.0-or-later
#include "synthetic_case.h"
#include "cell_locator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

using hemo::particles::CellLocator;
using hemo::particles::Vec3;
using hemo::particles::synthetic::box_mesh;

namespace {

// 2 x 2 x 2 unit cubes over [0,2]^3, periodic along z with period 2; cell = (k*2 + j)*2 + i.
CellLocator unit_box() { return CellLocator(box_mesh(2, 2, 2, 0, 2, 0, 2, 2, 2)); }

int expected_cell(double x, double y, double z) {
  return (static_cast<int>(z) * 2 + static_cast<int>(y)) * 2 + static_cast<int>(x);
}

}  // namespace

TEST(CellLocator, FindsPointsInsideEachCell) {
  const auto loc = unit_box();
  ASSERT_EQ(loc.n_cells(), 8);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i)
        for (double off : {0.01, 0.5, 0.99}) {
          const double x = i + off, y = j + 1 - off, z = k + off;
          EXPECT_EQ(loc.locate(Vec3(x, y, z)), expected_cell(x, y, z)) << x << " " << y << " " << z;
        }
}

TEST(CellLocator, WrapsZPeriodically) {
  const auto loc = unit_box();
  EXPECT_DOUBLE_EQ(loc.length(), 2.0);
  EXPECT_DOUBLE_EQ(loc.z0(), 0.0);
  EXPECT_EQ(loc.locate(Vec3(0.5, 0.5, 2.5)), expected_cell(0.5, 0.5, 0.5));
  EXPECT_EQ(loc.locate(Vec3(1.5, 0.5, -0.5)), expected_cell(1.5, 0.5, 1.5));
  EXPECT_EQ(loc.locate(Vec3(0.5, 1.5, 2.0)), expected_cell(0.5, 1.5, 0.0));     // exactly one period
  EXPECT_EQ(loc.locate(Vec3(0.5, 1.5, -4.25)), expected_cell(0.5, 1.5, 1.75));  // several periods
  EXPECT_EQ(loc.locate(Vec3(0.5, 1.5, -1e-17)), expected_cell(0.5, 1.5, 0.0));  // rounds into range
  const Vec3 w = loc.wrap(Vec3(0.1, 0.2, 7.3));
  EXPECT_NEAR(w.z(), 1.3, 1e-12);
}

TEST(CellLocator, OutsideTheMeshIsMinusOne) {
  const auto loc = unit_box();
  EXPECT_EQ(loc.locate(Vec3(2.5, 0.5, 0.5)), -1);
  EXPECT_EQ(loc.locate(Vec3(-0.1, 0.5, 0.5)), -1);
  EXPECT_EQ(loc.locate(Vec3(0.5, 2.0001, 0.5)), -1);
  EXPECT_EQ(loc.locate(Vec3(0.5, 2.0001, 0.5), 3), -1);  // with a hint next to it
  EXPECT_EQ(loc.locate(Vec3(1e3, -1e3, 0.5)), -1);
}

TEST(CellLocator, PointsOnFacesBelongToAnAdjacentCell) {
  const auto loc = unit_box();
  const int c = loc.locate(Vec3(1.0, 0.5, 0.5));
  EXPECT_TRUE(c == 0 || c == 1);
  EXPECT_EQ(loc.locate(Vec3(2.0, 0.5, 0.5)), 1);  // on the outer wall: still inside
  EXPECT_EQ(loc.locate(Vec3(0.0, 0.0, 0.0)), 0);  // a corner of the mesh
}

TEST(CellLocator, HintsAndWalksGiveTheSameAnswer) {
  const CellLocator loc(box_mesh(5, 4, 6, -1, 1, -1, 1, 3, 2));
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> ux(-1, 1), uz(-3, 6);
  for (int n = 0; n < 2000; ++n) {
    const Vec3 x(ux(rng), ux(rng), uz(rng));
    const int truth = loc.locate(x);
    ASSERT_GE(truth, 0);
    ASSERT_TRUE(loc.inside(truth, loc.wrap(x)));
    for (int hint : {0, 17, loc.n_cells() - 1, truth}) EXPECT_EQ(loc.locate(x, hint), truth);
  }
  EXPECT_GT(loc.stats().hint_hits, 0);
  EXPECT_GT(loc.stats().walk_hits, 0);
}

TEST(CellLocator, ExactInSkewedCells) {
  // An affine map keeps hexahedra convex and faces planar; locate in mapped coordinates and
  // compare with the cell of the pre-image. z is left alone to keep the period.
  auto mesh = box_mesh(3, 3, 4, 0, 3, 0, 3, 4, 3, "skew");
  auto map = [](double x, double y, double z) { return Vec3(x + 0.3 * y + 0.2 * z, y + 0.25 * x, z); };
  for (auto& p : mesh.points) {
    const Vec3 q = map(p[0], p[1], p[2]);
    p = {q.x(), q.y(), q.z()};
  }
  for (auto& c : mesh.cell_centres) {
    const Vec3 q = map(c[0], c[1], c[2]);
    c = {q.x(), q.y(), q.z()};
  }
  for (auto& v : mesh.cell_volumes) v *= 1 - 0.3 * 0.25;  // |det| of the map
  const CellLocator loc(mesh);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.001, 2.999), uz(0.001, 3.999);
  for (int n = 0; n < 2000; ++n) {
    const double x = u(rng), y = u(rng), z = uz(rng);
    const int truth = (static_cast<int>(z) * 3 + static_cast<int>(y)) * 3 + static_cast<int>(x);
    EXPECT_EQ(loc.locate(map(x, y, z)), truth);
    EXPECT_EQ(loc.locate(map(x, y, z), (truth + 5) % loc.n_cells()), truth);
  }
  EXPECT_EQ(loc.locate(map(-0.01, 1.5, 1.5)), -1);
  EXPECT_EQ(loc.locate(map(1.5, 3.01, 1.5)), -1);
}

TEST(CellLocator, RejectsInconsistentMeshes) {
  auto mesh = box_mesh(2, 2, 2, 0, 2, 0, 2, 2, 2);
  mesh.owner[3] = 99;
  EXPECT_THROW(CellLocator{mesh}, std::invalid_argument);
  auto mesh2 = box_mesh(2, 2, 2, 0, 2, 0, 2, 2, 2);
  mesh2.vessel_length_m = 3;  // does not match the mesh's z extent
  EXPECT_THROW(CellLocator{mesh2}, std::invalid_argument);
}

TEST(CellLocator, WallGapOfAPolygonalVessel) {
  const double R = 25e-6, L = 100e-6;
  const int n = 8;
  const CellLocator loc(hemo::particles::synthetic::wedge_mesh(n, 4, R, L));
  const double pi = 3.14159265358979323846;
  const double sag = R * (1 - std::cos(pi / n));
  EXPECT_NEAR(loc.wall_gap(), sag, 1e-12 * R);
  // The middle of wedge 0's chord is at angle pi/n; a point behind it, inside the circle.
  const double a = pi / n;
  const Vec3 behind((R - 0.3 * sag) * std::cos(a), (R - 0.3 * sag) * std::sin(a), 30e-6);
  EXPECT_EQ(loc.locate(behind), -1);
  const int c = loc.locate_in_wall_gap(behind);
  EXPECT_EQ(c, n * 1 + 0);  // layer 1 (z in [25, 50) um), wedge 0
  // Inside the chord: located exactly; outside the circle: nowhere.
  const Vec3 in_front((R - 1.5 * sag) * std::cos(a), (R - 1.5 * sag) * std::sin(a), 30e-6);
  EXPECT_EQ(loc.locate(in_front), c);
  const Vec3 beyond((R + 0.01 * sag) * std::cos(a), (R + 0.01 * sag) * std::sin(a), 30e-6);
  EXPECT_EQ(loc.locate(beyond), -1);
  EXPECT_EQ(loc.locate_in_wall_gap(beyond), -1);
  // The box mesh's flat walls leave no gap.
  EXPECT_EQ(CellLocator(box_mesh(2, 2, 2, -1, 1, -1, 1, 2, 2)).wall_gap(), 0.0);
}

TEST(CellLocator, CacheGivesTheSameAnswerAsASearch) {
  const CellLocator loc(box_mesh(5, 4, 6, -1, 1, -1, 1, 3, 2));
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> ux(-0.99, 0.99), step(-0.02, 0.02);
  for (int p = 0; p < 50; ++p) {
    hemo::particles::LocateCache cache;
    Vec3 x(ux(rng), ux(rng), 1.5);
    for (int n = 0; n < 400; ++n) {  // a random walk, crossing faces and the periodic ends
      x += Vec3(step(rng), step(rng), 5 * step(rng));
      x.x() = std::clamp(x.x(), -0.99, 0.99);
      x.y() = std::clamp(x.y(), -0.99, 0.99);
      ASSERT_EQ(loc.locate(x, cache), loc.locate(x)) << "point " << x.transpose();
    }
  }
  EXPECT_GT(loc.stats().cache_hits, 5000);
}

TEST(CellLocator, NoWallGapWhereTheMeshStopsShortOfTheVessel) {
  // Mesh points at half the vessel radius: its wall faces are not chords of the vessel, so a
  // point between the mesh and the vessel wall is outside the mesh, not in a gap.
  const double R = 25e-6;
  auto mesh = hemo::particles::synthetic::wedge_mesh(8, 4, 0.5 * R, 100e-6);
  mesh.vessel_diameter_m = 2 * R;
  const CellLocator loc(mesh);
  EXPECT_EQ(loc.wall_gap(), 0.0);
  EXPECT_EQ(loc.locate(Vec3(0.7 * R, 0, 10e-6)), -1);
  EXPECT_EQ(loc.locate_in_wall_gap(Vec3(0.7 * R, 0, 10e-6)), -1);
  EXPECT_GE(loc.locate(Vec3(0.3 * R, 0.01 * R, 10e-6)), 0);
}
