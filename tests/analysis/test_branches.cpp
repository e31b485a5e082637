// SPDX-License-Identifier: GPL-3.0-or-later
// The observables along a bifurcation's branches (BranchAccumulator) on synthetic snapshots with
// answers known by hand: where each branch's sections are its own, the cell-free layer per slice
// in a branch's own coordinates, and that in the parent it is the straight tube's edge method.
#include "observables.h"
#include "synthetic.h"

#include <bifurcation.h>
#include <surface_wall.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace hemo::analysis;
using namespace hemo::analysis::test;
using Point = hemo::VesselWall::Point;

namespace {

constexpr double kRbcDiameter = 5.56e-6;
constexpr double kParentLength = 200e-6, kDaughterLength = 300e-6, kAngle = kPi / 3;

// A 40-um parent, Murray's daughters (31.7 um) at 60 degrees.
hemo::BifurcationWall bifurcation() {
  hemo::BifurcationSpec spec;
  spec.parent_diameter = 40e-6;
  spec.parent_length = kParentLength;
  spec.daughter_length = kDaughterLength;
  spec.angle = kAngle;
  return hemo::BifurcationWall(spec);
}

void add_rbc(Snapshot& s, std::int64_t id, const Point& x) {
  s.id.push_back(id);
  s.species.push_back(kRbc);
  s.position.insert(s.position.end(), {x.x(), x.y(), x.z()});
  s.velocity.insert(s.velocity.end(), {0.0, 0.0, 0.0});
}

}  // namespace

// The parent's sections are all its own: the daughters' tubes come no nearer its circle than
// R_p cos(theta/2) = 17.3 um from their axes, beyond their 15.9-um radius. A daughter's section at
// s from the junction meets the other daughter's tube until its circle's nearest point is r from
// that axis: s^2 + r^2 - (s cos theta + r sin theta)^2 = r^2, i.e. s = r cot(theta/2) (27.5 um);
// the parent's tube lets go of it earlier (sqrt(R_p^2 - r^2) = 12.2 um). Both run to their outlets.
TEST(BranchObservables, EachBranchsOwnSectionsRunFromWhereNoOtherTubeMeetsThem) {
  const auto wall = bifurcation();
  const auto branches = wall.branches();
  ASSERT_EQ(branches.size(), 3u);
  const double r = branches[1].radius;
  EXPECT_NEAR(r, 20e-6 / std::cbrt(2.0), 1e-15);
  const BranchSpan parent = own_section_span(wall, 0);
  EXPECT_EQ(parent.start, 0);
  EXPECT_EQ(parent.end, kParentLength);
  for (int b : {1, 2}) {
    const BranchSpan d = own_section_span(wall, b);
    EXPECT_NEAR(d.start, r / std::tan(kAngle / 2), 2e-4 * r) << b;
    EXPECT_NEAR(d.end, kDaughterLength, 1e-15) << b;
  }
}

// Four slices along each branch, one sector. The parent (slices of 50 um): a red cell 3 um from
// the wall in slice 0, then 5 um (and one on the axis, which moves no edge): δ = 4 um; 2 um in
// slice 2 at both snapshots; slices 1 and 3 empty. Daughter 1: 1.5 um from its own wall (in its
// own section, off its axis along y) in its slice 1. Daughter 2: one cell on its axis 10 um from the
// junction, inside it but short of its span: counted nowhere. The branch's δ is the mean over its
// occupied slices and snapshots: (3 + 5 + 2 + 2) / 4 um in the parent.
TEST(BranchObservables, CellFreeLayerPerSliceInEachBranchsOwnSections) {
  const auto wall = bifurcation();
  const auto branches = wall.branches();
  const double Rp = branches[0].radius, rd = branches[1].radius, half = kRbcDiameter / 2;
  const Point junction(0, 0, kParentLength);
  const Point d1 = hemo::daughter_direction(wall.spec(), 0), d2 = hemo::daughter_direction(wall.spec(), 1);
  const BranchSpan span1 = own_section_span(wall, 1);
  const double width1 = span1.length() / 4;
  BranchAccumulator acc(wall, 4, 1, kRbcDiameter);
  for (int k = 0; k < 2; ++k) {
    Snapshot s;
    s.time_s = 0.01 * k;
    const double gap0 = k == 0 ? 3e-6 : 5e-6;
    add_rbc(s, 1, Point(0, Rp - half - gap0, 25e-6));
    add_rbc(s, 2, Point(0, 0, 30e-6));
    add_rbc(s, 3, Point(-(Rp - half - 2e-6), 0, 125e-6));
    add_rbc(s, 4, junction + (span1.start + 1.5 * width1) * d1 + Point(0, rd - half - 1.5e-6, 0));
    add_rbc(s, 5, junction + 10e-6 * d2);
    ASSERT_EQ(wall.branch_at(junction + 10e-6 * d2), 2);
    acc.add(s);
  }
  const auto layers = acc.result();
  ASSERT_EQ(layers.size(), 3u);
  const BranchLayer& p = layers[0];
  EXPECT_EQ(p.name, "parent");
  EXPECT_EQ(layers[1].name, "daughter_1");
  EXPECT_EQ(layers[2].name, "daughter_2");
  EXPECT_EQ(p.stations.axial, 4);
  EXPECT_EQ(p.stations.sectors, 1);
  ASSERT_EQ(p.s.size(), 4u);
  EXPECT_NEAR(p.s[0], 25e-6, 1e-15);
  EXPECT_NEAR(p.s[3], 175e-6, 1e-15);
  EXPECT_NEAR(p.station[0].thickness, 4e-6, 1e-12);
  EXPECT_NEAR(p.station[2].thickness, 2e-6, 1e-12);
  EXPECT_TRUE(std::isnan(p.station[1].thickness));
  EXPECT_TRUE(std::isnan(p.station[3].thickness));
  EXPECT_EQ(p.station[1].empty_samples, 2);
  EXPECT_NEAR(p.whole.thickness, 3e-6, 1e-12);
  EXPECT_EQ(p.whole.samples, 4);
  EXPECT_DOUBLE_EQ(p.mean_rbc_count, 3);

  const BranchLayer& a = layers[1];
  EXPECT_NEAR(a.s[1], span1.start + 1.5 * width1, 1e-15);
  EXPECT_NEAR(a.station[1].thickness, 1.5e-6, 1e-12);
  EXPECT_NEAR(a.whole.thickness, 1.5e-6, 1e-12);
  EXPECT_DOUBLE_EQ(a.mean_rbc_count, 1);

  const BranchLayer& b = layers[2];
  EXPECT_TRUE(std::isnan(b.whole.thickness));
  EXPECT_EQ(b.whole.samples, 0);
  EXPECT_DOUBLE_EQ(b.mean_rbc_count, 0);
}

