// An imported surface's wall as the particle side asks it (model/surface_wall.h): its signed
// distance against the shapes it was made of, on either side and at its vertices and edges; the
// section along the wall's normal against a tube's axis, tilted as no axis-bound code would
// expect; the DEM's facets and the outlets; and a scene that imports a surface carries cells.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "small_bifurcation.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "bifurcation.h"
#include "geometry.h"
#include "scene.h"
#include "surface_wall.h"

using namespace hemo;
using Point = Eigen::Vector3d;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A closed tube of radius r from `start` along `axis` for `length`: `around` segments, `along`
// rings, flat caps fanned about their centres ("inlet" at the start, "outlet_1" at the end),
// normals out. Its wall's chords lie within r (1 - cos(pi / around)) of the cylinder.
Surface tube(const Point& start, const Point& axis, double r, double length, int around, int along) {
  const Point a = axis.normalized();
  const Point u = a.unitOrthogonal(), v = a.cross(u);
  Surface s;
  s.region_names = {"wall", "inlet", "outlet_1"};
  for (int k = 0; k <= along; ++k)
    for (int j = 0; j < around; ++j) {
      const double phi = 2 * kPi * j / around;
      s.points.push_back(start + length * k / along * a + r * (std::cos(phi) * u + std::sin(phi) * v));
    }
  auto ring = [&](int k, int j) { return k * around + (j % around); };
  for (int k = 0; k < along; ++k)
    for (int j = 0; j < around; ++j) {
      // Counter-clockwise seen from outside: around (u -> v) then along.
      s.triangles.push_back({ring(k, j), ring(k, j + 1), ring(k + 1, j + 1)});
      s.triangles.push_back({ring(k, j), ring(k + 1, j + 1), ring(k + 1, j)});
      s.region.push_back(0);
      s.region.push_back(0);
    }
  const int first = static_cast<int>(s.points.size());
  s.points.push_back(start);
  s.points.push_back(start + length * a);
  for (int j = 0; j < around; ++j) {
    s.triangles.push_back({first, ring(0, j + 1), ring(0, j)});  // facing -a
    s.region.push_back(1);
    s.triangles.push_back({first + 1, ring(along, j), ring(along, j + 1)});  // facing +a
    s.region.push_back(2);
  }
  return s;
}

// The distance from x to a finite cylinder (negative inside).
double cylinder_distance(const Point& start, const Point& a, double r, double length, const Point& x) {
  const double t = (x - start).dot(a);
  const double radial = (x - start - t * a).norm() - r, axial = std::max(-t, t - length);
  if (radial <= 0 && axial <= 0) return std::max(radial, axial);
  return std::hypot(std::max(radial, 0.0), std::max(axial, 0.0));
}

}  // namespace

// Against the cylinder it approximates: the sign is the cylinder's wherever the cylinder is
// farther than the chords' error, and the magnitude within that error, for points inside,
// outside, beyond the caps and off the rims; at the surface's own vertices and edge midpoints the
// distance is zero, and a point pushed off a vertex or an edge along its normal is on the side it
// was pushed to.
TEST(SurfaceWall, SignedDistanceIsTheCylindersWithinTheChordsError) {
  const Point start(1e-6, -2e-6, 0), axis = Point(1, 0.5, 2).normalized();
  const double r = 20e-6, length = 80e-6;
  const int around = 48;
  const SurfaceWall wall(tube(start, axis, r, length, around, 20));
  const double chord = r * (1 - std::cos(kPi / around));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> box(-1.5, 1.5), along(-0.3, 1.3);
  const Point u = axis.unitOrthogonal(), v = axis.cross(u);
  int checked = 0, inside = 0, outside = 0;
  for (int n = 0; n < 4000; ++n) {
    const Point x = start + along(rng) * length * axis + box(rng) * r * u + box(rng) * r * v;
    const double exact = cylinder_distance(start, axis, r, length, x), d = wall.signed_distance(x);
    EXPECT_NEAR(d, exact, chord + 1e-15) << "at " << x.transpose();
    if (std::abs(exact) > chord) {
      ++checked;
      EXPECT_EQ(d < 0, exact < 0) << "at " << x.transpose();
      (exact < 0 ? inside : outside) += 1;
    }
  }
  EXPECT_GT(inside, 500);
  EXPECT_GT(outside, 500);
  const Surface& s = wall.surface();
  for (std::size_t t = 0; t < s.triangles.size(); t += 7) {
    const Point& p = s.points[static_cast<std::size_t>(s.triangles[t][0])];
    const Point& q = s.points[static_cast<std::size_t>(s.triangles[t][1])];
    EXPECT_NEAR(wall.signed_distance(p), 0, 1e-15);
    EXPECT_NEAR(wall.signed_distance((p + q) / 2), 0, 1e-15);
    // Off a vertex and an edge (the rims' too) along the outward normal there: out, then in (or
    // onto a cap: a rim vertex's pseudo-normal is nearly the wall's, and the cap is its plane).
    for (const Point& at : {p, Point((p + q) / 2)}) {
      const Point n = wall.outward_normal(at);
      EXPECT_GT(wall.signed_distance(at + 1e-8 * n), 0) << at.transpose();
      EXPECT_LE(wall.signed_distance(at - 1e-8 * n), 0) << at.transpose();
    }
  }
}

