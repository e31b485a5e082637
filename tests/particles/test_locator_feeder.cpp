// SPDX-License-Identifier: GPL-3.0-or-later
// The cell locator on an open vessel's mesh with its feeder (model/vessel_ends.h, FeederLayout):
// two disconnected regions, periodic along z with the feeder's length, the feeder's wall gap
// measured around its own axis. The fluid node's own mesh, as the particle node receives it.
#include "cell_locator.h"

#include <geometry.h>
#include <scene.h>
#include <vessel_ends.h>
#include <vessel_mesh.h>
#include <hemo/mesh_t.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

using namespace hemo::particles;

namespace {

constexpr double kPi = 3.14159265358979323846;

// d = 100 um, L = 300 um in 6 layers of 50 um: the feeder is 8 layers, P = 400 um. Inscribed
// polygon: the wall's corners on the circle, so its faces are chords with a gap behind them.
const hemo::MeshSpec kSpec{4, 3, 6, hemo::WallPolygon::inscribed};

hemo::Vessel open_vessel() {
  hemo::Vessel v{100e-6, 300e-6};
  v.ends = "open";
  v.inlet = "feeder";
  return v;
}

struct OpenMesh {
  hemo::PolyMesh poly;
  hemo::MeshGeometry geometry;
  hemo::mesh_t message;
};

OpenMesh open_mesh(const hemo::Vessel& vessel) {
  OpenMesh m;
  m.poly = hemo::make_vessel_mesh(vessel, kSpec);
  m.geometry = hemo::compute_geometry(m.poly);
  hemo::fill_mesh_message(m.poly, m.geometry, vessel, m.message);
  return m;
}

const hemo::CellZone& feeder_zone(const hemo::PolyMesh& poly) {
  for (const auto& z : poly.cell_zones)
    if (z.name == hemo::feeder_zone) return z;
  throw std::runtime_error("no feeder zone");
}

Vec3 vec(const hemo::Vec3& p) { return Vec3(p[0], p[1], p[2]); }

}  // namespace

// Both regions: each cell's centre is in that cell. The period is the feeder's (P, not L): a
// point moved by +-P is in the cell it was in (a move by L would land two layers away).
TEST(FeederLocator, LocatesBothRegionsPeriodicWithTheFeedersLength) {
  const auto vessel = open_vessel();
  const auto mesh = open_mesh(vessel);
  const auto layout = hemo::feeder_layout(vessel, kSpec.axial_cells);
  ASSERT_NEAR(layout.period, 400e-6, 1e-15);
  const CellLocator locator(mesh.message, hemo::make_vessel_geometry(vessel), layout);
  EXPECT_EQ(locator.length(), layout.period);
  const auto& zone = feeder_zone(mesh.poly);
  ASSERT_GT(zone.first, 0);
  ASSERT_EQ(zone.first + zone.size, locator.n_cells());
  const Vec3 period(0, 0, layout.period);
  for (int c = 0; c < locator.n_cells(); ++c) {
    const Vec3 x = locator.centre(c);
    ASSERT_EQ(c >= zone.first, layout.in_feeder(x.x())) << c;
    EXPECT_EQ(locator.locate(x), c) << c;
    EXPECT_EQ(locator.locate(x + period), c) << c;
    EXPECT_EQ(locator.locate(x - period), c) << c;
  }
  // Points near the feeder's cyclic ends and their images across them.
  for (const double dz : {0.3e-6, layout.period - 0.3e-6}) {
    const Vec3 x(layout.axis_x + 10e-6, -5e-6, dz);
    const int c = locator.locate(x);
    EXPECT_GE(c, zone.first);
    EXPECT_EQ(locator.locate(x + period), c);
    EXPECT_EQ(locator.locate(x - period), c);
  }
}

// The vessel ends at its outlet, z = L: beside the feeder's last layers, (L, P), is no vessel.
TEST(FeederLocator, NothingBeyondTheVesselsOutlet) {
  const auto vessel = open_vessel();
  const auto mesh = open_mesh(vessel);
  const auto layout = hemo::feeder_layout(vessel, kSpec.axial_cells);
  const CellLocator locator(mesh.message, hemo::make_vessel_geometry(vessel), layout);
  const int feeder_first = feeder_zone(mesh.poly).first;
  for (const double z :
       {layout.vessel_length + 1e-6, 0.5 * (layout.vessel_length + layout.period), layout.period - 1e-6}) {
    for (const double x : {0.0, 0.9 * vessel.radius()}) {
      const Vec3 p(x, 0.1 * vessel.radius(), z);
      ASSERT_LT(p.x(), layout.split_x);
      EXPECT_EQ(locator.locate(p), -1) << x << " " << z;
      EXPECT_EQ(locator.locate_in_wall_gap(p), -1) << x << " " << z;
    }
    // The feeder beside it is there.
    EXPECT_GE(locator.locate(Vec3(layout.axis_x, 0.1 * vessel.radius(), z)), feeder_first) << z;
  }
  // Just inside the outlet: the vessel.
  const int c = locator.locate(Vec3(0, 0.1 * vessel.radius(), layout.vessel_length - 1e-6));
  EXPECT_GE(c, 0);
  EXPECT_LT(c, feeder_first);
}

