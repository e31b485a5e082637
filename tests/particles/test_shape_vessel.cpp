// SPDX-License-Identifier: GPL-3.0-or-later
// The particle node in a vessel shape that narrows (model/geometry.h): the cell locator's wall
// gap follows R(z), placement keeps every particle inside the local wall, and on the straight
// tube both give what the fixed radius gave, to the bit.
#include "cell_locator.h"

#include <geometry.h>
#include <placement.h>
#include <scene.h>
#include <vessel_mesh.h>
#include <hemo/mesh_t.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

using namespace hemo::particles;

namespace {

constexpr double kPi = 3.14159265358979323846;

hemo::mesh_t mesh_message(const hemo::Vessel& vessel, const hemo::MeshSpec& spec) {
  const auto poly = hemo::make_vessel_mesh(vessel, spec);
  hemo::mesh_t message;
  hemo::fill_mesh_message(poly, hemo::compute_geometry(poly), vessel, message);
  return message;
}

hemo::Vessel stenosed(double diameter, double length, double area_reduction, double constriction) {
  hemo::Vessel v{diameter, length};
  v.shape = "stenosis";
  v.stenosis_area_reduction = area_reduction;
  v.stenosis_length = constriction;
  return v;
}

}  // namespace

// On the inscribed polygon each wall face's corners lie on r = R(z) at its own station: the
// points between a face and the local wall are in the wall gap of that face's cell, points
// beyond R(z) in none. At the throat, a point at 0.999 R(z) between two corners is in no cell
// (behind the chord) and found in the gap; at 1.001 R(z) it is outside. The fixed-radius locator
// (no shape) would miss the first: its circle is R0, and the throat's faces are no chords of it.
TEST(ShapeLocator, WallGapFollowsTheLocalRadius) {
  const auto vessel = stenosed(100e-6, 600e-6, 0.5, 300e-6);
  const hemo::MeshSpec spec{4, 3, 48, hemo::WallPolygon::inscribed};
  const auto message = mesh_message(vessel, spec);
  std::shared_ptr<const hemo::VesselGeometry> geometry = hemo::make_vessel_geometry(vessel);
  const CellLocator locator(message, geometry);
  EXPECT_GT(locator.wall_gap(), 0);
  int found = 0;
  for (double z : {300e-6, 250e-6, 100e-6, 3e-6}) {  // throat, flank, straight part, near the periodic end
    const double R = geometry->radius_at(z);
    const double theta = kPi / 16;  // between two of the 16 wall corners: furthest behind the chord
    const Vec3 in(0.999 * R * std::cos(theta), 0.999 * R * std::sin(theta), z);
    const Vec3 out(1.001 * R * std::cos(theta), 1.001 * R * std::sin(theta), z);
    EXPECT_EQ(locator.locate(in), -1) << z;
    const int cell = locator.locate_in_wall_gap(in);
    EXPECT_GE(cell, 0) << z;
    if (cell >= 0) {
      ++found;
      EXPECT_LT((locator.centre(cell) - in).head<2>().norm(), 0.3 * R) << z;  // a wall cell, beside the point
      EXPECT_LT(std::abs(locator.centre(cell).z() - z), 600e-6 / 48) << z;
    }
    EXPECT_EQ(locator.locate_in_wall_gap(out), -1) << z;
    EXPECT_EQ(locator.section(Vec3(0, 0, z)).radius, R);
  }
  EXPECT_EQ(found, 4);
  const CellLocator fixed(message);  // the mesh's diameter alone: the straight tube's R0
  const double Rt = geometry->throat_radius();
  EXPECT_EQ(fixed.locate_in_wall_gap(Vec3(0.999 * Rt * std::cos(kPi / 16), 0.999 * Rt * std::sin(kPi / 16), 300e-6)), -1);
}