// In the parent, whose axis is the z axis from z = 0, the branch's layer is the straight tube's
// edge method (rbc_core_edges and cfl_thickness_edge over slices x sectors of the parent's tube) on
// the same cells; with no sectors asked for, they are sized to about kRbcsPerStation red cells each.
TEST(BranchObservables, InTheParentTheLayerIsTheStraightTubesEdgeMethod) {
  const auto wall = bifurcation();
  const double Rp = wall.branches()[0].radius;
  const Tube parent{Rp, kParentLength};
  const Stations stations{4, 6};
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  BranchAccumulator acc(wall, stations.axial, stations.sectors, kRbcDiameter);
  BranchAccumulator sized(wall, stations.axial, 0, kRbcDiameter);
  std::vector<StationEdges> straight;
  constexpr int kCells = 240;
  for (int k = 0; k < 3; ++k) {
    Snapshot s;
    for (int i = 0; i < kCells; ++i)
      add_particle(s, i, kRbc, (Rp - kRbcDiameter / 2 - 1e-6) * std::sqrt(u(rng)), 2 * kPi * u(rng),
                   0.9 * kParentLength * u(rng));
    acc.add(s);
    sized.add(s);
    straight.push_back(rbc_core_edges(select_species(s, kRbc), kRbcDiameter, parent, stations));
  }
  const CflThickness expected = cfl_thickness_edge(straight, parent);
  const BranchLayer layer = acc.result()[0];
  EXPECT_NEAR(layer.whole.thickness, expected.thickness, 1e-15);
  EXPECT_EQ(layer.whole.samples, expected.samples);
  EXPECT_EQ(layer.whole.empty_samples, expected.empty_samples);
  EXPECT_GT(expected.samples, 0);
  EXPECT_EQ(sized.result()[0].stations.sectors, std::lround(kCells / (stations.axial * kRbcsPerStation)));
}

// What passes an end, per blood volume: the platelets' counterpart of H_D.
TEST(BranchObservables, DischargePlateletDensityIsTheRateOverTheBloodsFlux) {
  EndFlux e{"outlet_1", 4e-11, 1e5, 2e4, 1e5 * 90e-18, 2e4 * 6e-18};
  EXPECT_DOUBLE_EQ(e.discharge_platelet_density(), 2e4 / (4e-11 + 9e-12 + 1.2e-13));
  EXPECT_TRUE(std::isnan(EndFlux{"outlet_2"}.discharge_platelet_density()));
}

// An imported surface's branches (SurfaceWall: each open end's straight stretch) are measured
// like the generated bifurcation's: the imported copy of the 40-um bifurcation's surface gives
// three branches whose own sections span their whole stretch (each stretch already ends where
// the wall leaves its tube), and a red cell 3 um from daughter 1's wall mid-stretch gives that
// daughter a 3-um layer.
TEST(BranchObservables, AnImportedSurfacesBranchesAreMeasuredAlongTheirStretches) {
  hemo::BifurcationSpec spec;
  spec.parent_diameter = 40e-6;
  spec.parent_length = kParentLength;
  spec.daughter_length = kDaughterLength;
  spec.angle = kAngle;
  const hemo::SurfaceWall wall(hemo::make_bifurcation(spec));
  const auto branches = wall.branches();
  ASSERT_EQ(branches.size(), 3u);
  for (int b = 0; b < 3; ++b) {
    const auto& br = branches[static_cast<std::size_t>(b)];
    const BranchSpan span = own_section_span(wall, b);
    EXPECT_EQ(span.start, 0) << b;
    EXPECT_NEAR(span.end, (br.end - br.start).norm(), br.radius / 10) << b;
  }
  const auto& d1 = branches[1];
  const Point axis = (d1.end - d1.start).normalized();
  const Point across = axis.unitOrthogonal();
  const double length = (d1.end - d1.start).norm();
  BranchAccumulator acc(wall, 1, 1, kRbcDiameter);
  Snapshot s;
  add_rbc(s, 1, d1.start + 0.5 * length * axis + (d1.radius - kRbcDiameter / 2 - 3e-6) * across);
  ASSERT_EQ(wall.branch_at(d1.start + 0.5 * length * axis), 1);
  acc.add(s);
  const auto layers = acc.result();
  ASSERT_EQ(layers.size(), 3u);
  EXPECT_EQ(layers[1].name, "daughter_1");
  EXPECT_NEAR(layers[1].whole.thickness, 3e-6, 1e-12);
  EXPECT_DOUBLE_EQ(layers[1].mean_rbc_count, 1);
}
