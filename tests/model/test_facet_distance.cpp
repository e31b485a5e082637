// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "small_bifurcation.h"

#include <cmath>
#include <limits>
#include <random>

#include "bifurcation.h"
#include "facet_distance.h"

using namespace hemo;
using Point = Eigen::Vector3d;

// Against the nearest of a fine barycentric grid of the triangle's points: every region (the
// three vertices', the three edges', the face's) is met by points all around it.
TEST(FacetDistance, NearestPointOnATriangleIsTheNearestOfItsPoints) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2, 2);
  const int n = 200;
  for (int trial = 0; trial < 300; ++trial) {
    const Point a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    const Point x(2 * u(rng), 2 * u(rng), 2 * u(rng));
    double brute = std::numeric_limits<double>::infinity();
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j)
        brute = std::min(brute, (x - (a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n))).norm());
    const Point p = nearest_on_triangle(x, a, b, c);
    const double found = (x - p).norm();
    // Never farther than the grid's nearest; not nearer than it by more than the grid's spacing.
    const double spacing = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()}) / n;
    EXPECT_LE(found, brute + 1e-12) << trial;
    EXPECT_GE(found, brute - spacing) << trial;
    // And on the triangle: its barycentric coordinates are in [0, 1].
    const Point n_ = (b - a).cross(c - a);
    const double area = n_.norm();
    const double wa = (b - p).cross(c - p).norm() / area, wb = (c - p).cross(a - p).norm() / area,
                 wc = (a - p).cross(b - p).norm() / area;
    EXPECT_NEAR(wa + wb + wc, 1, 1e-9) << trial;
  }
}

// A surface vessel's DEM wall: away from the junction, the facets' distance is the analytic
// wall's to within the chords' sagitta, on either side, and nothing is seen beyond the reach.
TEST(FacetDistance, DistanceToABifurcationsDemWallIsTheWallsAwayFromItsRidges) {
  const BifurcationSpec spec = resolved(test::small_bifurcation());
  const BifurcationWall wall(spec);
  const double reach = 6e-6;
  const FacetDistance facets(wall.dem_wall(), reach);
  const double rp = spec.parent_diameter / 2;
  // Chords of a circle of radius R between points a step apart lie within step^2 / (8 R) of it,
  // and a marching-tetrahedra triangle's edge is at most a cube's diagonal, sqrt(3) steps.
  const double sagitta = 3 * spec.step * spec.step / (8 * rp);
  int seen = 0;
  for (int k = 0; k < 12; ++k) {
    const double angle = 0.52 * k;
    const Point radial(std::cos(angle), std::sin(angle), 0);
    for (const double depth : {-2e-6, -0.5e-6, 0.5e-6, 2e-6, 4e-6}) {
      const Point x = Point(0, 0, spec.parent_length * 0.4) + (rp - depth) * radial;
      const double d = facets.distance(x);
      EXPECT_NEAR(d, std::abs(depth), sagitta) << "angle " << angle << " depth " << depth;
      seen += std::isfinite(d);
    }
    EXPECT_EQ(facets.distance(Point(0, 0, spec.parent_length * 0.4) + (rp - 2 * reach) * radial),
              std::numeric_limits<double>::infinity());
  }
  EXPECT_EQ(seen, 60);
  EXPECT_EQ(facets.distance(Point(1, 1, 1)), std::numeric_limits<double>::infinity());
}

// The divider's ridge, where the daughters meet: the facets bevel it, so the analytic ridge lies
// off the DEM's wall by a good part of a sampling step. A cell there touches no facet although the
// analytic wall says it is a radius into it.
TEST(FacetDistance, TheDemWallBevelsTheDividersRidge) {
  const BifurcationSpec spec = resolved(test::small_bifurcation());
  const BifurcationWall wall(spec);
  const FacetDistance facets(wall.dem_wall(), spec.step);
  // The apex of the divider: on the symmetry plane x = 0, where both daughters' walls pass.
  const Point d = daughter_direction(spec, 0);
  const double r1 = spec.daughter_diameter[0] / 2;
  const Point apex(0, 0, spec.parent_length + r1 / d.x());
  EXPECT_NEAR(wall.signed_distance(apex), 0, 1e-12);
  const double bevel = facets.distance(apex);
  EXPECT_GT(bevel, 0.05 * spec.step) << "step " << spec.step;
  EXPECT_LT(bevel, spec.step);
  // The facets across the ridge lie outside the analytic wall (the solid wedge's nearer face is
  // nearer them than its edge is), and nowhere by more than a facet's size.
  const double outside = furthest_outside(wall, wall.dem_wall());
  EXPECT_GT(outside, 0.1 * spec.step);
  EXPECT_LT(outside, std::sqrt(3.0) * spec.step);
}