// The section along the wall's normal in a tilted tube: the tube's radius within the chords'
// error and the point's distance from its axis; the wall region alone (near a cap the section is
// still the tube's); no centre-line speed.
TEST(SurfaceWall, SectionIsTheTubesAlongTheWallsNormal) {
  const Point start(0, 0, 5e-6), axis = Point(0.3, -0.2, 1).normalized();
  const double r = 25e-6, length = 100e-6;
  const int around = 64;
  const SurfaceWall wall(tube(start, axis, r, length, around, 25));
  EXPECT_FALSE(wall.defines_centreline_speed());
  // At most the chords' error either side, which both sides of the chord reach between facets'
  // midlines (the radius r cos(pi / around)): equality, to round-off.
  const double chord = r * (1 - std::cos(kPi / around)) * (1 + 1e-9);
  const Point u = axis.unitOrthogonal(), v = axis.cross(u);
  for (double t : {0.02, 0.3, 0.77, 0.98})
    for (double off : {0.0, 0.1, 0.45, 0.8, 0.97})
      for (double phi : {0.1, 1.3, 4.0}) {
        const Point x = start + t * length * axis + off * r * (std::cos(phi) * u + std::sin(phi) * v);
        const VesselWall::Section s = wall.section_at(x);
        EXPECT_NEAR(s.radius, r, chord) << t << " " << off << " " << phi;
        EXPECT_NEAR(s.off_axis, off * r, chord) << t << " " << off << " " << phi;
        EXPECT_TRUE(std::isnan(s.speed_scale));
      }
  // Beyond the outlet, in line with the tube: no wall across, no section.
  const VesselWall::Section beyond = wall.section_at(start + 1.5 * length * axis + 0.2 * r * u);
  EXPECT_TRUE(std::isnan(beyond.radius));
}

// The DEM collides with the wall region, facing in; the outlet is the end cap's centre, facing out.
TEST(SurfaceWall, DemWallFacesInAndTheOutletIsTheEndCap) {
  const Point start(0, 0, 0), axis(0, 0, 1);
  const double r = 10e-6, length = 40e-6;
  const Surface s = tube(start, axis, r, length, 24, 8);
  const SurfaceWall wall(s);
  const auto facets = wall.dem_wall();
  ASSERT_EQ(facets.size(), 24u * 8u * 2u);
  for (const WallTriangle& f : facets) {
    const Point c = (f.vertex[0] + f.vertex[1] + f.vertex[2]) / 3;
    const Point n = (f.vertex[1] - f.vertex[0]).cross(f.vertex[2] - f.vertex[0]);
    EXPECT_LT(n.dot(Point(c.x(), c.y(), 0)), 0) << "facet at " << c.transpose() << " faces out";
  }
  const auto outlets = wall.outlets();
  ASSERT_EQ(outlets.size(), 1u);
  EXPECT_NEAR((outlets[0].centre - Point(0, 0, length)).norm(), 0, 1e-18);
  EXPECT_NEAR((outlets[0].normal - axis).norm(), 0, 1e-12);
  // The cap's equivalent radius: a 24-gon's area, pi r^2 sin(2 pi / 24) / (2 pi / 24).
  EXPECT_NEAR(outlets[0].radius, r * std::sqrt(std::sin(2 * M_PI / 24) / (2 * M_PI / 24)), 1e-12 * r);
}

