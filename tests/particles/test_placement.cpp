// SPDX-License-Identifier: GPL-3.0-or-later
#include "overlap.h"

#include <gtest/gtest.h>
#include <placement.h>

#include <chrono>
#include <cmath>
#include <cstdio>

using namespace hemo::particles;

namespace {
hemo::Scene calibration_scene() {
  hemo::Scene s;
  s.vessel.diameter = 100e-6;
  s.vessel.length = 600e-6;
  s.rbc.present = true;
  s.rbc.diameter = 5.56e-6;
  s.rbc.volume = 90e-18;
  s.rbc.mass = 1100 * 90e-18;
  s.rbc.hematocrit = 0.15;
  s.platelet.present = true;
  s.platelet.diameter = 2.66e-6;
  s.platelet.mass = 8.79e-15;
  s.platelet.number_density = 3e5 * 1e9;
  return s;
}
}  // namespace

TEST(Placement, CountsFromHematocritAndNumberDensity) {
  const auto s = calibration_scene();
  EXPECT_EQ(rbc_count(s), 7854);       // 0.15 x 4.712e-12 m^3 / 90 um^3 (docs/design.md "Speed and accuracy": 7,850)
  EXPECT_EQ(platelet_count(s), 1414);  // 3e14 / m^3 x 4.712e-12 m^3
  auto none = s;
  none.platelet.present = false;
  EXPECT_EQ(platelet_count(none), 0);
  EXPECT_EQ(placement_requests(none).size(), 1u);
}

TEST(Placement, InsideNonOverlappingAndReproducible) {
  const double R = 25e-6, L = 100e-6, z0 = 0;
  const std::vector<PlacementRequest> req = {{kPlatelet, 2.66e-6, 150}, {kRbc, 5.56e-6, 250}};
  const auto a = place_particles(R, L, z0, req, 42);
  ASSERT_EQ(a.size(), 400u);
  std::vector<Vec3> x;
  std::vector<double> d;
  int rbcs = 0;
  for (const auto& p : a) {
    const double gap = 0.02 * p.diameter;
    EXPECT_LE(std::hypot(p.position.x(), p.position.y()), R - p.diameter / 2 - gap + 1e-15);
    EXPECT_GE(p.position.z(), z0);
    EXPECT_LT(p.position.z(), z0 + L);
    x.push_back(p.position);
    d.push_back(p.diameter);
    rbcs += p.species == kRbc;
  }
  EXPECT_EQ(rbcs, 250);
  EXPECT_EQ(a.front().species, kRbc);  // largest first
  const auto overlaps = measure_overlaps(x, d, R, L, z0);
  EXPECT_EQ(overlaps.contacts, 0);
  const auto b = place_particles(R, L, z0, req, 42);
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].position, b[i].position);
  const auto c = place_particles(R, L, z0, req, 43);
  EXPECT_NE(a[0].position, c[0].position);
}