// The straight tube given as a shape is the locator of before shapes: the same gap, the same
// answers.
TEST(ShapeLocator, StraightShapeIsTheFixedRadius) {
  const hemo::Vessel vessel{100e-6, 600e-6};
  const auto message = mesh_message(vessel, {4, 3, 24, hemo::WallPolygon::inscribed});
  const CellLocator fixed(message);
  const CellLocator shaped(message, hemo::make_vessel_geometry(vessel));
  EXPECT_EQ(fixed.wall_gap(), shaped.wall_gap());
  for (int i = 0; i < 2000; ++i) {
    const double r = 50e-6 * (0.98 + 0.03 * ((i * 7919) % 1000) / 1000.0), t = 0.0031 * i, z = 0.3e-6 * i;
    const Vec3 x(r * std::cos(t), r * std::sin(t), z);
    ASSERT_EQ(fixed.locate(x), shaped.locate(x)) << i;
    ASSERT_EQ(fixed.locate_in_wall_gap(x), shaped.locate_in_wall_gap(x)) << i;
  }
}

// Placement in the stenosis: every particle keeps its radius and the gap (2 % of its diameter)
// from the local wall, measured by the shape's signed distance; the throat gets particles too;
// reproducible. In the straight tube the shape's placement is the radius's, bit for bit.
TEST(ShapePlacement, KeepsEveryParticleInsideTheLocalWall) {
  const auto vessel = stenosed(100e-6, 600e-6, 0.6, 300e-6);
  const auto g = hemo::make_vessel_geometry(vessel);
  const std::vector<PlacementRequest> requests = {{kRbc, 8e-6, 600}, {kPlatelet, 2.5e-6, 300}};
  const auto placed = place_particles(*g, 0.0, requests, 11);
  ASSERT_EQ(placed.size(), 900u);
  int in_throat = 0;
  double closest = 1;
  for (const auto& p : placed) {
    const double clearance = -g->signed_distance(p.position) - p.diameter / 2;
    closest = std::min(closest, clearance / p.diameter);
    EXPECT_GE(clearance, 0.02 * p.diameter * (1 - 1e-9));
    in_throat += std::abs(p.position.z() - 300e-6) < 30e-6;
  }
  std::printf("  closest to the wall: %.4f diameters beyond the particle's own radius; %d in the throat\n", closest,
              in_throat);
  EXPECT_GT(in_throat, 0);
  const auto again = place_particles(*g, 0.0, requests, 11);
  for (std::size_t i = 0; i < placed.size(); ++i) ASSERT_EQ(placed[i].position, again[i].position);

  const hemo::Vessel straight{100e-6, 600e-6};
  const auto by_shape = place_particles(*hemo::make_vessel_geometry(straight), 0.0, requests, 11);
  const auto by_radius = place_particles(50e-6, 600e-6, 0.0, requests, 11);
  ASSERT_EQ(by_shape.size(), by_radius.size());
  for (std::size_t i = 0; i < by_shape.size(); ++i) ASSERT_EQ(by_shape[i].position, by_radius[i].position) << i;
}

// scenes/stenosis.toml: `hemocosim check` places its particles in the scene's shape from z = 0;
// the particle node in its locator's shape on the fluid node's mesh. One vessel, bit for bit.
TEST(ShapePlacement, TheCheckPlacesTheStenosisSceneAsTheNode) {
  const hemo::Scene scene = hemo::load_scene(std::string(HEMO_SCENES_DIR) + "/stenosis.toml");
  const CellLocator locator(mesh_message(scene.vessel, scene.mesh), hemo::make_vessel_geometry(scene.vessel));
  const auto requests = placement_requests(scene);
  const auto by_node = place_particles(*locator.axisymmetric(), locator.z0(), requests, scene.run.seed);
  const auto by_check = place_particles(*hemo::make_vessel_geometry(scene.vessel), 0.0, requests, scene.run.seed);
  ASSERT_EQ(static_cast<long>(by_node.size()), rbc_count(scene) + platelet_count(scene));
  ASSERT_EQ(by_node.size(), by_check.size());
  for (std::size_t i = 0; i < by_node.size(); ++i) ASSERT_EQ(by_node[i].position, by_check[i].position) << i;
}
