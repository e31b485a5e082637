// The vessel's shapes (model/geometry.h): volumes against their closed forms, the signed distance
// and normal against finite differences and a brute-force search, the straight tube against the
// formulas every part used before shapes, and the scene's refusals.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "driving.h"
#include "geometry.h"
#include "minimal_scene.h"
#include "scene.h"
#include "units.h"

using namespace hemo;
using Point = VesselGeometry::Point;

namespace {

Vessel stenosis(double area_reduction = 0.5, double length_um = 400) {
  Vessel v{100e-6, 1200e-6};
  v.shape = "stenosis";
  v.stenosis_area_reduction = area_reduction;
  v.stenosis_length = length_um * 1e-6;
  return v;
}

// Points around the wall of a shape: inside and outside, in and beside the constriction, off the
// x-z plane.
std::vector<Point> probes(const VesselGeometry& g) {
  std::vector<Point> out;
  const double L = g.length();
  for (double zf : {0.02, 0.3, 0.36, 0.42, 0.5, 0.55, 0.61, 0.7, 0.97})
    for (double rf : {0.3, 0.8, 0.95, 1.04, 1.2}) {
      const double z = zf * L, r = rf * g.radius_at(z), th = 0.7 + 3 * zf;
      out.emplace_back(r * std::cos(th), r * std::sin(th), z);
    }
  return out;
}

// The distance to the wall by brute force: the nearest of a million points along the meridian.
double brute_distance(const VesselGeometry& g, const Point& x) {
  const double r = std::hypot(x.x(), x.y());
  double best = std::numeric_limits<double>::infinity();
  const int n = 1'000'000;
  for (int i = 0; i < n; ++i) {
    const double z = x.z() - g.length() / 2 + g.length() * i / n;
    best = std::min(best, std::hypot(z - x.z(), g.radius_at(z) - r));
  }
  return best;
}

}  // namespace

// The straight tube answers with the very operations the code used before shapes.
TEST(VesselGeometry, StraightIsTodaysTube) {
  const Vessel v{100e-6, 600e-6};
  const auto g = make_vessel_geometry(v);
  EXPECT_TRUE(g->uniform());
  EXPECT_EQ(g->volume(), units::pi * v.radius() * v.radius() * v.length);
  EXPECT_EQ(vessel_volume(v), units::pi * v.radius() * v.radius() * v.length);
  EXPECT_EQ(g->throat_radius(), v.radius());
  for (const Point& x : probes(*g)) {
    EXPECT_EQ(g->radius_at(x.z()), v.radius());
    EXPECT_EQ(g->signed_distance(x), std::hypot(x.x(), x.y()) - v.radius());
    const Point n = g->outward_normal(x);
    EXPECT_NEAR((n - Point(x.x(), x.y(), 0).normalized()).norm(), 0, 1e-15);
  }
}

// R(z) as docs/scenes.md gives it: R0 outside the constriction, R0 sqrt(1 - A) at its centre,
// continuous with its slope at its ends, periodic.
TEST(VesselGeometry, StenosisRadiusIsTheCosineConstriction) {
  const Vessel v = stenosis(0.5, 400);
  const auto g = make_vessel_geometry(v);
  const double R0 = 50e-6, zc = 600e-6;
  EXPECT_FALSE(g->uniform());
  EXPECT_NEAR(g->radius_at(zc), R0 * std::sqrt(0.5), 1e-18);
  EXPECT_NEAR(g->throat_radius(), R0 * std::sqrt(0.5), 1e-18);
  EXPECT_NEAR(units::pi * std::pow(g->throat_radius(), 2) / (units::pi * R0 * R0), 0.5, 1e-14);
  EXPECT_EQ(g->radius_at(100e-6), R0);
  EXPECT_EQ(g->radius_at(1150e-6), R0);
  EXPECT_NEAR(g->radius_at(400e-6), R0, 1e-18);
  EXPECT_NEAR(g->radius_slope(400e-6), 0, 1e-15);
  EXPECT_NEAR(g->radius_at(zc + 1200e-6), g->radius_at(zc), 1e-18);
  EXPECT_NEAR(g->radius_at(500e-6 - 1200e-6), g->radius_at(500e-6), 1e-18);
  // Slope and curvature are the derivatives of R (central differences).
  for (double z : {450e-6, 530e-6, 610e-6, 700e-6, 790e-6}) {
    const double h = 1e-9;
    EXPECT_NEAR(g->radius_slope(z), (g->radius_at(z + h) - g->radius_at(z - h)) / (2 * h), 1e-7);
    EXPECT_NEAR(g->radius_curvature(z), (g->radius_slope(z + h) - g->radius_slope(z - h)) / (2 * h), 1);
  }
}

