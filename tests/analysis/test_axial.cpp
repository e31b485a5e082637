// SPDX-License-Identifier: GPL-3.0-or-later
// The observables along a vessel shape (AxialAccumulator) on synthetic snapshots with known
// answers: the cell-free layer and hematocrit per station against the local radius, the platelets
// near the wall and their arrivals at it.
#include "observables.h"
#include "synthetic.h"

#include <scene.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace hemo::analysis;
using namespace hemo::analysis::test;

namespace {

constexpr double kRbcDiameter = 5.56e-6, kRbcVolume = 94e-18, kPlateletDiameter = 2.5e-6;

std::unique_ptr<hemo::VesselGeometry> stenosis() {
  hemo::Vessel v{100e-6, 600e-6};
  v.shape = "stenosis";
  v.stenosis_area_reduction = 0.5;
  v.stenosis_length = 300e-6;
  return hemo::make_vessel_geometry(v);
}

}  // namespace

// 15 stations of 40 um: the throat (z = 300 um) is the middle one. Two RBCs in one sector of the
// throat's station, 3 and 7 um of gap from the local wall (R' = 0 there: the gap is radial), and
// one in another sector at 5 um: the station's CFL is the mean of its sectors' smallest gaps,
// (3 + 5) / 2 um, in both snapshots. In the straight part (z = 20 um) one RBC 2 um from R0. Every
// other station has no RBC: NaN. Hematocrit: the station's RBC volume over its volume.
TEST(AxialObservables, CellFreeLayerAndHematocritAgainstTheLocalRadius) {
  const auto g = stenosis();
  const Stations stations{15, 4};
  AxialAccumulator acc(*g, stations, kRbcDiameter, kRbcVolume, kPlateletDiameter);
  const double zt = 300e-6, Rt = g->radius_at(zt), R0 = 50e-6;
  for (int k = 0; k < 2; ++k) {
    Snapshot s;
    s.time_s = 0.01 * k;
    add_particle(s, 1, kRbc, Rt - kRbcDiameter / 2 - 3e-6, 0.1, zt);
    add_particle(s, 2, kRbc, Rt - kRbcDiameter / 2 - 7e-6, 0.2, zt + 600e-6);  // z unwrapped
    add_particle(s, 3, kRbc, Rt - kRbcDiameter / 2 - 5e-6, 0.1 + kPi, zt);
    add_particle(s, 4, kRbc, R0 - kRbcDiameter / 2 - 2e-6, 0.5, 20e-6 + 600e-6 * k);  // z unwrapped
    acc.add(s);
  }
  const auto o = acc.result();
  ASSERT_EQ(o.z.size(), 15u);
  EXPECT_DOUBLE_EQ(o.z[7], zt);
  EXPECT_EQ(o.radius[7], Rt);
  EXPECT_NEAR(Rt, R0 * std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(o.cfl[7], 4e-6, 1e-12);
  EXPECT_NEAR(o.cfl[0], 2e-6, 1e-12);
  for (int k : {1, 3, 6, 8, 14}) EXPECT_TRUE(std::isnan(o.cfl[k])) << k;
  // The straight first station's volume is pi R0^2 40 um; the throat's, the integral of pi R^2.
  EXPECT_NEAR(o.hematocrit[0], kRbcVolume / (kPi * R0 * R0 * 40e-6), 1e-12 * o.hematocrit[0]);
  double throat_volume = 0;
  for (int i = 0; i < 100000; ++i) {
    const double z = 280e-6 + 40e-6 * (i + 0.5) / 100000, R = g->radius_at(z);
    throat_volume += kPi * R * R * 40e-6 / 100000;
  }
  EXPECT_NEAR(o.hematocrit[7], 3 * kRbcVolume / throat_volume, 1e-6 * o.hematocrit[7]);
  EXPECT_EQ(o.hematocrit[3], 0);
  EXPECT_EQ(o.snapshots, 2);
}

// Platelets near the wall (gap below one diameter) per wall area, and arrivals at the wall (gap
// below 2 % of a diameter now and not at the snapshot before) per wall area and second. Four
// snapshots 0.01 s apart: platelet 1 touches the throat's wall throughout (it arrived before the
// first: not counted), platelet 2 touches at snapshots 1 and 3 (two arrivals), platelet 3 stays
// near the wall but never touches, platelet 4 is in the core.
TEST(AxialObservables, PlateletsNearAndArrivingAtTheWall) {
  const auto g = stenosis();
  const Stations stations{15, 1};
  AxialAccumulator acc(*g, stations, kRbcDiameter, kRbcVolume, kPlateletDiameter);
  const double zt = 300e-6, Rt = g->radius_at(zt), d = kPlateletDiameter;
  auto at_gap = [&](double gap) { return Rt - d / 2 - gap; };
  for (int k = 0; k < 4; ++k) {
    Snapshot s;
    s.time_s = 0.01 * k;
    add_particle(s, 1, kPlatelet, at_gap(0.005 * d), 0.3, zt);
    add_particle(s, 2, kPlatelet, at_gap(k % 2 == 1 ? 0.01 * d : 0.5 * d), 1.3, zt);
    add_particle(s, 3, kPlatelet, at_gap(0.8 * d), 2.3, zt);
    add_particle(s, 4, kPlatelet, 0, 0, zt);
    acc.add(s);
  }
  const auto o = acc.result();
  // The throat's wall area: 2 pi int R sqrt(1 + R'^2) dz over 280..320 um.
  double area = 0;
  for (int i = 0; i < 100000; ++i) {
    const double z = 280e-6 + 40e-6 * (i + 0.5) / 100000, R = g->radius_at(z), dR = g->radius_slope(z);
    area += 2 * kPi * R * std::sqrt(1 + dR * dR) * 40e-6 / 100000;
  }
  EXPECT_NEAR(o.platelet_near_wall[7], 3 / area, 1e-6 * o.platelet_near_wall[7]);
  EXPECT_NEAR(o.wall_contact_rate[7], 2 / area / 0.03, 1e-6 * o.wall_contact_rate[7]);
  EXPECT_EQ(o.platelet_near_wall[0], 0);
  EXPECT_EQ(o.wall_contact_rate[0], 0);
  EXPECT_GT(o.wall_area_total, 2 * kPi * Rt * 600e-6);
  EXPECT_LT(o.wall_area_total, 2 * kPi * 50e-6 * 600e-6);
}

// On a straight tube, with one sector per station, the stations' CFL averaged is the edge
// method's thickness (rbc_core_edges, cfl_thickness_edge) over the same stations.
TEST(AxialObservables, StraightTubeIsTheEdgeMethodPerStation) {
  const auto g = hemo::make_vessel_geometry(hemo::Vessel{100e-6, 600e-6});
  const Stations stations{6, 1};
  const Tube tube{50e-6, 600e-6};
  AxialAccumulator acc(*g, stations, kRbcDiameter, kRbcVolume, kPlateletDiameter);
  Snapshot s;
  for (int i = 0; i < 60; ++i) add_particle(s, i, kRbc, 10e-6 + 0.5e-6 * i, 0.37 * i, 10e-6 * i + 5e-6);
  acc.add(s);
  const auto o = acc.result();
  const auto edges = rbc_core_edges(select_species(s, kRbc), kRbcDiameter, tube, stations);
  ASSERT_EQ(edges.empty, 0);
  double mean = 0;
  for (double c : o.cfl) mean += c / static_cast<double>(o.cfl.size());
  EXPECT_NEAR(mean, cfl_thickness_edge({edges}, tube).thickness, 1e-15);
  EXPECT_NEAR(o.cfl.back(), 50e-6 - (10e-6 + 0.5e-6 * 59) - kRbcDiameter / 2, 1e-15);  // the outermost, last
}

// The platelets' radial MSD in a narrowing vessel: a platelet that follows its streamline from the
// straight part (r = 0.5 R0) into the throat (r = 0.5 R_throat) has moved 0.5 (R0 - R_throat) in r
// but not at all relative to the wall: taken at r R0 / R(z) its displacement is zero. A straight
// tube's cells are left as they are, bit for bit.
TEST(AxialObservables, RadialMsdFollowsTheLocalWall) {
  const auto g = stenosis();
  const double r0 = 50e-6, rt = g->throat_radius();
  Snapshot before, after;
  add_particle(before, 1, kPlatelet, 0.5 * r0, 0.3, 10e-6, 0.01);
  add_particle(after, 1, kPlatelet, 0.5 * rt, 0.3, 300e-6 + 600e-6, 0.01);  // the throat, one period on
  const Cells b = select_species(before, kPlatelet), a = select_species(after, kPlatelet);
  EXPECT_NEAR(radial_msd(b, 0, a, 0.1).msd_m2, std::pow(0.5 * (r0 - rt), 2), 1e-24);
  EXPECT_NEAR(radial_msd(radii_at_nominal_wall(b, *g), 0, radii_at_nominal_wall(a, *g), 0.1).msd_m2, 0, 1e-24);
  const auto straight = hemo::make_vessel_geometry(hemo::Vessel{100e-6, 600e-6});
  EXPECT_EQ(radii_at_nominal_wall(a, *straight).r, a.r);
}