// Each feeder wall face is a chord of the feeder's circle (radius R(0) around its axis): a point
// between it and the circle, radially behind the face's centre, is in no cell and in the gap of
// the face's own cell; just beyond the circle, in neither. The gap is the vessel's, R (1 -
// cos(pi / n)): a reach that missed the feeder's axis would be off by about n_x axis_x.
TEST(FeederLocator, TheFeedersWallGapIsAroundItsOwnAxis) {
  const auto vessel = open_vessel();
  const auto mesh = open_mesh(vessel);
  const auto layout = hemo::feeder_layout(vessel, kSpec.axial_cells);
  const CellLocator locator(mesh.message, hemo::make_vessel_geometry(vessel), layout);
  const double R = layout.radius;
  const double sag = R * (1 - std::cos(kPi / kSpec.wall_sides()));
  EXPECT_NEAR(locator.wall_gap(), sag, 1e-9 * R);
  const int feeder_first = feeder_zone(mesh.poly).first;
  const auto& wall = mesh.poly.patch(hemo::patch_name::feeder_wall);
  ASSERT_EQ(wall.size, kSpec.wall_sides() * hemo::feeder_axial_cells(vessel, kSpec.axial_cells));
  for (int f = wall.start; f < wall.start + wall.size; ++f) {
    // The face's centre is its chord's middle; the circle is its own gap beyond, along the normal.
    const Vec3 centre = vec(mesh.geometry.face_centres[f]);
    const Vec3 out = vec(mesh.geometry.face_areas[f]).normalized();
    const double gap = R - out.dot(centre - Vec3(layout.axis_x, 0, centre.z()));
    ASSERT_GT(gap, 0.5 * sag) << f;
    const Vec3 behind = centre + 0.5 * gap * out;
    const Vec3 beyond = centre + (gap + 0.01 * sag) * out;
    ASSERT_GT(std::hypot(beyond.x() - layout.axis_x, beyond.y()), R) << f;
    ASSERT_EQ(locator.locate(behind), -1) << f;
    const int c = locator.locate_in_wall_gap(behind);
    EXPECT_EQ(c, mesh.poly.owner[f]) << f;
    EXPECT_GE(c, feeder_first) << f;
    EXPECT_EQ(locator.locate_in_wall_gap(behind + Vec3(0, 0, layout.period)), c) << f;
    EXPECT_EQ(locator.locate(beyond), -1) << f;
    EXPECT_EQ(locator.locate_in_wall_gap(beyond), -1) << f;
  }
}

// The frame: a feeder point stands for the inlet-plane point at its offset from the axis, with
// the inlet's radius; a vessel point is itself. Without a feeder, every point is itself.
TEST(FeederLocator, TheVesselFrame) {
  const auto vessel = open_vessel();
  const auto mesh = open_mesh(vessel);
  const auto layout = hemo::feeder_layout(vessel, kSpec.axial_cells);
  const CellLocator locator(mesh.message, hemo::make_vessel_geometry(vessel), layout);
  const Vec3 fed(layout.axis_x + 7e-6, -3e-6, 123e-6);
  EXPECT_EQ(locator.in_vessel_frame(fed), Vec3(fed.x() - layout.axis_x, -3e-6, 0));
  EXPECT_EQ(locator.section(fed).radius, layout.radius);
  const Vec3 in_vessel(7e-6, -3e-6, 123e-6);
  EXPECT_EQ(locator.in_vessel_frame(in_vessel), in_vessel);
  const hemo::Vessel periodic{100e-6, 300e-6};
  const CellLocator plain(open_mesh(periodic).message, hemo::make_vessel_geometry(periodic));
  EXPECT_FALSE(plain.feeder().has_value());
  EXPECT_EQ(plain.in_vessel_frame(fed), fed);
}

// A mesh whose z extent is not the layout's period, or whose vessel is not the layout's, is
// refused; so is the feeder's mesh without its layout (its extent is P, its vessel length L).
TEST(FeederLocator, RefusesAMeshThatIsNotTheLayouts) {
  const auto vessel = open_vessel();
  const auto mesh = open_mesh(vessel);
  const std::shared_ptr<const hemo::VesselGeometry> geometry = hemo::make_vessel_geometry(vessel);
  const auto layout = hemo::feeder_layout(vessel, kSpec.axial_cells);
  EXPECT_NO_THROW(CellLocator(mesh.message, geometry, layout).n_cells());
  auto longer = layout;
  longer.period += layout.period / 8;  // one layer more than the mesh has
  EXPECT_THROW(CellLocator(mesh.message, geometry, longer), std::invalid_argument);
  const hemo::Vessel periodic{100e-6, 300e-6};  // no feeder: its extent is L
  EXPECT_THROW(CellLocator(open_mesh(periodic).message, geometry, layout), std::invalid_argument);
  auto shorter_vessel = layout;
  shorter_vessel.vessel_length -= 50e-6;
  EXPECT_THROW(CellLocator(mesh.message, geometry, shorter_vessel), std::invalid_argument);
  EXPECT_THROW(CellLocator(mesh.message, geometry), std::invalid_argument);
}
