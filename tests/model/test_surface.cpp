// Surface vessels in the model (model/surface.h, model/bifurcation.h): the generated Y
// bifurcation is closed, has its regions, and its caps, volume and area are those of its tubes;
// STL round trips; every refusal says why in one line.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <fmt/format.h>
#include <gtest/gtest.h>

#include "small_bifurcation.h"
#include "thrown.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>

#include "bifurcation.h"
#include "geometry.h"
#include "minimal_scene.h"
#include "scene.h"
#include "surface.h"
#include "vessel_ends.h"

using namespace hemo;
using Point = Eigen::Vector3d;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The small bifurcation of the fluid tests: D_p = 30 um, L_p = L_d = 60 um, Murray daughters at 60 degrees.
BifurcationSpec small() { return hemo::test::small_bifurcation(); }

// The number of triangles on each undirected edge, counted afresh from the triangles.
std::map<std::pair<int, int>, int> edge_counts(const Surface& s) {
  std::map<std::pair<int, int>, int> n;
  for (const auto& t : s.triangles)
    for (int k = 0; k < 3; ++k)
      ++n[std::minmax(t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)])];
  return n;
}

std::string what(const std::function<void()>& f) { return hemo::test::what_thrown(f); }

// The box holding the bifurcation's points, for sampling.
struct Box {
  Point lo, hi;
  double volume() const { return (hi - lo).prod(); }
};
Box box_of(const Surface& s, double margin) {
  return {s.lower() - Point::Constant(margin), s.upper() + Point::Constant(margin)};
}

}  // namespace

TEST(Bifurcation, IsClosedWithItsFourRegions) {
  const Surface s = make_bifurcation(small());
  EXPECT_EQ(s.region_names, (std::vector<std::string>{"wall", "inlet", "outlet_1", "outlet_2"}));
  for (const auto& [edge, n] : edge_counts(s)) ASSERT_EQ(n, 2) << "edge " << edge.first << "-" << edge.second;
  for (int r = 0; r < 4; ++r) EXPECT_GT(s.area(r), 0) << s.region_names[static_cast<std::size_t>(r)];
  EXPECT_NO_THROW(check_surface(s));
  std::printf("small bifurcation: %zu points, %zu triangles\n", s.points.size(), s.triangles.size());
}

// Closed whatever the angle and the diameters (make_bifurcation checks every edge; counted here
// again), with each end's cap where it belongs.
TEST(Bifurcation, IsClosedAtOtherAnglesAndDiameters) {
  struct Case {
    double deg, d1_um, d2_um, length_um;
  };
  for (const Case& c : {Case{30, 0, 0, 90}, Case{90, 20, 12, 60}, Case{150, 30, 8, 50}, Case{120, 16, 25, 70}}) {
    BifurcationSpec spec = small();
    spec.angle = c.deg * kPi / 180;
    spec.daughter_diameter[0] = c.d1_um * 1e-6;
    spec.daughter_diameter[1] = c.d2_um * 1e-6;
    spec.daughter_length = c.length_um * 1e-6;
    const Surface s = make_bifurcation(spec);
    const BifurcationSpec r = resolved(spec);
    for (const auto& [edge, n] : edge_counts(s)) ASSERT_EQ(n, 2) << c.deg << " degrees";
    for (int i = 0; i < 2; ++i) {
      const int region = s.region_index(surface_region::outlet(i + 1));
      const double d = r.daughter_diameter[i];
      EXPECT_NEAR(s.area(region) / (kPi * d * d / 4), 1, 7e-3) << c.deg << " degrees, outlet " << i + 1;
      const Point centre = Point(0, 0, spec.parent_length) + r.daughter_length * daughter_direction(r, i);
      EXPECT_LT((s.centroid(region) - centre).norm(), r.step / 10) << c.deg << " degrees, outlet " << i + 1;
    }
  }
}

// Each cap is a flat disc of its tube's radius at its end: a polygon inscribed in the rim whose
// sides are at most about a grid step, so its area is short of pi r^2 by at most
// (2 pi / N)^2 / 6 with N >= pi D / step = 31 sides: 0.7 %. The caps' normals point along their
// tubes, outwards, and their centroids are their centres.
TEST(Bifurcation, CapsAreTheirTubesSections) {
  for (const double d2 : {0.0, 16e-6}) {  // Murray's equal daughters, and unequal ones
    BifurcationSpec spec = small();
    spec.daughter_diameter[1] = d2;
    const Surface s = make_bifurcation(spec);
    const BifurcationSpec r = resolved(spec);
    EXPECT_DOUBLE_EQ(r.daughter_diameter[0], 30e-6 / std::cbrt(2.0));
    const Point junction(0, 0, spec.parent_length);
    struct End {
      std::string name;
      double diameter;
      Point centre, normal;
    };
    const std::vector<End> ends = {{"inlet", 30e-6, Point::Zero(), Point(0, 0, -1)},
                                   {"outlet_1", r.daughter_diameter[0],
                                    junction + r.daughter_length * daughter_direction(r, 0), daughter_direction(r, 0)},
                                   {"outlet_2", r.daughter_diameter[1],
                                    junction + r.daughter_length * daughter_direction(r, 1), daughter_direction(r, 1)}};
    for (const End& e : ends) {
      const int i = s.region_index(e.name);
      const double exact = kPi * e.diameter * e.diameter / 4;
      std::printf("%s (D_2 %g um): area / pi r^2 - 1 = %+.2e\n", e.name.c_str(), d2 * 1e6, s.area(i) / exact - 1);
      EXPECT_NEAR(s.area(i) / exact, 1, 7e-3) << e.name;
      EXPECT_NEAR(s.area_vector(i).norm() / s.area(i), 1, 1e-12) << e.name << " is flat";
      EXPECT_LT((s.area_vector(i).normalized() - e.normal).norm(), 1e-12) << e.name;
      EXPECT_LT((s.centroid(i) - e.centre).norm(), r.step / 10) << e.name;
    }
  }
}

