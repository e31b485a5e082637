// The fluid mesh of a surface vessel (fluid-node/surface_mesh.h): blockMesh + snappyHexMesh on
// the generated small bifurcation (D_p = 30 um, cells of 2.5 um), read back; every region a
// non-empty patch of its name, the box's patch gone, checkMesh content, the mesh's volume and its
// ends' areas the surface's; and the one-line refusals when a region gets no faces or the
// vessel's side is not the inside.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "surface_mesh.h"

#include <bifurcation.h>
#include <child_process.h>
#include <vessel_ends.h>

#include <gtest/gtest.h>

#include "minimal_scene.h"
#include "small_bifurcation.h"
#include "thrown.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

using namespace hemo;
namespace fs = std::filesystem;

namespace {

BifurcationSpec small() { return hemo::test::small_bifurcation(); }

std::string fresh_case(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("hemo_surface_mesh_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::string what(const std::function<void()>& f) { return hemo::test::what_thrown(f); }

double area_of(const PolyMesh& m, const MeshGeometry& g, const std::string& patch) {
  const PatchInfo& p = m.patch(patch);
  double a = 0;
  for (int f = p.start; f < p.start + p.size; ++f) {
    const auto& s = g.face_areas[static_cast<std::size_t>(f)];
    a += std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  }
  return a;
}

}  // namespace

TEST(SurfaceMesh, SnappyMeshesTheBifurcationWithAPatchPerRegion) {
  const Surface s = make_bifurcation(small());
  const std::string dir = fresh_case("ok");
  SurfaceMeshSpec spec;
  spec.cell_size = 2.5e-6;
  spec.location_in_mesh = point_inside_from_inlet(s);
  const auto t0 = std::chrono::steady_clock::now();
  const PolyMesh m = mesh_surface(s, spec, dir);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(m.patches.size(), 4u);
  for (const auto& p : m.patches) {
    EXPECT_GE(s.region_index(p.name), 0) << p.name;
    EXPECT_GT(p.size, 0) << p.name;
    EXPECT_EQ(p.type, p.name == "wall" ? "wall" : "patch") << p.name;
  }
  // Faces in OpenFOAM's order: internal first, then the patches back to back to the end.
  EXPECT_EQ(m.patches.front().start, m.n_internal_faces());
  EXPECT_EQ(m.patches.back().start + m.patches.back().size, m.n_faces());
  const MeshGeometry g = compute_geometry(m);
  // Every cell closed: its faces' area vectors, outward, sum to zero.
  std::vector<std::array<double, 3>> sum(static_cast<std::size_t>(m.n_cells), {0, 0, 0});
  double largest = 0;
  for (int f = 0; f < m.n_faces(); ++f)
    for (int c = 0; c < 3; ++c) {
      const double a = g.face_areas[static_cast<std::size_t>(f)][static_cast<std::size_t>(c)];
      sum[static_cast<std::size_t>(m.owner[static_cast<std::size_t>(f)])][static_cast<std::size_t>(c)] += a;
      if (f < m.n_internal_faces())
        sum[static_cast<std::size_t>(m.neighbour[static_cast<std::size_t>(f)])][static_cast<std::size_t>(c)] -= a;
      largest = std::max(largest, std::abs(a));
    }
  double open = 0;
  for (const auto& v : sum) open = std::max({open, std::abs(v[0]), std::abs(v[1]), std::abs(v[2])});
  EXPECT_LT(open, 1e-9 * largest);
  double volume = 0;
  for (double v : g.cell_volumes) {
    EXPECT_GT(v, 0);
    volume += v;
  }
  // Snapped onto the surface, the mesh fills it: the cells' volume is the surface's, to what
  // snapping leaves between the wall's faces and the surface (measured -0.9 %; 2 % allowed).
  const double pi = 3.14159265358979323846;
  const double d_daughter = 30e-6 / std::cbrt(2.0);
  const double inlet = area_of(m, g, "inlet") / (pi * 15e-6 * 15e-6);
  const double out1 = area_of(m, g, "outlet_1") / (pi * d_daughter * d_daughter / 4);
  const double out2 = area_of(m, g, "outlet_2") / (pi * d_daughter * d_daughter / 4);
  std::printf(
      "snappy bifurcation (cells of 2.5 um, %.1f s): %d cells; volume / surface's - 1 = %+.3e; patch areas / "
      "pi r^2 - 1: inlet %+.3e, outlet_1 %+.3e, outlet_2 %+.3e\n",
      seconds, m.n_cells, volume / s.volume() - 1, inlet - 1, out1 - 1, out2 - 1);
  EXPECT_NEAR(volume / s.volume(), 1, 0.02);
  // The ends' patches are their caps: snapped onto the caps' planes, their rims onto the caps'
  // edges (multiRegionFeatureSnap), so each patch's area is its cap's to the snapped polygon's
  // error (measured within 0.7 %; 2 % allowed).
  for (double a : {inlet, out1, out2}) EXPECT_NEAR(a, 1, 0.02);
  // And OpenFOAM's checkMesh finds nothing wrong.
  ChildOptions opt;
  opt.env = {{"WM_PROJECT_DIR", "/usr/share/openfoam"}};
  std::string verdict;
  opt.on_line = [&](const std::string& line) {
    if (line.find("Mesh OK") != std::string::npos || line.find("Failed") != std::string::npos) verdict = line;
  };
  opt.merge_stderr = true;
  EXPECT_TRUE(run_child({"checkMesh", "-case", dir}, opt).ok());
  EXPECT_NE(verdict.find("Mesh OK"), std::string::npos) << verdict;
  fs::remove_all(dir);
}

TEST(SurfaceMesh, RefusesARegionThatGetsNoFacesInOneLine) {
  Surface s = make_bifurcation(small());
  // One wall triangle of the parent, of a micrometre or so, as a region of its own: far smaller
  // than a cell, it gets no face.
  std::size_t pick = 0;
  for (std::size_t t = 0; t < s.triangles.size(); ++t)
    if (s.region[t] == 0 && s.points[static_cast<std::size_t>(s.triangles[t][0])].z() > 20e-6 &&
        s.points[static_cast<std::size_t>(s.triangles[t][0])].z() < 30e-6)
      pick = t;
  s.region_names.push_back("outlet_3");
  s.region[pick] = 4;
  const std::string dir = fresh_case("lost");
  SurfaceMeshSpec spec;
  spec.cell_size = 2.5e-6;
  spec.location_in_mesh = point_inside_from_inlet(s);
  const std::string m = what([&] { mesh_surface(s, spec, dir); });
  EXPECT_NE(m.find("snappyHexMesh made no faces of region 'outlet_3' (cells of 2.5 um"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  fs::remove_all(dir);
}

TEST(SurfaceMesh, RefusesAPointOutsideTheVesselInOneLine) {
  const Surface s = make_bifurcation(small());
  const std::string dir = fresh_case("outside");
  SurfaceMeshSpec spec;
  spec.cell_size = 2.5e-6;
  spec.location_in_mesh = {20.1e-6, 0.13e-6, 10.1e-6};  // beside the parent, in the box
  const std::string m = what([&] { mesh_surface(s, spec, dir); });
  EXPECT_NE(m.find("faces on patch 'background', not one of the surface's regions"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  fs::remove_all(dir);
}

// A fed surface vessel's mesh (surface_vessel_mesh, append_feeder): the snapped bifurcation's
// cells, then the feeder's O-grid (the scene's 4/3 section of the inlet's equivalent radius, its
// layers the cubes' 2.5 um) as a disconnected region after them, in OpenFOAM's order; the inlet a
// mapped patch taking the feeder's end faces, which cover it once moved onto it; checkMesh content
// with the two regions; and the case's mesh read back (a resumed run) is the same mesh, its zone
// and mapped patch included.
TEST(SurfaceMesh, AFedBifurcationIsTheSnappedMeshAndTheFeedersOGrid) {
  const std::string dir = fresh_case("fed");
  const Scene scene = load_scene(hemo::test::write_temp(
      "[vessel]\ndiameter_um = 30\nlength_um = 60\nshape = \"bifurcation\"\nends = \"open\"\ninlet = \"feeder\"\n"
      "[mesh]\nsurface_cell_size_um = 2.5\n[driving]\nwall_shear_rate_per_s = 799\n"));
  const FeederLayout f = feeder_layout(scene);
  const PolyMesh m = surface_vessel_mesh(scene, dir, true);
  const std::vector<std::pair<std::string, std::string>> patches{
      {"wall", "wall"},        {"inlet", "mappedPatch"},   {"outlet_1", "patch"},      {"outlet_2", "patch"},
      {"feeder_wall", "wall"}, {"feeder_inlet", "cyclic"}, {"feeder_outlet", "cyclic"}};
  ASSERT_EQ(m.patches.size(), patches.size());
  int next = m.n_internal_faces();
  for (std::size_t i = 0; i < patches.size(); ++i) {
    EXPECT_EQ(m.patches[i].name, patches[i].first);
    EXPECT_EQ(m.patches[i].type, patches[i].second) << patches[i].first;
    EXPECT_EQ(m.patches[i].start, next) << patches[i].first;
    EXPECT_GT(m.patches[i].size, 0) << patches[i].first;
    next += m.patches[i].size;
  }
  EXPECT_EQ(next, m.n_faces());
  EXPECT_NEAR(m.patch("feeder_inlet").separation[2], f.period, 1e-18);
  const int section = 4 * 4 + 4 * 4 * 3;
  ASSERT_EQ(m.cell_zones.size(), 1u);
  const CellZone& zone = m.cell_zones[0];
  EXPECT_EQ(zone.name, feeder_zone);
  EXPECT_EQ(zone.size, section * f.layers);
  EXPECT_EQ(zone.first + zone.size, m.n_cells);
  // Upper-triangular internal faces (by owner, then neighbour), none joining the two regions.
  for (int i = 0; i < m.n_internal_faces(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_LT(m.owner[k], m.neighbour[k]) << i;
    EXPECT_EQ(m.owner[k] < zone.first, m.neighbour[k] < zone.first) << i;
    if (i > 0) {
      EXPECT_TRUE(m.owner[k - 1] < m.owner[k] || (m.owner[k - 1] == m.owner[k] && m.neighbour[k - 1] < m.neighbour[k]))
          << i;
    }
  }
  const MeshGeometry g = compute_geometry(m);
  for (double v : g.cell_volumes) ASSERT_GT(v, 0);
  for (int c = zone.first; c < m.n_cells; ++c) {
    const auto& x = g.cell_centres[static_cast<std::size_t>(c)];
    EXPECT_LT(std::hypot(x[0] - f.axis_x, x[1] - f.inlet_y), f.radius) << c;
    EXPECT_GT(x[2], f.inlet_z);
    EXPECT_LT(x[2], f.inlet_z + f.period);
    EXPECT_GT(x[0], f.split_x);
  }
  for (int c = 0; c < zone.first; ++c) EXPECT_LT(g.cell_centres[static_cast<std::size_t>(c)][0], f.split_x) << c;
  // The inlet takes the faces of feeder_inlet (the feeder's end, in the inlet plane) moved onto it
  // by the offset, weighted by their overlaps: the inlet is flat in that plane, and moved back onto
  // the feeder its faces lie within its section (their centres inside the circle of its radius,
  // which its circumscribed wall polygon holds), but for the rim's snapped points: the cap's
  // circle is the parent's, 1e-3 wider than the equivalent one, and snapping leaves them a little
  // further (measured 0.9 %; what sticks out takes nothing).
  const PatchInfo& inlet = m.patch("inlet");
  EXPECT_EQ(inlet.sample_patch, "feeder_inlet");
  EXPECT_EQ(inlet.sample_offset[0], f.inlet_x - f.axis_x);
  EXPECT_EQ(inlet.sample_offset[1], 0.0);
  EXPECT_EQ(inlet.sample_offset[2], 0.0);
  const double h = f.period / f.layers;
  double farthest_centre = 0, farthest_point = 0;
  for (int i = inlet.start; i < inlet.start + inlet.size; ++i) {
    const auto& x = g.face_centres[static_cast<std::size_t>(i)];
    farthest_centre = std::max(farthest_centre, std::hypot(x[0] - inlet.sample_offset[0] - f.axis_x, x[1] - f.inlet_y));
    for (const int p : m.faces[static_cast<std::size_t>(i)]) {
      const auto& q = m.points[static_cast<std::size_t>(p)];
      farthest_point = std::max(farthest_point, std::hypot(q[0] - inlet.sample_offset[0] - f.axis_x, q[1] - f.inlet_y));
      EXPECT_NEAR(q[2], f.inlet_z, 1e-3 * h);
    }
  }
  const PatchInfo& end = m.patch("feeder_inlet");
  for (int i = end.start; i < end.start + end.size; ++i)
    EXPECT_NEAR(g.face_centres[static_cast<std::size_t>(i)][2], f.inlet_z, 1e-18);
  std::printf(
      "fed bifurcation: %d snapped cells + feeder %d x %d; the inlet moved onto the feeder: its farthest face centre "
      "at %.4f of the feeder's radius, its farthest point at %.4f\n",
      zone.first, section, f.layers, farthest_centre / f.radius, farthest_point / f.radius);
  EXPECT_LT(farthest_centre, f.radius);
  EXPECT_LT(farthest_point, 1.02 * f.radius);
  // What the case holds, and what a resumed run reads back.
  write_polymesh(m, dir);
  const PolyMesh back = read_polymesh(dir);
  EXPECT_EQ(mesh_hash(back), mesh_hash(m));
  ASSERT_EQ(back.cell_zones.size(), 1u);
  EXPECT_EQ(back.cell_zones[0].first, zone.first);
  EXPECT_EQ(back.cell_zones[0].size, zone.size);
  std::ifstream boundary(fs::path(dir) / "constant" / "polyMesh" / "boundary");
  const std::string text((std::istreambuf_iterator<char>(boundary)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("sampleMode      nearestPatchFaceAMI;\n        samplePatch     feeder_inlet;"),
            std::string::npos);
  ChildOptions opt;
  opt.env = {{"WM_PROJECT_DIR", "/usr/share/openfoam"}};
  std::string verdict, regions;
  opt.on_line = [&](const std::string& line) {
    if (line.find("Mesh OK") != std::string::npos || line.find("Failed") != std::string::npos) verdict = line;
    if (line.find("Number of regions") != std::string::npos) regions = line;
  };
  opt.merge_stderr = true;
  EXPECT_TRUE(run_child({"checkMesh", "-case", dir}, opt).ok());
  EXPECT_NE(verdict.find("Mesh OK"), std::string::npos) << verdict;
  EXPECT_NE(regions.find("2"), std::string::npos) << regions;
  fs::remove_all(dir);
}

// The straight tube's feeder and mesh are what they were before surface vessels could be fed: its
// layout's numbers and its fed mesh's hash, pinned from the code before the change.
TEST(SurfaceMesh, TheStraightTubesFeederIsUnchanged) {
  Vessel v;
  v.diameter = 100e-6;
  v.length = 600e-6;
  v.ends = "open";
  v.inlet = "feeder";
  EXPECT_EQ(mesh_hash(make_vessel_mesh(v, MeshSpec{4, 3, 6})), "75ec9c38499cfb94");
  EXPECT_EQ(mesh_hash(make_vessel_mesh(v, MeshSpec{4, 3, 24})), "928f135aa0f22c3c");
  for (const int axial : {6, 24}) {
    const FeederLayout f = feeder_layout(v, axial);
    EXPECT_EQ(f.vessel_length, 0.00059999999999999995);
    EXPECT_EQ(f.period, 0.00069999999999999988);
    EXPECT_EQ(f.axis_x, 0.00015000000000000001);
    EXPECT_EQ(f.split_x, 7.5000000000000007e-05);
    EXPECT_EQ(f.radius, 5.0000000000000002e-05);
  }
}