// On the bifurcation our own generator makes, read as an imported surface: the sign is the
// analytic union's wherever that is farther from the wall than the facets' error (a few
// thousandths of the step), the two daughters' outlets are their caps, and a point on the inlet
// disc (where a feeder's cell stands for one: FeederLayout::in_vessel_frame) has the inlet's
// section.
TEST(SurfaceWall, AnImportedBifurcationIsInsideWhereTheAnalyticOneIs) {
  const BifurcationSpec spec = hemo::test::small_bifurcation();
  const BifurcationSpec r = resolved(spec);
  const SurfaceWall wall(make_bifurcation(spec));
  const Surface& s = wall.surface();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(s.lower().x(), s.upper().x()), uy(s.lower().y(), s.upper().y()),
      uz(s.lower().z(), s.upper().z());
  const double tolerance = 0.1 * r.step;
  int checked = 0;
  for (int n = 0; n < 3000; ++n) {
    const Point x(ux(rng), uy(rng), uz(rng));
    const double exact = bifurcation_function(spec, x);
    if (std::abs(exact) < tolerance) continue;
    ++checked;
    EXPECT_EQ(wall.signed_distance(x) < 0, exact < 0) << x.transpose();
  }
  EXPECT_GT(checked, 2000);
  const auto outlets = wall.outlets();
  ASSERT_EQ(outlets.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    const Point d = daughter_direction(r, i);
    EXPECT_LT((outlets[static_cast<std::size_t>(i)].centre - (Point(0, 0, r.parent_length) + r.daughter_length * d))
                  .norm(),
              0.02 * r.daughter_diameter[i]);
    EXPECT_GT(outlets[static_cast<std::size_t>(i)].normal.dot(d), 0.999);
    // The cap's equivalent radius, the daughter's to the facets' error; the analytic wall's exactly.
    EXPECT_NEAR(outlets[static_cast<std::size_t>(i)].radius, r.daughter_diameter[i] / 2, 0.02 * r.daughter_diameter[i]);
    EXPECT_EQ(BifurcationWall(spec).outlets()[static_cast<std::size_t>(i)].radius, r.daughter_diameter[i] / 2);
  }
  const VesselWall::Section inlet = wall.section_at(Point(0.3 * r.parent_diameter / 2, 0, 0));
  EXPECT_NEAR(inlet.radius, r.parent_diameter / 2, 0.02 * r.parent_diameter);
  EXPECT_NEAR(inlet.off_axis, 0.3 * r.parent_diameter / 2, 0.02 * r.parent_diameter);
}

// Every shape carries cells now: an imported surface's wall is a SurfaceWall, which names no
// centre-line speed.
TEST(SurfaceWall, AnImportedScenesWallIsItsSurface) {
  EXPECT_TRUE(vessel_shape("imported").carries_cells());
  namespace fs = std::filesystem;
  const fs::path file = fs::temp_directory_path() / ("hemo_surface_wall_" + std::to_string(::getpid()) + ".stl");
  Surface s = tube(Point::Zero(), Point(0, 0, 1), 50e-6, 200e-6, 32, 10);
  s.region_names = {"side", "in", "out"};
  write_stl(file.string(), s);
  Vessel v;
  v.shape = "imported";
  v.diameter = 100e-6;
  v.length = 200e-6;
  v.surface_path = file.string();
  v.surface_inlet = "in";
  v.surface_outlets = "out";
  const auto wall = make_vessel_wall(v);
  EXPECT_FALSE(wall->axisymmetric());
  EXPECT_FALSE(wall->defines_centreline_speed());
  EXPECT_LT(wall->signed_distance(Point(0, 0, 100e-6)), -49e-6);
  EXPECT_EQ(wall->outlets().size(), 1u);
  fs::remove(file);
}

// A straight tube's two ends each give a branch of the end's equivalent radius (a 32-gon's:
// sqrt(16 sin(pi / 16) / pi) = 0.99679 r) that runs the whole length: its 32 chords stay within
// r (1 - cos(pi / 32)) = 0.0048 r of the circle, inside the 5 % tolerance. A point is in the
// first branch whose tube it is in, and in none outside the tubes or beyond the ends.
TEST(SurfaceWall, AStraightTubesEndsBranchTheWholeLength) {
  const double r = 50e-6, length = 200e-6;
  const SurfaceWall wall(tube(Point::Zero(), Point(0, 0, 1), r, length, 32, 10));
  const auto branches = wall.branches();
  ASSERT_EQ(branches.size(), 2u);
  const double equivalent = r * std::sqrt(16 * std::sin(kPi / 16) / kPi);
  for (const auto& b : branches) {
    EXPECT_NEAR(b.radius, equivalent, 1e-9 * r);
    EXPECT_DOUBLE_EQ(b.tolerance, SurfaceWall::kBranchWallTolerance * b.radius);
    EXPECT_LT(b.start.norm(), 1e-12);
    EXPECT_LT((b.end - Point(0, 0, length)).norm(), 1e-12);
  }
  EXPECT_EQ(wall.branch_at(Point(10e-6, 0, 100e-6)), 0);
  EXPECT_EQ(wall.branch_at(Point(0, 0, -1e-6)), -1);
  EXPECT_EQ(wall.branch_at(Point(0, 0, length + 1e-6)), -1);
  EXPECT_EQ(wall.branch_at(Point(r + 0.1 * r, 0, 100e-6)), -1);
}