// A section's centre-line speed follows from the fastest one at the throat: every section of a
// Poiseuille-like flow passes the same flux pi R^2 u_c / 2. The straight tube's is the fastest.
TEST(VesselGeometry, CentrelineSpeedKeepsEverySectionsFluxTheThroats) {
  const auto straight = make_vessel_geometry(Vessel{100e-6, 600e-6});
  EXPECT_EQ(straight->centreline_speed_at(123e-6, 0.02), 0.02);
  const auto g = make_vessel_geometry(stenosis(0.5, 400));
  const double fastest = 0.04, throat_flux = units::pi * std::pow(g->throat_radius(), 2) * fastest / 2;
  EXPECT_NEAR(g->centreline_speed_at(600e-6, fastest), fastest, 1e-15);
  EXPECT_NEAR(g->centreline_speed_at(100e-6, fastest), fastest / 2, 1e-15);  // A = 0.5: half the area
  for (double z : {0.0, 420e-6, 500e-6, 560e-6, 700e-6, 1100e-6}) {
    const double R = g->radius_at(z);
    EXPECT_NEAR(units::pi * R * R * g->centreline_speed_at(z, fastest) / 2, throat_flux, 1e-12 * throat_flux) << z;
  }
}

// V = pi R0^2 [(L - L_s) + L_s ((1 - s/2)^2 + (s/2)^2 / 2)]: the integral of pi R^2 over the
// cosine, in closed form; for several severities and a constriction as long as the vessel.
TEST(VesselGeometry, StenosisVolumeIsTheClosedFormIntegral) {
  for (const auto& [A, Ls_um] : {std::pair{0.5, 400.0}, {0.2, 1000.0}, {0.9, 120.0}, {0.75, 1200.0}}) {
    const Vessel v = stenosis(A, Ls_um);
    const double R0 = v.radius(), L = v.length, Ls = v.stenosis_length, a = stenosis_severity(A) / 2;
    const double exact = units::pi * R0 * R0 * ((L - Ls) + Ls * ((1 - a) * (1 - a) + a * a / 2));
    EXPECT_NEAR(make_vessel_geometry(v)->volume() / exact, 1, 1e-13) << "A = " << A << ", L_s = " << Ls_um;
    EXPECT_NEAR(vessel_volume(v) / exact, 1, 1e-13);
  }
  // The lubrication integral the fluid verification uses, int R^-4 dz, likewise:
  // int (1 - a - a cos)^-4 over a period is L_s (1 - a)^-4 P_3(...)-free only numerically, so
  // check it against a fine midpoint sum instead.
  const auto g = make_vessel_geometry(stenosis(0.5, 400));
  double midpoint = 0;
  const int n = 2'000'000;
  for (int i = 0; i < n; ++i) midpoint += std::pow(g->radius_at((i + 0.5) * g->length() / n), -4) * g->length() / n;
  EXPECT_NEAR(g->axial_integral([](double R) { return std::pow(R, -4); }) / midpoint, 1, 1e-10);
}

