// Unit tests of the O-grid vessel mesh generator.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>
#include <hemo/mesh_t.hpp>

#include "geometry.h"
#include "minimal_scene.h"
#include "scene.h"
#include "vessel_mesh.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

namespace {

using hemo::Vec3;
constexpr double kPi = 3.14159265358979323846;

hemo::Vessel paper_vessel() { return hemo::Vessel{100e-6, 600e-6}; }

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

struct Built {
  hemo::PolyMesh mesh;
  hemo::MeshGeometry geo;
};

Built build(int core, int ring, int axial, hemo::Vessel v = paper_vessel(),
            const std::string& wall_polygon = "circumscribed") {
  hemo::MeshSpec spec;
  spec.core_cells = core;
  spec.ring_cells = ring;
  spec.axial_cells = axial;
  hemo::choice_named(wall_polygon, spec.wall_polygon);
  Built b{hemo::make_vessel_mesh(v, spec), {}};
  b.geo = hemo::compute_geometry(b.mesh);
  return b;
}

TEST(VesselMesh, CellCountMatchesSpec) {
  for (auto [c, r, a] : {std::array<int, 3>{4, 3, 24}, {2, 1, 1}, {6, 4, 10}, {8, 6, 3}}) {
    hemo::MeshSpec spec{c, r, a};
    const auto mesh = hemo::make_vessel_mesh(paper_vessel(), spec);
    EXPECT_EQ(mesh.n_cells, spec.cells()) << c << " " << r << " " << a;
  }
  EXPECT_EQ(build(4, 3, 24).mesh.n_cells, 1536);  // the paper's mesh
}

TEST(VesselMesh, CellsAreClosedHexahedraWithPositiveVolume) {
  const auto b = build(4, 3, 24);
  const auto& m = b.mesh;
  std::vector<Vec3> sum(static_cast<std::size_t>(m.n_cells), Vec3{0, 0, 0});
  std::vector<double> mag(static_cast<std::size_t>(m.n_cells), 0.0);
  std::vector<int> nfaces(static_cast<std::size_t>(m.n_cells), 0);
  for (int f = 0; f < m.n_faces(); ++f) {
    EXPECT_EQ(m.faces[f].size(), 4u);
    const auto& s = b.geo.face_areas[f];
    auto add = [&](int c, double sign) {
      for (int d = 0; d < 3; ++d) sum[c][d] += sign * s[d];
      mag[c] += norm(s);
      ++nfaces[c];
    };
    add(m.owner[f], 1);
    if (f < m.n_internal_faces()) add(m.neighbour[f], -1);
  }
  for (int c = 0; c < m.n_cells; ++c) {
    EXPECT_EQ(nfaces[c], 6) << "cell " << c;
    EXPECT_LT(norm(sum[c]), 1e-12 * mag[c]) << "cell " << c << " is not closed";
    EXPECT_GT(b.geo.cell_volumes[c], 0) << "cell " << c;
  }
}

// The cross-section is the regular polygon of 4 core_cells sides, tangent to the vessel circle
// (the default) or inscribed in it; either converges to the cylinder at second order.
TEST(VesselMesh, TotalVolumeIsTheWallPolygonsAndConvergesToTheCylinder) {
  const auto v = paper_vessel();
  const double exact = kPi * v.radius() * v.radius() * v.length;
  for (const std::string polygon : {"circumscribed", "inscribed"}) {
    double previous_error = 1;
    for (int n : {2, 4, 8, 16, 32}) {
      const auto b = build(n, n, 2, v, polygon);
      double total = 0;
      for (double vol : b.geo.cell_volumes) total += vol;
      const int sides = 4 * n;
      const double area = polygon == "inscribed" ? 0.5 * sides * std::sin(2 * kPi / sides)  // in R^2
                                                 : sides * std::tan(kPi / sides);
      EXPECT_NEAR(total / (area * v.radius() * v.radius() * v.length), 1.0, 1e-12) << polygon << " " << n;
      const double error = std::abs(total / exact - 1);
      EXPECT_LT(error, previous_error / 3.5) << "second-order polygon convergence at n = " << n << ", " << polygon;
      previous_error = error;
    }
    EXPECT_LT(previous_error, 2e-3) << polygon;
  }
}

TEST(VesselMesh, InternalFacesAreUpperTriangularAndPointOwnerToNeighbour) {
  const auto b = build(4, 3, 6);
  const auto& m = b.mesh;
  ASSERT_GT(m.n_internal_faces(), 0);
  for (int f = 0; f < m.n_internal_faces(); ++f) {
    EXPECT_LT(m.owner[f], m.neighbour[f]);
    if (f > 0) {
      const bool ordered =
          m.owner[f - 1] < m.owner[f] || (m.owner[f - 1] == m.owner[f] && m.neighbour[f - 1] < m.neighbour[f]);
      EXPECT_TRUE(ordered) << "face " << f;
    }
    const Vec3 d = sub(b.geo.cell_centres[m.neighbour[f]], b.geo.cell_centres[m.owner[f]]);
    EXPECT_GT(dot(d, b.geo.face_areas[f]), 0) << "face " << f;
  }
  for (int f = m.n_internal_faces(); f < m.n_faces(); ++f) {
    const Vec3 d = sub(b.geo.face_centres[f], b.geo.cell_centres[m.owner[f]]);
    EXPECT_GT(dot(d, b.geo.face_areas[f]), 0) << "boundary face " << f << " not outward";
  }
}

TEST(VesselMesh, PatchesCoverTheBoundary) {
  const auto b = build(4, 3, 5);
  const auto& m = b.mesh;
  ASSERT_EQ(m.patches.size(), 3u);
  int next = m.n_internal_faces();
  for (const auto& p : m.patches) {
    EXPECT_EQ(p.start, next) << p.name;
    next += p.size;
  }
  EXPECT_EQ(next, m.n_faces());
  const auto& wall = m.patch("wall");
  EXPECT_EQ(wall.type, "wall");
  EXPECT_EQ(wall.size, 4 * 4 * 5);
  std::set<int> used;
  for (const auto& f : m.faces) used.insert(f.begin(), f.end());
  EXPECT_EQ(used.size(), m.points.size()) << "every point belongs to a face";
}

// Where the wall's nodes sit, and the cross-section's hydraulic diameter 4A/P (volume over wall
// area, times 4): the vessel's d on the circumscribed polygon, whose faces touch the circle at
// their middles, so the balance tau_w = d dP/(4l) holds on it; d cos(pi/n) on the inscribed one.
TEST(VesselMesh, WallPolygonTouchesOrIsInscribedInTheCircleAndHasTheHydraulicDiameterItSays) {
  const auto v = paper_vessel();
  const double R = v.radius();
  for (const std::string polygon : {"circumscribed", "inscribed"}) {
    for (int n : {1, 4, 8}) {
      const auto b = build(n, 3, 5, v, polygon);
      const auto& m = b.mesh;
      const auto& wall = m.patch("wall");
      hemo::MeshSpec spec;
      spec.core_cells = n;
      hemo::choice_named(polygon, spec.wall_polygon);
      const double corner = polygon == "inscribed" ? R : R / std::cos(kPi / (4 * n));
      EXPECT_NEAR(spec.wall_corner_radius() * R, corner, 1e-15);
      double wall_area = 0, volume = 0;
      for (int f = wall.start; f < wall.start + wall.size; ++f) {
        for (int p : m.faces[f]) EXPECT_NEAR(std::hypot(m.points[p][0], m.points[p][1]), corner, 1e-15) << polygon;
        // The face's plane is at R (circumscribed) or R cos(pi/n) (inscribed) from the axis.
        const auto& c = b.geo.face_centres[f];
        EXPECT_NEAR(std::hypot(c[0], c[1]), corner * std::cos(kPi / (4 * n)), 1e-15) << polygon;
        wall_area += norm(b.geo.face_areas[f]);
      }
      for (double vol : b.geo.cell_volumes) volume += vol;
      EXPECT_NEAR(4 * volume / wall_area / v.diameter, spec.hydraulic_diameter_ratio(), 1e-12) << polygon << " " << n;
      EXPECT_NEAR(spec.hydraulic_diameter_ratio(), polygon == "inscribed" ? std::cos(kPi / (4 * n)) : 1.0, 1e-15);
    }
  }
}

TEST(VesselMesh, CyclicFacesArePairedOneLengthApart) {
  const auto v = paper_vessel();
  const auto b = build(4, 3, 7);
  const auto& m = b.mesh;
  const auto& in = m.patch("inlet");
  const auto& out = m.patch("outlet");
  EXPECT_EQ(in.type, "cyclic");
  EXPECT_EQ(in.neighbour, "outlet");
  EXPECT_EQ(out.neighbour, "inlet");
  EXPECT_DOUBLE_EQ(in.separation[2], v.length);
  EXPECT_DOUBLE_EQ(out.separation[2], -v.length);
  ASSERT_EQ(in.size, out.size);
  ASSERT_EQ(in.size, 4 * 4 + 4 * 4 * 3);
  for (int i = 0; i < in.size; ++i) {
    const int fi = in.start + i, fo = out.start + i;
    const Vec3& ci = b.geo.face_centres[fi];
    const Vec3& co = b.geo.face_centres[fo];
    EXPECT_NEAR(co[0], ci[0], 1e-18);
    EXPECT_NEAR(co[1], ci[1], 1e-18);
    EXPECT_NEAR(ci[2], 0.0, 1e-18);
    EXPECT_NEAR(co[2] - ci[2], v.length, 1e-15);
    // Same first point (shifted by the length), opposite orientation.
    const Vec3& p0 = m.points[m.faces[fi][0]];
    const Vec3& q0 = m.points[m.faces[fo][0]];
    EXPECT_EQ(p0[0], q0[0]);
    EXPECT_EQ(p0[1], q0[1]);
    EXPECT_LT(b.geo.face_areas[fi][2], 0);
    EXPECT_GT(b.geo.face_areas[fo][2], 0);
    EXPECT_NEAR(b.geo.face_areas[fi][2], -b.geo.face_areas[fo][2], 1e-24);
  }
}

TEST(VesselMesh, CellsAreNotBadlySkewed) {
  // Face non-orthogonality (angle between the owner-neighbour line and the face normal).
  const auto b = build(4, 3, 24);
  double worst = 0;
  for (int f = 0; f < b.mesh.n_internal_faces(); ++f) {
    const Vec3 d = sub(b.geo.cell_centres[b.mesh.neighbour[f]], b.geo.cell_centres[b.mesh.owner[f]]);
    const double c = dot(d, b.geo.face_areas[f]) / (norm(d) * norm(b.geo.face_areas[f]));
    worst = std::max(worst, std::acos(std::min(1.0, c)) * 180 / kPi);
  }
  EXPECT_LT(worst, 40.0);
}

TEST(VesselMesh, HashIsAFingerprintOfTheGeometry) {
  const auto a = build(4, 3, 24);
  const auto same = build(4, 3, 24);
  const auto other = build(4, 3, 23);
  const auto h = hemo::mesh_hash(a.mesh);
  EXPECT_EQ(h.size(), 16u);
  EXPECT_EQ(h, hemo::mesh_hash(same.mesh));
  EXPECT_NE(h, hemo::mesh_hash(other.mesh));
  const auto longer = build(4, 3, 24, hemo::Vessel{100e-6, 601e-6});
  EXPECT_NE(h, hemo::mesh_hash(longer.mesh));
}

// The straight tube's mesh is the one generated before vessel shapes, to the bit: these are the
// fingerprints of the generator as it was (main at 9dc7f7d), points, faces and patches.
TEST(VesselMesh, StraightTubeIsTheMeshOfBeforeShapes) {
  EXPECT_EQ(hemo::mesh_hash(build(4, 3, 24).mesh), "c5301aeaa803253b");
  EXPECT_EQ(hemo::mesh_hash(build(4, 3, 24, paper_vessel(), "inscribed").mesh), "28ef864729be624c");
  EXPECT_EQ(hemo::mesh_hash(build(8, 6, 10).mesh), "0788ba1ba1b2a304");
  EXPECT_EQ(hemo::mesh_hash(build(8, 6, 10, paper_vessel(), "inscribed").mesh), "57aa143bd93d7b78");
}

hemo::Vessel stenosed_vessel() {
  hemo::Vessel v{100e-6, 1200e-6};
  v.shape = "stenosis";
  v.stenosis_area_reduction = 0.5;
  v.stenosis_length = 600e-6;
  return v;
}

// Each axial station is the straight section scaled to the local radius: the wall polygon's
// corners at R(z) / cos(pi/n) (its sides tangent to the station's circle), every point's radius
// R(z)/R0 of the straight mesh's; the cells stay closed with positive volumes.
TEST(VesselMesh, StenosisScalesEachStationToTheLocalRadius) {
  const auto v = stenosed_vessel();
  const auto g = hemo::make_vessel_geometry(v);
  const auto straight = build(4, 3, 24, hemo::Vessel{100e-6, 1200e-6});
  const auto b = build(4, 3, 24, v);
  ASSERT_EQ(b.mesh.points.size(), straight.mesh.points.size());
  EXPECT_EQ(b.mesh.faces, straight.mesh.faces);
  for (std::size_t i = 0; i < b.mesh.points.size(); ++i) {
    const auto& p = b.mesh.points[i];
    const auto& q = straight.mesh.points[i];
    EXPECT_EQ(p[2], q[2]);
    EXPECT_NEAR(std::hypot(p[0], p[1]), std::hypot(q[0], q[1]) * g->radius_at(p[2]) / v.radius(), 1e-18);
  }
  const auto& wall = b.mesh.patch("wall");
  for (int f = wall.start; f < wall.start + wall.size; ++f)
    for (int p : b.mesh.faces[f]) {
      const auto& x = b.mesh.points[p];
      EXPECT_NEAR(std::hypot(x[0], x[1]), g->radius_at(x[2]) / std::cos(kPi / 16), 1e-15);
    }
  for (double vol : b.geo.cell_volumes) EXPECT_GT(vol, 0);
}

// The mesh's volume converges to the shape's, times the tangent polygon's area over the circle's,
// as the stations get closer (second order: R^2 between stations is the chord of a smooth curve).
TEST(VesselMesh, StenosisVolumeConvergesToTheShapesOnThePolygon) {
  const auto v = stenosed_vessel();
  const double polygon = 16 * std::tan(kPi / 16) / kPi;
  const double exact = polygon * hemo::make_vessel_geometry(v)->volume();
  double previous = 1;
  for (int axial : {12, 24, 48, 96}) {
    double total = 0;
    for (double vol : build(4, 3, axial, v).geo.cell_volumes) total += vol;
    const double error = std::abs(total / exact - 1);
    std::printf("  axial %3d: mesh volume / shape's on the polygon - 1 = %.3e\n", axial, total / exact - 1);
    EXPECT_LT(error, previous / 3.5) << axial;
    previous = error;
  }
  EXPECT_LT(previous, 1e-4);
}

TEST(VesselMesh, MessageCarriesTheMesh) {
  const auto b = build(4, 3, 4);
  hemo::mesh_t msg;
  hemo::fill_mesh_message(b.mesh, b.geo, paper_vessel(), msg);
  EXPECT_EQ(msg.mesh_hash, hemo::mesh_hash(b.mesh));
  EXPECT_EQ(msg.n_points, static_cast<int>(b.mesh.points.size()));
  EXPECT_EQ(msg.points.size(), b.mesh.points.size());
  EXPECT_EQ(msg.n_faces, b.mesh.n_faces());
  EXPECT_EQ(msg.face_offsets.size(), b.mesh.faces.size());
  EXPECT_EQ(msg.n_face_points, 4 * msg.n_faces);
  EXPECT_EQ(static_cast<int>(msg.face_points.size()), msg.n_face_points);
  EXPECT_EQ(msg.n_internal_faces, static_cast<int>(msg.neighbour.size()));
  EXPECT_EQ(msg.n_cells, b.mesh.n_cells);
  EXPECT_EQ(static_cast<int>(msg.cell_centres.size()), msg.n_cells);
  EXPECT_EQ(static_cast<int>(msg.cell_volumes.size()), msg.n_cells);
  EXPECT_EQ(msg.n_patches, 3);
  EXPECT_EQ(msg.patch_types[1], "cyclic");
  EXPECT_DOUBLE_EQ(msg.vessel_length_m, 600e-6);
  // It encodes (sizes consistent with the counts).
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  EXPECT_EQ(msg.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
}

TEST(VesselMesh, WritesPolyMesh) {
  const auto b = build(2, 1, 2);
  const auto dir = std::filesystem::temp_directory_path() / "hemocosim_test_polymesh";
  std::filesystem::remove_all(dir);
  hemo::write_polymesh(b.mesh, dir.string());
  for (const char* f : {"points", "faces", "owner", "neighbour", "boundary"})
    EXPECT_TRUE(std::filesystem::exists(dir / "constant" / "polyMesh" / f)) << f;
  std::ifstream in(dir / "constant" / "polyMesh" / "boundary");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("neighbourPatch  outlet;"), std::string::npos);
  EXPECT_NE(text.find("transform       translational;"), std::string::npos);
  std::filesystem::remove_all(dir);
}

hemo::Vessel open_vessel(const std::string& inlet) {
  hemo::Vessel v = paper_vessel();
  v.ends = "open";
  v.inlet = inlet;
  return v;
}

// Open ends change the ends' patches only: the vessel's points, faces and cells are the periodic
// vessel's, its inlet and outlet plain patches (the inlet a mapped one with a feeder).
TEST(VesselMesh, OpenEndsAreTheVesselsMeshWithPatchesForEnds) {
  const auto periodic = build(4, 3, 6);
  for (const std::string inlet : {"poiseuille", "feeder"}) {
    const auto open = build(4, 3, 6, open_vessel(inlet));
    ASSERT_GE(open.mesh.n_cells, periodic.mesh.n_cells);
    for (int c = 0; c < periodic.mesh.n_cells; ++c)
      for (int d = 0; d < 3; ++d)
        EXPECT_EQ(open.geo.cell_centres[c][d], periodic.geo.cell_centres[c][d]) << inlet << " cell " << c;
    EXPECT_EQ(open.mesh.patch("inlet").type, inlet == "feeder" ? "mappedPatch" : "patch");
    EXPECT_EQ(open.mesh.patch("outlet").type, "patch");
    EXPECT_EQ(open.mesh.patch("inlet").size, periodic.mesh.patch("inlet").size);
    EXPECT_NE(hemo::mesh_hash(open.mesh), hemo::mesh_hash(periodic.mesh));
    int next = open.mesh.n_internal_faces();
    for (const auto& p : open.mesh.patches) {
      EXPECT_EQ(p.start, next) << p.name;
      next += p.size;
    }
    EXPECT_EQ(next, open.mesh.n_faces());
  }
  EXPECT_TRUE(build(4, 3, 6, open_vessel("poiseuille")).mesh.cell_zones.empty());
}

// The feeder: a straight periodic tube of the inlet's radius beside the vessel, in layers as long
// as the vessel's, the vessel's length and the fewest whole layers spanning d beyond it, its cells a zone after the vessel's and connected to none of them; the
// point each inlet face samples lies in the feeder's last layer, in the cell of the same section
// position as the face's own cell.
TEST(VesselMesh, FeederIsADisconnectedPeriodicTubeTheInletSamples) {
  const auto b = build(4, 3, 6, open_vessel("feeder"));
  const auto& m = b.mesh;
  // The vessel's 6 layers of 100 um and one more, spanning d = 100 um.
  const int section = 64, vessel_cells = section * 6, feeder_layers = 7;
  ASSERT_EQ(m.cell_zones.size(), 1u);
  const auto& zone = m.cell_zones[0];
  EXPECT_EQ(zone.name, hemo::feeder_zone);
  EXPECT_EQ(zone.first, vessel_cells);
  EXPECT_EQ(zone.size, section * feeder_layers);
  EXPECT_EQ(m.n_cells, vessel_cells + zone.size);
  for (int f = 0; f < m.n_internal_faces(); ++f)
    EXPECT_EQ(m.owner[f] < vessel_cells, m.neighbour[f] < vessel_cells) << "face " << f << " joins the regions";
  const auto& fi = m.patch("feeder_inlet");
  const auto& fo = m.patch("feeder_outlet");
  EXPECT_EQ(fi.type, "cyclic");
  EXPECT_EQ(fi.neighbour, "feeder_outlet");
  EXPECT_EQ(fo.neighbour, "feeder_inlet");
  EXPECT_NEAR(fi.separation[2], 700e-6, 1e-18);
  EXPECT_EQ(m.patch("feeder_wall").type, "wall");
  const double axis = 150e-6;  // 3 R0
  for (int c = zone.first; c < zone.first + zone.size; ++c)
    EXPECT_LT(std::hypot(b.geo.cell_centres[c][0] - axis, b.geo.cell_centres[c][1]), 52e-6);
  // Sampled points: in the last layer, above the inlet face's own cell's section position.
  const auto& inlet = m.patch("inlet");
  const int last_layer_first = zone.first + zone.size - section;
  for (int i = 0; i < inlet.size; ++i) {
    const int f = inlet.start + i;
    const Vec3 sample{b.geo.face_centres[f][0] + inlet.sample_offset[0],
                      b.geo.face_centres[f][1] + inlet.sample_offset[1],
                      b.geo.face_centres[f][2] + inlet.sample_offset[2]};
    const int expected = last_layer_first + m.owner[f];  // the inlet's cells are layer 0: q itself
    // The nearest cell centre of the feeder is the expected one (the cells are convex prisms of the
    // same section, the sample sits at mid-layer above a point inside the quad).
    int nearest = -1;
    double best = 1e300;
    for (int c = zone.first; c < zone.first + zone.size; ++c) {
      const double d = norm(sub(b.geo.cell_centres[c], sample));
      if (d < best) {
        best = d;
        nearest = c;
      }
    }
    EXPECT_EQ(nearest, expected) << "inlet face " << i;
    EXPECT_NEAR(sample[2], b.geo.cell_centres[expected][2], 1e-12);
  }
}

// Every registered shape takes open ends and a feeder: its vessel region is the periodic
// vessel's, cell by cell, and the feeder's radius is the shape's at the inlet.
TEST(VesselMesh, EveryShapeOpensWithAFeederOfItsInletsRadius) {
  for (const auto& shape : hemo::vessel_shapes()) {
    if (shape.surface()) continue;  // no O-grid: snappyHexMesh meshes it (test_surface_mesh.cpp)
    const std::string text = "[vessel]\ndiameter_um = 100\nlength_um = 600\nshape = \"" + shape.name + "\"\n" +
                             shape.example + "\n[driving]\nwall_shear_rate_per_s = 799\n";
    hemo::Vessel v = hemo::load_scene(hemo::test::write_temp(text)).vessel;
    const auto periodic = build(4, 3, 12, v);
    v.ends = "open";
    const auto open = build(4, 3, 12, v);
    for (int c = 0; c < periodic.mesh.n_cells; ++c)
      EXPECT_EQ(open.geo.cell_volumes[c], periodic.geo.cell_volumes[c]) << shape.name << " cell " << c;
    ASSERT_EQ(open.mesh.cell_zones.size(), 1u) << shape.name;
    // The feeder's wall: its faces' centres touch the circle of R(0) (the circumscribed polygon).
    const auto& wall = open.mesh.patch("feeder_wall");
    const double inlet_radius = hemo::make_vessel_geometry(v)->radius_at(0);
    double nearest = 1e300;
    for (int f = wall.start; f < wall.start + wall.size; ++f)
      nearest = std::min(nearest, std::hypot(open.geo.face_centres[f][0] - 150e-6, open.geo.face_centres[f][1]));
    EXPECT_NEAR(nearest, inlet_radius, 1e-3 * inlet_radius) << shape.name;
  }
}

TEST(VesselMesh, WritesTheMappedInletAndTheFeedersZone) {
  const auto b = build(2, 1, 2, open_vessel("feeder"));
  const auto dir = std::filesystem::temp_directory_path() / "hemocosim_test_polymesh_open";
  std::filesystem::remove_all(dir);
  hemo::write_polymesh(b.mesh, dir.string());
  auto read = [&](const char* name) {
    std::ifstream in(dir / "constant" / "polyMesh" / name);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const std::string boundary = read("boundary"), zones = read("cellZones");
  EXPECT_NE(boundary.find("type            mappedPatch;"), std::string::npos);
  EXPECT_NE(boundary.find("sampleMode      nearestCell;"), std::string::npos);
  EXPECT_NE(boundary.find("neighbourPatch  feeder_outlet;"), std::string::npos);
  EXPECT_NE(zones.find("feeder\n{\n    type            cellZone;"), std::string::npos);
  // A periodic mesh written over it takes the zones away.
  hemo::write_polymesh(build(2, 1, 2).mesh, dir.string());
  EXPECT_FALSE(std::filesystem::exists(dir / "constant" / "polyMesh" / "cellZones"));
  std::filesystem::remove_all(dir);
}

TEST(VesselMesh, RefusesImpossibleInput) {
  EXPECT_THROW(hemo::make_vessel_mesh(hemo::Vessel{0, 1e-4}, hemo::MeshSpec{}), std::invalid_argument);
  EXPECT_THROW(hemo::make_vessel_mesh(paper_vessel(), hemo::MeshSpec{0, 3, 2}), std::invalid_argument);
  EXPECT_THROW(hemo::make_vessel_mesh(paper_vessel(), hemo::MeshSpec{}, hemo::OGridShape{0.8, 0.4}),
               std::invalid_argument);
}

}  // namespace