// scenes/surfaces/eccentric-stenosis.stl: its centre line moves sideways as 15 um (1 - cos(pi z /
// 300 um)), so the inlet's tube leaves the wall by 5 % of the radius (2.5 um) where that is 2.5 um,
// z = 300 um acos(5/6) / pi = 56 um, before the plaque (from z = 90 um); the outlet's, by symmetry,
// 56 um before the outlet. Between them a cell is in no branch.
TEST(SurfaceWall, AnImportedVesselsBranchesEndWhereItBends) {
  Vessel v;
  v.shape = "imported";
  v.diameter = 100e-6;
  v.length = 300e-6;
  v.surface_path = std::string(HEMO_SCENES_DIR) + "/surfaces/eccentric-stenosis.stl";
  v.surface_inlet = "inflow";
  v.surface_outlets = "outflow";
  const auto wall = make_vessel_wall(v);
  const auto b = wall->branches();
  ASSERT_EQ(b.size(), 2u);
  const double bend = 300e-6 * std::acos(5.0 / 6) / kPi;
  EXPECT_NEAR(b[0].start.z(), 0, 1e-9);
  EXPECT_NEAR(b[0].end.z(), bend, 8e-6);
  EXPECT_NEAR(b[1].end.z(), 300e-6, 1e-9);
  EXPECT_NEAR(300e-6 - b[1].start.z(), bend, 8e-6);
  EXPECT_NEAR(b[0].radius, 50e-6, 0.01 * 50e-6);
  EXPECT_EQ(wall->branch_at(Point(0, 0, 20e-6)), 0);
  EXPECT_EQ(wall->branch_at(Point(30e-6, 0, 280e-6)), 1);
  EXPECT_EQ(wall->branch_at(Point(15e-6, 0, 150e-6)), -1);
}

// An imported Y bifurcation (the generator's surface, as an STL would bring it): the inlet's branch
// runs up the parent's axis from the inlet to about the junction, each outlet's along its
// daughter's axis from near the junction to the outlet, with the daughters' radii; a point on an
// axis is in that branch.
TEST(SurfaceWall, AnImportedBifurcationsBranchesAreItsTubes) {
  const BifurcationSpec spec = hemo::test::small_bifurcation();
  const BifurcationSpec r = resolved(spec);
  const SurfaceWall wall(make_bifurcation(spec));
  const auto b = wall.branches();
  ASSERT_EQ(b.size(), 3u);
  const Point junction(0, 0, r.parent_length);
  EXPECT_LT(b[0].start.norm(), 1e-3 * r.parent_diameter);  // the inlet cap's centroid
  EXPECT_GT((b[0].end - b[0].start).normalized().z(), std::cos(kPi / 180));
  EXPECT_NEAR(b[0].radius, r.parent_diameter / 2, 0.02 * r.parent_diameter / 2);
  // The parent's tube reaches to within a parent diameter of the junction, and past it no further
  // than where the parent's rounded end (the capsule's, radius R) has narrowed by the tolerance:
  // R sqrt(1 - 0.95^2) = 0.312 R.
  const double rp = r.parent_diameter / 2;
  EXPECT_GT(b[0].end.z(), r.parent_length - r.parent_diameter);
  EXPECT_LE(b[0].end.z(),
            r.parent_length + rp * std::sqrt(1 - std::pow(1 - SurfaceWall::kBranchWallTolerance, 2)));
  for (int i = 0; i < 2; ++i) {
    const auto& d = b[static_cast<std::size_t>(i + 1)];
    const Point direction = daughter_direction(r, i);
    EXPECT_GT((d.end - d.start).normalized().dot(direction), std::cos(2 * kPi / 180)) << i;
    EXPECT_LT((d.end - (junction + r.daughter_length * direction)).norm(), 0.02 * r.daughter_diameter[i]) << i;
    EXPECT_NEAR(d.radius, r.daughter_diameter[i] / 2, 0.02 * r.daughter_diameter[i] / 2) << i;
    EXPECT_GT((d.end - d.start).norm(), 0.5 * r.daughter_length) << i;
    EXPECT_EQ(wall.branch_at(junction + 0.8 * r.daughter_length * direction), i + 1) << i;
  }
  EXPECT_EQ(wall.branch_at(Point(0, 0, 0.3 * r.parent_length)), 0);
}