// The signed distance is the exact distance to the wall (a brute-force search along the
// meridian), negative inside; its gradient (central differences) is the outward normal.
TEST(VesselGeometry, StenosisSignedDistanceAndNormalMatchFiniteDifferences) {
  for (const double A : {0.5, 0.9}) {
    const auto g = make_vessel_geometry(stenosis(A, 300));
    for (const Point& x : probes(*g)) {
      const double d = g->signed_distance(x);
      const bool inside = std::hypot(x.x(), x.y()) < g->radius_at(x.z());
      EXPECT_EQ(d < 0, inside);
      EXPECT_EQ(g->inside(x), inside);
      EXPECT_NEAR(std::abs(d), brute_distance(*g, x), 1e-12) << x.transpose();
      const double h = 1e-10;
      Point grad;
      for (int k = 0; k < 3; ++k) {
        Point e = Point::Zero();
        e[k] = h;
        grad[k] = (g->signed_distance(x + e) - g->signed_distance(x - e)) / (2 * h);
      }
      const Point n = g->outward_normal(x);
      EXPECT_NEAR(n.norm(), 1, 1e-14);
      EXPECT_NEAR((grad - n).norm(), 0, 1e-5)
          << "A = " << A << " at " << x.transpose() << ": grad " << grad.transpose() << ", normal " << n.transpose();
    }
    // A point on the wall is at distance 0.
    for (double z : {0.4e-3, 0.55e-3, 0.6e-3, 0.71e-3}) {
      const double R = g->radius_at(z);
      EXPECT_NEAR(g->signed_distance(Point(R * 0.6, R * 0.8, z)), 0, 1e-18);
    }
  }
}

namespace {
std::vector<SceneProblem> problems_of(const std::string& extra_vessel) {
  try {
    load_scene(test::write_temp("[vessel]\ndiameter_um = 100\nlength_um = 600\n" + extra_vessel +
                                "\n[driving]\nwall_shear_rate_per_s = 799\n"));
  } catch (const SceneError& e) {
    return e.problems();
  }
  return {};
}
}  // namespace

TEST(VesselGeometry, SceneTakesAStenosisAndRefusesImpossibleOnes) {
  const Scene s = load_scene(test::write_temp(
      "[vessel]\ndiameter_um = 100\nlength_um = 600\nshape = \"stenosis\"\nstenosis_area_reduction = 0.5\n"
      "stenosis_length_um = 300\n[driving]\nwall_shear_rate_per_s = 799\n"));
  EXPECT_EQ(s.vessel.shape, "stenosis");
  EXPECT_DOUBLE_EQ(s.vessel.stenosis_length, 300e-6);
  EXPECT_EQ(problems_of("shape = \"straight\"").size(), 0u);

  auto refused = [](const std::string& extra, const std::string& key, const std::string& starts) {
    const auto ps = problems_of(extra);
    ASSERT_EQ(ps.size(), 1u) << extra;
    EXPECT_EQ(ps[0].key, key) << extra;
    EXPECT_EQ(ps[0].message.rfind(starts, 0), 0u) << ps[0].message;
  };
  refused("shape = \"stenosis\"\nstenosis_area_reduction = 1\nstenosis_length_um = 300",
          "vessel.stenosis_area_reduction", "must be in [0, 1) (1 closes the vessel)");
  // A throat of 100 um sqrt(1 - 0.997) = 5.5 um passes no red cell of 5.56 um.
  refused("shape = \"stenosis\"\nstenosis_area_reduction = 0.997\nstenosis_length_um = 300",
          "vessel.stenosis_area_reduction", "the throat is 5.48 um across, narrower than a red cell");
  refused("shape = \"stenosis\"\nstenosis_length_um = 700", "vessel.stenosis_length_um",
          "must not exceed vessel.length_um");
  refused("shape = \"stenosis\"", "vessel.stenosis_length_um", "must be positive");
  refused("shape = \"bulge\"", "vessel.shape", "unknown name 'bulge' (known: straight, stenosis, bifurcation, imported)");
}