// The enclosed volume against the union's own function integrated by the midpoint rule on a grid
// of 0.25 um (independent of the surface's triangles; its own error at the surface is about
// cell / surface-to-volume ratio, < 0.1 % here), and between the analytic bounds: at least the
// parent with its round end, pi r_p^2 L_p + 2/3 pi r_p^3; at most that plus both daughters'
// cylinders. The facets are chords of the curved wall, about step^2 / (8 r) inside it: a
// deficit of about 2 x 1.5^2 / (8 x 12) / 12 = 0.4 % relative to the volume.
TEST(Bifurcation, VolumeIsTheUnionsOfItsTubes) {
  const BifurcationSpec spec = small();
  const BifurcationSpec r = resolved(spec);
  const Surface s = make_bifurcation(spec);
  const Box b = box_of(s, 1e-6);
  const double h = 0.25e-6;
  const int nx = static_cast<int>(std::ceil((b.hi.x() - b.lo.x()) / h));
  const int ny = static_cast<int>(std::ceil((b.hi.y() - b.lo.y()) / h));
  const int nz = static_cast<int>(std::ceil((b.hi.z() - b.lo.z()) / h));
  long inside = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        inside += bifurcation_function(spec, b.lo + Point((i + 0.5) * h, (j + 0.5) * h, (k + 0.5) * h)) < 0;
  const double quadrature = static_cast<double>(inside) * h * h * h;
  const double rp = 15e-6, parent = kPi * rp * rp * spec.parent_length + 2.0 / 3 * kPi * rp * rp * rp;
  double daughters = 0;
  for (const double d : r.daughter_diameter) daughters += kPi * d * d / 4 * r.daughter_length;
  std::printf("volume %.5g um^3: / quadrature - 1 = %+.2e; bounds [%.5g, %.5g] um^3\n", s.volume() * 1e18,
              s.volume() / quadrature - 1, parent * 1e18, (parent + daughters) * 1e18);
  EXPECT_NEAR(s.volume() / quadrature, 1, 6e-3);
  EXPECT_GT(s.volume(), parent);
  EXPECT_LT(s.volume(), parent + daughters);
}

// The whole area against the union's function: the volume of the shell |f| < eps over 2 eps (f is
// a distance near the wall and the caps), by Monte Carlo with 4e6 samples in the box (the shell
// holds about 4 % of them: 0.3 % statistical error), eps = 0.3 um; within 2 %.
TEST(Bifurcation, AreaIsTheUnionsOfItsTubes) {
  const BifurcationSpec spec = small();
  const Surface s = make_bifurcation(spec);
  const Box b = box_of(s, 1e-6);
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(0, 1);
  const double eps = 0.3e-6;
  const long n = 4'000'000;
  long shell = 0;
  for (long i = 0; i < n; ++i) {
    const Point x = b.lo + (b.hi - b.lo).cwiseProduct(Point(u(rng), u(rng), u(rng)));
    shell += std::abs(bifurcation_function(spec, x)) < eps;
  }
  const double sampled = b.volume() * static_cast<double>(shell) / static_cast<double>(n) / (2 * eps);
  std::printf("area %.5g um^2 (wall %.5g): / sampled - 1 = %+.2e (%ld shell samples)\n", s.area() * 1e12,
              s.area(0) * 1e12, s.area() / sampled - 1, shell);
  EXPECT_NEAR(s.area() / sampled, 1, 0.02);
}

TEST(Surface, StlRoundTripKeepsPointsTrianglesAndRegions) {
  const Surface s = make_bifurcation(small());
  const std::string path = hemo::test::write_temp("", ".stl");
  write_stl(path, s);
  const Surface t = read_stl(path);
  EXPECT_EQ(t.region_names, s.region_names);
  ASSERT_EQ(t.points.size(), s.points.size());
  ASSERT_EQ(t.triangles.size(), s.triangles.size());
  // Written per region, so the triangles come back grouped; compare as sets of (region, corners).
  std::multiset<std::tuple<int, double, double, double, double, double, double, double, double, double>> a, c;
  for (auto* sf : {&s, &t})
    for (std::size_t i = 0; i < sf->triangles.size(); ++i) {
      const auto& tr = sf->triangles[i];
      const auto& p = sf->points;
      (sf == &s ? a : c)
          .insert({sf->region[i], p[tr[0]].x(), p[tr[0]].y(), p[tr[0]].z(), p[tr[1]].x(), p[tr[1]].y(), p[tr[1]].z(),
                   p[tr[2]].x(), p[tr[2]].y(), p[tr[2]].z()});
    }
  EXPECT_TRUE(a == c);
  EXPECT_NO_THROW(check_surface(t));
  std::remove(path.c_str());
}