TEST(Placement, ClearErrorWhenTooFull) {
  const std::vector<PlacementRequest> req = {{kRbc, 5.56e-6, 5000}};
  try {
    place_particles(10e-6, 20e-6, 0, req, 1, {0.02, 200});
    FAIL() << "expected PlacementError";
  } catch (const PlacementError& e) {
    EXPECT_NE(std::string(e.what()).find("too full"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("cannot place RBC"), std::string::npos) << e.what();
  }
  EXPECT_THROW(place_particles(2e-6, 20e-6, 0, req, 1), PlacementError);  // does not fit at all
}

TEST(Placement, CalibrationVesselAtTwentyPercentHematocritQuickly) {
  // d = 100 um, l = 600 um, Ht 20 % (10,472 RBCs) and 1,414 platelets: placed, non-overlapping,
  // reproducibly, in well under a second.
  auto s = calibration_scene();
  s.rbc.hematocrit = 0.20;
  const auto req = placement_requests(s);
  ASSERT_EQ(req[0].count, 10472);
  const auto t0 = std::chrono::steady_clock::now();
  const auto a = place_particles(50e-6, 600e-6, 0, req, 2024);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(a.size(), 10472u + 1414u);
  std::vector<Vec3> x;
  std::vector<double> d;
  double rbc_volume = 0;
  for (const auto& p : a) {
    x.push_back(p.position);
    d.push_back(p.diameter);
    if (p.species == kRbc) rbc_volume += 90e-18;
  }
  const double vessel = 3.14159265358979 * 50e-6 * 50e-6 * 600e-6;
  std::printf("[ info ] Ht %.4f: %zu particles placed in %.2f s\n", rbc_volume / vessel, a.size(), seconds);
  EXPECT_NEAR(rbc_volume / vessel, 0.20, 1e-4);
  EXPECT_EQ(measure_overlaps(x, d, 50e-6, 600e-6, 0).contacts, 0);
  EXPECT_LT(seconds, 5.0);
  const auto b = place_particles(50e-6, 600e-6, 0, req, 2024);
  EXPECT_EQ(a.back().position, b.back().position);
}

// Above what random sequential addition reaches (it jams near 0.31 in the bench vessel), the RBCs
// go on lattice sites: physiological hematocrits and beyond, still inside, apart, reproducible,
// with the platelets added at random in the gaps.
TEST(Placement, DenseHematocritsGoOnALattice) {
  auto s = calibration_scene();
  s.vessel.diameter = 50e-6;
  s.vessel.length = 60e-6;
  const double R = 25e-6, L = 60e-6, vessel = 3.14159265358979 * R * R * L;
  for (double ht : {0.35, 0.45, 0.5}) {
    s.rbc.hematocrit = ht;
    const auto req = placement_requests(s);
    const auto a = place_particles(R, L, 0, req, 7);
    ASSERT_EQ(static_cast<long>(a.size()), req[0].count + req[1].count) << "Ht " << ht;
    std::vector<Vec3> x;
    std::vector<double> d;
    double rbc_volume = 0;
    for (const auto& p : a) {
      EXPECT_LE(std::hypot(p.position.x(), p.position.y()), R - p.diameter / 2 - 0.02 * p.diameter + 1e-15);
      EXPECT_GE(p.position.z(), 0);
      EXPECT_LT(p.position.z(), L);
      x.push_back(p.position);
      d.push_back(p.diameter);
      if (p.species == kRbc) rbc_volume += 90e-18;
    }
    EXPECT_NEAR(rbc_volume / vessel, ht, 0.002);
    EXPECT_EQ(measure_overlaps(x, d, R, L, 0).contacts, 0) << "Ht " << ht;
    const auto b = place_particles(R, L, 0, req, 7);
    EXPECT_EQ(a.back().position, b.back().position);
  }
  // Beyond the lattice's capacity: the same clear error.
  s.rbc.hematocrit = 0.65;
  EXPECT_THROW(place_particles(R, L, 0, placement_requests(s), 7), PlacementError);
}

TEST(Overlap, MeasuresPairsAcrossThePeriodAndTheWall) {
  const double R = 10e-6, L = 20e-6;
  // Two spheres of d = 2 um across the periodic end, 1.8 um apart: overlap 0.2 um = 0.1 d.
  std::vector<Vec3> x = {Vec3(0, 0, 0.1e-6), Vec3(0, 0, L - 1.7e-6)};
  std::vector<double> d = {2e-6, 2e-6};
  auto r = measure_overlaps(x, d, R, L, 0);
  EXPECT_EQ(r.contacts, 1);
  EXPECT_NEAR(r.max_relative, 0.1, 1e-9);
  x.push_back(Vec3(R - 0.5e-6, 0, 10e-6));  // 0.5 um into the wall: 0.25 d
  d.push_back(2e-6);
  r = measure_overlaps(x, d, R, L, 0);
  EXPECT_EQ(r.contacts, 2);
  EXPECT_NEAR(r.max_relative, 0.25, 1e-9);
}