// The DEM's wall surface: every vertex on r = R(z); the facets cover the wall once (their areas
// sum to the shape's lateral area within the chords' deficit), each facet's normal points into
// the vessel, and every facet's centroid lies within 2e-3 R0 of the wall at the resolution the DEM
// uses (1e-3 R0 from the chords around, as much from those along).
TEST(VesselGeometry, WallSurfaceIsTheShapesWallWithinTheTolerance) {
  const auto g = make_vessel_geometry(stenosis(0.5, 400));
  const WallResolution res = dem_wall_resolution(*g);
  EXPECT_EQ(res.around, 72);
  const auto triangles = wall_surface(*g, res.around, res.along);
  ASSERT_EQ(triangles.size(), 2u * res.around * res.along);
  // Lateral area of r = R(z): 2 pi int R sqrt(1 + R'^2) dz, by the trapezoid on a fine grid.
  double lateral = 0;
  constexpr int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double z = g->length() * (i + 0.5) / n, R = g->radius_at(z), dR = g->radius_slope(z);
    lateral += 2 * units::pi * R * std::sqrt(1 + dR * dR) * g->length() / n;
  }
  double area = 0, deepest = 0;
  for (const auto& t : triangles) {
    for (const auto& v : t.vertex) ASSERT_NEAR(std::hypot(v.x(), v.y()), g->radius_at(v.z()), 1e-18);
    const Point normal = (t.vertex[1] - t.vertex[0]).cross(t.vertex[2] - t.vertex[0]);
    area += normal.norm() / 2;
    const Point centroid = (t.vertex[0] + t.vertex[1] + t.vertex[2]) / 3;
    EXPECT_LT(normal.dot(g->outward_normal(centroid)), 0);  // into the vessel
    deepest = std::max(deepest, std::abs(g->signed_distance(centroid)));
  }
  std::printf("  %d x %d stations, %zu facets: area / lateral - 1 = %.2e, centroids within %.2e R0 of the wall\n",
              res.around, res.along, triangles.size(), area / lateral - 1, deepest / g->nominal_radius());
  EXPECT_LT(deepest, 2e-3 * g->nominal_radius());
  EXPECT_NEAR(area / lateral, 1, 2e-3);  // chords: sin(pi/n)/(pi/n) - 1 = -3.2e-4 around, plus the axial chords
}

// What a narrowing vessel cannot have, refused in one line each: the streaming neighbour-list
// criterion (it predicts the straight tube's flow), and a vessel too small for LIGGGHTS's mesh
// wall (it refuses meshes spanning under 1e-4 in its units).
TEST(VesselGeometry, SceneRefusesWhatANarrowingVesselCannotHave) {
  auto problems = [](const std::string& text) -> std::vector<SceneProblem> {
    try {
      load_scene(test::write_temp(text));
    } catch (const SceneError& e) {
      return e.problems();
    }
    return {};
  };
  const std::string stenosis = "shape = \"stenosis\"\nstenosis_length_um = 30\n";
  const std::string driving = "[driving]\nwall_shear_rate_per_s = 799\n";
  auto streaming = problems("[vessel]\ndiameter_um = 100\nlength_um = 600\n" + stenosis + driving +
                            "[dem]\nneighbour_rebuild = \"streaming\"\n");
  ASSERT_EQ(streaming.size(), 1u);
  EXPECT_EQ(streaming[0].key, "dem.neighbour_rebuild");
  EXPECT_NE(streaming[0].message.find("predicts the straight tube's Poiseuille flow"), std::string::npos);
  EXPECT_TRUE(problems("[vessel]\ndiameter_um = 100\nlength_um = 600\n" + driving +
                       "[dem]\nneighbour_rebuild = \"streaming\"\n")
                  .empty());

  auto small = problems("[vessel]\ndiameter_um = 40\nlength_um = 60\n" + stenosis + driving);
  ASSERT_EQ(small.size(), 1u);
  EXPECT_EQ(small[0].key, "vessel.length_um");
  EXPECT_EQ(small[0].message.rfind("a vessel.shape that narrows has a LIGGGHTS mesh wall", 0), 0u) << small[0].message;
  EXPECT_TRUE(problems("[vessel]\ndiameter_um = 40\nlength_um = 80\n" + stenosis + driving).empty());  // spans 100 um
  EXPECT_TRUE(
      problems("[vessel]\ndiameter_um = 40\nlength_um = 60\n" + driving).empty());  // the straight tube's zcylinder
}