// A tetrahedron: the smallest closed surface, two regions.
Surface tetrahedron() {
  Surface s;
  s.points = {Point(0, 0, 0), Point(1, 0, 0), Point(0, 1, 0), Point(0, 0, 1)};
  s.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  s.region = {0, 0, 0, 1};
  s.region_names = {"wall", "inlet"};
  return s;
}

TEST(Surface, TetrahedronIsClosedWithItsVolumeAndAreas) {
  const Surface s = tetrahedron();
  EXPECT_NO_THROW(check_surface(s));
  EXPECT_NEAR(s.volume(), 1.0 / 6, 1e-15);
  EXPECT_NEAR(s.area(1), std::sqrt(3.0) / 2, 1e-15);
  EXPECT_NEAR(s.area(), 1.5 + std::sqrt(3.0) / 2, 1e-15);
}

TEST(Surface, RefusesOpenMisorientedAndNonFiniteSurfacesInOneLine) {
  Surface open = tetrahedron();
  open.triangles.pop_back();
  open.region.pop_back();
  const std::string a = what([&] { check_surface(open); });
  EXPECT_NE(a.find("not closed"), std::string::npos) << a;
  EXPECT_NE(a.find("shared by 1 triangle"), std::string::npos) << a;
  Surface flipped = tetrahedron();
  std::swap(flipped.triangles[3][0], flipped.triangles[3][1]);
  const std::string b = what([&] { check_surface(flipped); });
  EXPECT_NE(b.find("not consistently oriented"), std::string::npos) << b;
  Surface inward = tetrahedron();
  for (auto& t : inward.triangles) std::swap(t[0], t[1]);
  const std::string c = what([&] { check_surface(inward); });
  EXPECT_NE(c.find("point inwards"), std::string::npos) << c;
  Surface nan = tetrahedron();
  nan.points[2].y() = std::nan("");
  const std::string d = what([&] { check_surface(nan); });
  EXPECT_NE(d.find("not finite"), std::string::npos) << d;
  for (const std::string& m : {a, b, c, d}) EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

TEST(Surface, RefusesAMissingRegionNamingTheOnesItHas) {
  const std::string m = what([] { check_regions(tetrahedron(), {"wall", "outlet_1"}); });
  EXPECT_EQ(m, "the surface has no region 'outlet_1' (its regions: wall, inlet)");
  EXPECT_NO_THROW(check_regions(tetrahedron(), {"inlet", "wall"}));
}

TEST(Surface, StlReaderRefusesNanBinaryAndMalformedFilesNamingTheLine) {
  const std::string nan = hemo::test::write_temp(
      "solid wall\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 nan 0\n  vertex 0 1 0\n endloop\n"
      "endfacet\nendsolid wall\n",
      ".stl");
  const std::string m = what([&] { read_stl(nan); });
  EXPECT_NE(m.find(nan + ":5: vertex coordinate 'nan' is not a finite number"), std::string::npos) << m;
  const std::string junk =
      hemo::test::write_temp("solid wall\nfacet normal 0 0 1\n outer loop\n  vertex 0 0\n", ".stl");
  EXPECT_NE(what([&] { read_stl(junk); }).find(":4: a vertex needs three coordinates"), std::string::npos);
  const std::string binary = hemo::test::write_temp(std::string("solid x\0\0\0", 10), ".stl");
  EXPECT_NE(what([&] { read_stl(binary); }).find("not an ASCII STL"), std::string::npos);
  EXPECT_NE(what([] { read_stl("/nonexistent/vessel.stl"); }).find("cannot be read"), std::string::npos);
  for (const auto& p : {nan, junk, binary}) std::remove(p.c_str());
}

TEST(Bifurcation, RefusesADaughterNarrowerThanARedCellAndImpossibleShapes) {
  BifurcationSpec narrow = small();
  narrow.daughter_diameter[1] = 7e-6;
  EXPECT_EQ(what([&] { make_bifurcation(narrow); }),
            "daughter 2 of the bifurcation is 7 um across, narrower than a red cell (8 um): widen it or the parent");
  BifurcationSpec tiny = small();
  tiny.parent_diameter = 9e-6;  // Murray's daughters: 7.1 um
  EXPECT_NE(what([&] { make_bifurcation(tiny); }).find("daughter 1 of the bifurcation is 7.14 um across"),
            std::string::npos);
  EXPECT_NO_THROW(check_bifurcation([] {
    BifurcationSpec ok = small();
    ok.daughter_diameter[0] = ok.daughter_diameter[1] = kMinDaughterDiameter;
    return ok;
  }()));
  for (const double deg : {0.0, 180.0, -10.0}) {
    BifurcationSpec bad = small();
    bad.angle = deg * kPi / 180;
    EXPECT_NE(what([&] { check_bifurcation(bad); }).find("must be in (0, 180) degrees"), std::string::npos) << deg;
  }
  BifurcationSpec close = small();
  close.angle = 10 * kPi / 180;
  EXPECT_NE(what([&] { check_bifurcation(close); }).find("outlets overlap"), std::string::npos);
  BifurcationSpec wide = small();
  wide.daughter_diameter[0] = 40e-6;
  EXPECT_NE(what([&] { check_bifurcation(wide); }).find("wider than the parent"), std::string::npos);
  BifurcationSpec long_one = small();
  long_one.daughter_length = 20e-3;  // 20 mm of 24-um daughters: 1e10 samples
  EXPECT_NE(what([&] { check_bifurcation(long_one); }).find("sampling grid would have"), std::string::npos);
  BifurcationSpec stub = small();
  stub.daughter_length = 20e-6;
  EXPECT_NE(what([&] { check_bifurcation(stub); }).find("must be longer than the parent's radius"), std::string::npos);
}

// ---- Surface vessels in scenes (model/scene.cpp, check_surface_vessel) ----

namespace {

// A scene of a 30-um bifurcation; `more` is appended to its [vessel] table, `tables` after it.
std::string bifurcation_scene(const std::string& more, const std::string& tables = "") {
  return "[vessel]\ndiameter_um = 30\nlength_um = 60\nshape = \"bifurcation\"\nends = \"open\"\n"
         "inlet = \"poiseuille\"\n" +
         more + "\n[driving]\nwall_shear_rate_per_s = 799\n" + tables;
}

std::vector<SceneProblem> scene_problems(const std::string& text, const std::string& suffix = ".toml") {
  try {
    load_scene(hemo::test::write_temp(text, suffix));
  } catch (const SceneError& e) {
    return e.problems();
  }
  return {};
}

}  // namespace

TEST(SurfaceScene, BifurcationKeysReachTheSurface) {
  const Scene s = load_scene(hemo::test::write_temp(bifurcation_scene(
      "daughter_1_diameter_um = 24\ndaughter_2_diameter_um = 18\ndaughter_length_um = 70\nbifurcation_angle_deg = 90",
      "[mesh]\nsurface_cell_size_um = 2\n")));
  EXPECT_TRUE(surface_vessel(s.vessel));
  EXPECT_DOUBLE_EQ(s.vessel.bifurcation_angle, kPi / 2);
  EXPECT_DOUBLE_EQ(s.mesh.surface_cell_size, 2e-6);
  const Surface surface = make_vessel_surface(s.vessel);
  // The outlets' caps are the scene's daughters', at the scene's length and angle.
  const Point out1 = surface.centroid(surface.region_index("outlet_1"));
  EXPECT_NEAR(surface.area(surface.region_index("outlet_1")) / (kPi * 144e-12), 1, 7e-3);
  EXPECT_NEAR(surface.area(surface.region_index("outlet_2")) / (kPi * 81e-12), 1, 7e-3);
  EXPECT_NEAR(out1.x(), 70e-6 * std::sin(kPi / 4), 1e-7);
  EXPECT_NEAR(out1.z(), 60e-6 + 70e-6 * std::cos(kPi / 4), 1e-7);
  // Not an axisymmetric vessel: refused by name where one is needed.
  EXPECT_NE(what([&] { make_vessel_geometry(s.vessel); }).find("vessel.shape \"bifurcation\" is a closed surface"),
            std::string::npos);
}

TEST(SurfaceScene, RefusesWhatASurfaceVesselCannotHaveInOneLineEach) {
  auto one = [](const std::string& text, const std::string& key, const std::string& part) {
    const auto ps = scene_problems(text);
    ASSERT_EQ(ps.size(), 1u) << text;
    EXPECT_EQ(ps[0].key, key) << text;
    EXPECT_NE(ps[0].message.find(part), std::string::npos) << ps[0].message;
    EXPECT_EQ(ps[0].message.find('\n'), std::string::npos) << ps[0].message;
  };
  EXPECT_TRUE(scene_problems(bifurcation_scene("")).empty());
  one(bifurcation_scene("daughter_2_diameter_um = 7"), "vessel.shape",
      "daughter 2 of the bifurcation is 7 um across, narrower than a red cell (8 um)");
  one(bifurcation_scene("", "[rbc]\nhematocrit = 0.1\n"), "vessel.inlet",
      "cells enter an open vessel only from a feeder (vessel.inlet = \"feeder\")");
  one("[vessel]\ndiameter_um = 30\nlength_um = 60\nshape = \"bifurcation\"\n[driving]\nwall_shear_rate_per_s = 799\n",
      "vessel.ends", "a surface vessel has open ends");
  one(bifurcation_scene("", "[run]\nfluid_ranks = 2\n"), "run.fluid_ranks", "runs on one rank for now");
  one(bifurcation_scene("bifurcation_angle_deg = 180"), "vessel.bifurcation_angle_deg", "must be in (0, 180)");
}

// An imported surface: its solids named by the scene become the inlet and outlet_1, outlet_2 (in
// the scene's order), the others the wall; a missing solid, a missing or open file, a path out of
// the scene's folder are refused on vessel.surface in one line.
TEST(SurfaceScene, ImportedSurfaceRenamesItsSolidsAndRefusesWhatItCannotUse) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("hemo_imported_" + std::to_string(::getpid()));
  fs::create_directories(dir / "shapes");
  Surface s = make_bifurcation(small());
  s.region_names = {"vessel_wall", "in", "left", "right"};  // daughter 1 (+x) is "left", daughter 2 "right"
  write_stl((dir / "shapes" / "y.stl").string(), s);
  auto scene = [&](const std::string& more) {
    const fs::path path = dir / "scene.toml";
    std::ofstream(path) << "[vessel]\ndiameter_um = 30\nlength_um = 60\nshape = \"imported\"\nends = \"open\"\n"
                           "inlet = \"uniform\"\n"
                        << more << "\n[driving]\nwall_shear_rate_per_s = 799\n";
    return path.string();
  };
  const Scene ok =
      load_scene(scene("surface = \"shapes/y.stl\"\nsurface_inlet = \"in\"\nsurface_outlets = \"right left\""));
  EXPECT_EQ(ok.vessel.surface_path, (dir / "shapes" / "y.stl").string());
  const Surface t = make_vessel_surface(ok.vessel);
  EXPECT_EQ(t.region_names, (std::vector<std::string>{"wall", "inlet", "outlet_1", "outlet_2"}));
  EXPECT_NEAR(t.area(t.region_index("inlet")), s.area(1), 1e-20);
  EXPECT_NEAR(t.area(t.region_index("outlet_1")), s.area(3), 1e-20);  // "right", named first
  EXPECT_LT(t.centroid(t.region_index("outlet_1")).x(), 0);           // "right" was daughter 2, at -x
  EXPECT_NEAR(t.area(0), s.area(0), 1e-20);
  auto refused = [&](const std::string& more, const std::string& part) {
    try {
      load_scene(scene(more));
      ADD_FAILURE() << more << ": not refused";
    } catch (const SceneError& e) {
      ASSERT_EQ(e.problems().size(), 1u) << e.what();
      EXPECT_EQ(e.problems()[0].key, "vessel.surface") << e.what();
      EXPECT_NE(e.problems()[0].message.find(part), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  };
  refused("surface = \"shapes/y.stl\"\nsurface_inlet = \"in\"\nsurface_outlets = \"left middle\"",
          "the surface has no region 'middle' (its regions: vessel_wall, in, left, right)");
  refused("surface = \"shapes/none.stl\"", "none.stl: cannot be read");
  refused("surface = \"../y.stl\"", "must be absolute or a path below the scene file's folder");
  refused("", "missing: the ASCII STL of the vessel.shape \"imported\"");
  Surface open = s;
  open.triangles.pop_back();
  open.region.pop_back();
  write_stl((dir / "shapes" / "open.stl").string(), open);
  refused("surface = \"shapes/open.stl\"\nsurface_inlet = \"in\"\nsurface_outlets = \"left right\"",
          "the surface is not closed");
  // An outlet narrower than a red cell, as if from another tool: the Y with daughter 2 of 8 um
  // (the narrowest the bifurcation shape itself takes), its outlet then shrunk to 7 um.
  BifurcationSpec eight = small();
  eight.daughter_diameter[1] = 8e-6;
  Surface thin = make_bifurcation(eight);
  // Shrink outlet_2's cap (region 3) about its centre to 7/8: its area to (7/8)^2, the wall's rim
  // with it (the surface stays closed; only the cap's and the last ring's points move).
  const Point c = thin.centroid(3);
  std::set<int> cap_points;
  for (std::size_t t = 0; t < thin.triangles.size(); ++t)
    if (thin.region[t] == 3)
      for (int v : thin.triangles[t]) cap_points.insert(v);
  for (int v : cap_points) thin.points[static_cast<std::size_t>(v)] = c + 0.875 * (thin.points[static_cast<std::size_t>(v)] - c);
  thin.region_names = {"vessel_wall", "in", "left", "right"};
  write_stl((dir / "shapes" / "thin.stl").string(), thin);
  refused("surface = \"shapes/thin.stl\"\nsurface_inlet = \"in\"\nsurface_outlets = \"left right\"",
          "the surface's end 'right' (outlet_2) is 7.0 um across (a disc of its area), narrower than a red cell (8 um)");
  fs::remove_all(dir);
}

// The bifurcation's wall as the particle side asks it (BifurcationWall): each branch's section
// (its radius, the distance from its axis, its centre-line speed from the network's split), the
// signed distance zero on the wall and of the right sign either side, the DEM's wall facing into
// the vessel with the wall region's area and no end caps.
TEST(BifurcationWall, SectionsAreTheirBranchesWithTheNetworksSpeeds) {
  BifurcationSpec spec = small();
  spec.daughter_diameter[0] = 24e-6;
  spec.daughter_diameter[1] = 18e-6;
  const BifurcationWall wall(spec);
  const BifurcationSpec r = resolved(spec);
  const Point junction(0, 0, r.parent_length);
  const double rp = r.parent_diameter / 2;
  // The network's split, written out: conductances R^4 / L with equal daughter lengths.
  const double c1 = std::pow(12e-6, 4), c2 = std::pow(9e-6, 4);
  const double q[2] = {c1 / (c1 + c2), c2 / (c1 + c2)};
  EXPECT_NEAR(network_flow_fraction(spec, 0), q[0], 1e-15);
  EXPECT_NEAR(network_flow_fraction(spec, 0) + network_flow_fraction(spec, 1), 1.0, 1e-15);

  const VesselWall::Section parent = wall.section_at(Point(3e-6, 4e-6, r.parent_length / 2));
  EXPECT_EQ(wall.branch_at(Point(3e-6, 4e-6, r.parent_length / 2)), 0);
  EXPECT_DOUBLE_EQ(parent.radius, rp);
  EXPECT_NEAR(parent.off_axis, 5e-6, 1e-18);
  EXPECT_DOUBLE_EQ(parent.centreline_speed(1.0), 1.0);
  for (int i = 0; i < 2; ++i) {
    const Point d = daughter_direction(r, i);
    const Point side = d.cross(Point::UnitY()).normalized();
    const Point x = junction + 0.7 * r.daughter_length * d + 2e-6 * side;
    EXPECT_EQ(wall.branch_at(x), i + 1);
    const VesselWall::Section s = wall.section_at(x);
    const double ri = r.daughter_diameter[i] / 2;
    EXPECT_DOUBLE_EQ(s.radius, ri);
    EXPECT_NEAR(s.off_axis, 2e-6, 1e-15);
    // Poiseuille in each branch: u_c = 2 Q / (pi R^2), so u_i / u_p = (Q_i / Q_p) (R_p / R_i)^2.
    EXPECT_NEAR(s.centreline_speed(1.0), q[i] * (rp / ri) * (rp / ri), 1e-12);
    // On the wall, inside and outside.
    EXPECT_NEAR(wall.signed_distance(junction + 0.7 * r.daughter_length * d + ri * side), 0, 1e-12);
    EXPECT_LT(wall.signed_distance(x), 0);
    EXPECT_GT(wall.signed_distance(junction + 0.7 * r.daughter_length * d + 1.1 * ri * side), 0);
  }
  EXPECT_LT((wall.outward_normal(Point(rp * 0.9, 0, r.parent_length / 3)) - Point::UnitX()).norm(), 1e-6);
}

TEST(BifurcationWall, DemWallIsTheWallRegionFacingIn) {
  const BifurcationSpec spec = small();
  const BifurcationWall wall(spec);
  const Surface s = make_bifurcation(spec);
  const std::vector<WallTriangle> dem = wall.dem_wall();
  const BifurcationSpec r = resolved(spec);
  const Point junction(0, 0, r.parent_length);
  double area = 0;
  int smooth = 0, facing_in = 0;
  for (const WallTriangle& t : dem) {
    const Point n = (t.vertex[1] - t.vertex[0]).cross(t.vertex[2] - t.vertex[0]);
    area += n.norm() / 2;
    // The wall's normal is defined away from the junction's creases and the ends' rims.
    const Point centroid = (t.vertex[0] + t.vertex[1] + t.vertex[2]) / 3;
    double from_ends = centroid.z();
    for (int i = 0; i < 2; ++i) {
      const Point d = daughter_direction(r, i);
      from_ends = std::min(from_ends, (junction + r.daughter_length * d - centroid).dot(d));
    }
    if ((centroid - junction).norm() > r.parent_diameter && from_ends > r.step) {
      ++smooth;
      facing_in += n.dot(wall.outward_normal(centroid)) < 0;
    }
    for (const Point& v : t.vertex) EXPECT_LT(std::abs(wall.signed_distance(v)), 1e-9) << v.transpose();
  }
  EXPECT_GT(smooth, static_cast<int>(dem.size()) / 2);
  EXPECT_EQ(facing_in, smooth);
  EXPECT_NEAR(area, s.area(s.region_index(surface_region::wall)), 1e-9 * area);
  EXPECT_LT(area, s.area());  // the inlet and outlet caps are open
}

TEST(BifurcationWall, EveryShapeCarriesCellsWithAWallOfItsOwn) {
  for (const VesselShape& shape : vessel_shapes()) EXPECT_TRUE(shape.carries_cells()) << shape.name;
  Vessel v;
  v.shape = "bifurcation";
  v.diameter = 30e-6;
  v.length = 60e-6;
  EXPECT_FALSE(make_vessel_wall(v)->axisymmetric());
  EXPECT_TRUE(make_vessel_wall(v)->defines_centreline_speed());
  v.shape = "straight";
  EXPECT_TRUE(make_vessel_wall(v)->axisymmetric());
}

namespace {

// The bifurcation scene with its inlet fed (`inlet`: "feeder", "feeder_at_q", or "" for the
// default).
std::string fed_bifurcation_scene(const std::string& inlet, const std::string& tables = "") {
  std::string text = bifurcation_scene("", tables);
  const std::string fixed = "inlet = \"poiseuille\"\n";
  text.replace(text.find(fixed), fixed.size(), inlet.empty() ? "" : "inlet = \"" + inlet + "\"\n");
  return text;
}

// The surface turned by `degrees` about the y axis (z towards x).
Surface turned(Surface s, double degrees) {
  const double a = degrees * kPi / 180, c = std::cos(a), sn = std::sin(a);
  for (Point& p : s.points) p = Point(c * p.x() + sn * p.z(), p.y(), -sn * p.x() + c * p.z());
  return s;
}

}  // namespace

// A fed surface vessel's feeder (model/vessel_ends.h, feeder_layout(scene)): a tube of the inlet's
// equivalent radius beside the surface's widest x by one radius, through the inlet's centre's y,
// from the inlet plane over whole layers of the surface mesh's cubes that cover the vessel's z
// extent and one inlet diameter; a feeder point stands for the inlet-plane point at its offset
// from the axis. "feeder" is a surface vessel's default inlet, as an O-grid's.
TEST(SurfaceScene, AFedBifurcationsFeederLiesBesideItFromItsInletPlane) {
  for (const double cell_um : {0.0, 3.0}) {
    const std::string tables = cell_um > 0 ? fmt::format("[mesh]\nsurface_cell_size_um = {}\n", cell_um) : "";
    const Scene s = load_scene(hemo::test::write_temp(fed_bifurcation_scene("", tables)));
    ASSERT_EQ(s.vessel.inlet, "feeder");
    ASSERT_TRUE(fed_by_feeder(s.vessel));
    const double h = cell_um > 0 ? cell_um * 1e-6 : 30e-6 / 12;
    EXPECT_DOUBLE_EQ(surface_cell_size(s), h);
    const Surface surface = make_vessel_surface(s.vessel);
    const int inlet = surface.region_index("inlet");
    const FeederLayout f = feeder_layout(s);
    const Point c = surface.centroid(inlet), hi = surface.upper();
    EXPECT_DOUBLE_EQ(f.radius, std::sqrt(surface.area(inlet) / kPi));
    EXPECT_NEAR(f.radius / 15e-6, 1, 0.01);
    EXPECT_EQ(f.inlet_x, c.x());
    EXPECT_EQ(f.inlet_y, c.y());
    EXPECT_EQ(f.inlet_z, c.z());
    EXPECT_NEAR(f.inlet_z, 0, 1e-12);
    EXPECT_DOUBLE_EQ(f.vessel_length, hi.z() - c.z());
    EXPECT_GT(f.vessel_length, 60e-6 + 60e-6 * std::cos(kPi / 6));  // the parent and the daughters' reach
    EXPECT_DOUBLE_EQ(f.period, f.layers * h);
    EXPECT_GE(f.period, f.vessel_length + 2 * f.radius);
    EXPECT_LT(f.period - h, f.vessel_length + 2 * f.radius);
    EXPECT_DOUBLE_EQ(f.axis_x, hi.x() + 2 * f.radius);
    EXPECT_DOUBLE_EQ(f.split_x, 0.5 * (hi.x() + f.axis_x - f.radius));
    EXPECT_GT(f.split_x, hi.x());
    EXPECT_LT(f.split_x, f.axis_x - f.radius);
    const Point p(f.axis_x + 3e-6, f.inlet_y + 2e-6, f.inlet_z + 50e-6);
    EXPECT_TRUE(f.in_feeder(p.x()));
    const Point q = f.in_vessel_frame(p);
    EXPECT_NEAR(q.x(), f.inlet_x + 3e-6, 1e-18);
    EXPECT_EQ(q.y(), p.y());
    EXPECT_EQ(q.z(), f.inlet_z);
    const Point vessel_point(hi.x(), 0, 100e-6);
    EXPECT_EQ(f.in_vessel_frame(vessel_point), vessel_point);
  }
  EXPECT_TRUE(scene_problems(fed_bifurcation_scene("feeder")).empty());
  EXPECT_TRUE(scene_problems(fed_bifurcation_scene("feeder_at_q")).empty());
  EXPECT_THROW(feeder_layout(load_scene(hemo::test::write_temp(bifurcation_scene("")))), std::invalid_argument);
}

// A feeder needs the inlet to face -z (its section is perpendicular to z): an imported surface
// turned a quarter turn is refused in one line on vessel.inlet naming where its inlet faces; a
// fixed profile takes it as it is, and a turn within the limit is fed.
TEST(SurfaceScene, AFeederRefusesAnInletThatDoesNotFaceMinusZ) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("hemo_turned_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto scene = [&](double degrees, const std::string& inlet) {
    const std::string name = fmt::format("y{}.stl", degrees);
    write_stl((dir / name).string(), turned(make_bifurcation(small()), degrees));
    const fs::path path = dir / "scene.toml";
    std::ofstream(path) << "[vessel]\ndiameter_um = 30\nlength_um = 60\nshape = \"imported\"\nends = \"open\"\n"
                           "inlet = \""
                        << inlet << "\"\nsurface = \"" << name
                        << "\"\nsurface_inlet = \"inlet\"\nsurface_outlets = \"outlet_1 outlet_2\"\n"
                           "[driving]\nwall_shear_rate_per_s = 799\n";
    return path.string();
  };
  try {
    load_scene(scene(90, "feeder"));
    ADD_FAILURE() << "a feeder for an inlet facing -x: not refused";
  } catch (const SceneError& e) {
    ASSERT_EQ(e.problems().size(), 1u) << e.what();
    EXPECT_EQ(e.problems()[0].key, "vessel.inlet") << e.what();
    const std::string& m = e.problems()[0].message;
    EXPECT_NE(m.find("a feeder needs the surface's inlet to face -z: it faces (-1.000, "), std::string::npos) << m;
    EXPECT_NE(m.find("), 90.0 degrees off (at most 1)"), std::string::npos) << m;
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(load_scene(scene(90, "poiseuille")));
  const Scene slightly = load_scene(scene(0.5, "feeder_at_q"));
  EXPECT_NEAR(feeder_layout(slightly).radius / 15e-6, 1, 0.01);
  fs::remove_all(dir);
}

// Just before the junction, near the parent's wall, a point can be nearer a daughter's axis than
// the parent's while outside that daughter's tube: its section is the parent's, the tube it is in.
TEST(BifurcationWall, APointInTheParentBeforeTheJunctionIsInTheParentsSection) {
  BifurcationSpec spec;
  spec.parent_diameter = 100e-6;
  spec.parent_length = 100e-6;
  spec.daughter_length = 120e-6;
  const BifurcationWall wall(spec);
  const Point x(47.5e-6, -4.4e-6, 87.8e-6);  // where a placed cell was given a daughter's section
  ASSERT_LT(wall.signed_distance(x), 0);
  EXPECT_EQ(wall.branch_at(x), 0);
  const VesselWall::Section s = wall.section_at(x);
  EXPECT_DOUBLE_EQ(s.radius, 50e-6);
  EXPECT_LT(s.off_axis, s.radius);
}

// A 30-um bifurcation's default cubes (2.5 um, d/12) are narrower than a red cell: refused with
// the particle's own sharing, accepted with a Gaussian kernel (coupling.solid_fraction
// "gaussian_kernel"), whose width is refused in one line when it is narrower than a cube or wider
// than the narrowest end's radius (the Murray daughters' 23.8 um across), at half maximum.
TEST(SurfaceScene, AKernelCarriesRedCellsInCubesNarrowerThanThem) {
  auto one = [](const std::string& text, const std::string& key, const std::string& part) {
    const auto ps = scene_problems(text);
    ASSERT_EQ(ps.size(), 1u) << text;
    EXPECT_EQ(ps[0].key, key) << text;
    EXPECT_NE(ps[0].message.find(part), std::string::npos) << ps[0].message;
    EXPECT_EQ(ps[0].message.find('\n'), std::string::npos) << ps[0].message;
  };
  const std::string blood = "[rbc]\nhematocrit = 0.15\n";
  one(fed_bifurcation_scene("", blood), "mesh.surface_cell_size_um",
      "the snapped cubes (2.5 um) must be wider than a rbc (5.56 um)");
  const std::string kernel = "[coupling]\nsolid_fraction = \"gaussian_kernel\"\n";
  const auto ps = scene_problems(fed_bifurcation_scene("", blood + kernel));
  EXPECT_TRUE(ps.empty()) << (ps.empty() ? "" : ps[0].message);
  const Scene s = load_scene(hemo::test::write_temp(fed_bifurcation_scene("", blood + kernel)));
  EXPECT_EQ(s.solid_fraction, "gaussian_kernel");
  EXPECT_EQ(s.kernel_width_diameters, 1.0);
  one(fed_bifurcation_scene("", blood + kernel + "kernel_width_diameters = 0.4\n"), "coupling.kernel_width_diameters",
      "a rbc's kernel (2.224 um at half maximum) is narrower than the snapped cubes (2.5 um)");
  // 2.2 diameters: 12.2 um at half maximum, against daughters of 23.8 um (a radius of 11.9); 2 fit.
  one(fed_bifurcation_scene("", blood + kernel + "kernel_width_diameters = 2.2\n"), "coupling.kernel_width_diameters",
      "a rbc's kernel (12.2 um at half maximum) is wider than the radius of the vessel's narrowest end (11.9 um)");
  EXPECT_TRUE(scene_problems(fed_bifurcation_scene("", blood + kernel + "kernel_width_diameters = 2\n")).empty());
  one(fed_bifurcation_scene("", blood + kernel + "kernel_width_diameters = 0\n"), "coupling.kernel_width_diameters",
      "must be positive");
}
