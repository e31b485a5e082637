// Test support: the checkpoint tests' case (tests/particles/test_node_checkpoint.cpp and the MPI
// variant in test_mpi_checkpoint.cpp), a few hundred red cells and platelets pressed together and
// against the wall, and exact comparisons of feedback and snapshots.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "h5_output.h"
#include "particle_node.h"
#include "synthetic_case.h"

#include <gtest/gtest.h>
#include <mpi.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace hemo::particles::testing::checkpoint_case {
using namespace hemo::particles::synthetic;

inline constexpr double kR = 25e-6, kL = 100e-6, kInterval = 1e-5;

// Dense enough for cell-cell and cell-wall contacts from the first steps, the paper's closures
// (platelets carry an orientation), closures held for 3 DEM steps.
inline hemo::Scene contact_scene(double hematocrit = 0.3) {
  auto scene = blood_scene(2 * kR, kL, hematocrit);
  use_paper_closures(scene);
  scene.time.closure_every_dem_steps = 3;
  return scene;
}

// Not a physical flow, a demanding one: Poiseuille flow (wall shear rate 8000 1/s) on a plug
// flow of 0.2 m/s, and a radial outflow growing to 0.05 m/s at the wall. Shear and outflow press
// cells together and against the wall within a few steps; the plug carries some of them across
// the periodic ends.
inline FieldAt pressing_flow() {
  const double outflow = 0.05 / kR;  // 1/s: u_r = outflow r
  const FieldAt shear = poiseuille(kR, 8000 * kR / 2);
  return [=](const std::array<double, 3>& x, std::array<double, 3>& u, std::array<double, 9>& g) {
    shear(x, u, g);
    u[0] = outflow * x[0];
    u[1] = outflow * x[1];
    u[2] += 0.2;
    g[0 * 3 + 0] = g[1 * 3 + 1] = outflow;  // G[i][j] = d u_j / d x_i
  };
}

inline hemo::step_order_t order(long k) {
  hemo::step_order_t o;
  o.envelope.step = k;
  o.dt_s = kInterval;
  o.time_s = k * kInterval;
  o.write_output = true;
  return o;
}

// One coupling step as main.cpp takes it; returns the feedback.
inline hemo::particle_feedback_t take_step(ParticleNode& node, long k, const hemo::fluid_state_t& fluid,
                                           bool write_checkpoint = false) {
  const auto o = order(k);
  EXPECT_EQ(node.check(fluid), "");
  EXPECT_EQ(node.advance(o, fluid), "") << "step " << k;
  auto fb = node.feedback();
  node.write_output(node.step(), node.time());
  if (write_checkpoint) node.write_checkpoint();
  node.diagnostics();
  return fb;
}

inline std::filesystem::path fresh_dir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

inline int world_rank() {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank;
}

// A fresh temporary directory, the same on every rank (the first rank's).
inline std::filesystem::path shared_dir(const std::string& name) {
  std::string path = world_rank() == 0 ? fresh_dir(name).string() : std::string();
  int len = static_cast<int>(path.size());
  MPI_Bcast(&len, 1, MPI_INT, 0, MPI_COMM_WORLD);
  path.resize(static_cast<std::size_t>(len));
  MPI_Bcast(path.data(), len, MPI_CHAR, 0, MPI_COMM_WORLD);
  return path;
}

// Exact equality, or the first difference named.
inline ::testing::AssertionResult same(const std::vector<double>& a, const std::vector<double>& b,
                                       const std::string& what) {
  if (a.size() != b.size())
    return ::testing::AssertionFailure() << what << ": " << a.size() << " vs " << b.size() << " values";
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!(a[i] == b[i]))
      return ::testing::AssertionFailure()
             << what << "[" << i << "]: " << a[i] << " vs " << b[i] << " (difference " << a[i] - b[i] << ")";
  return ::testing::AssertionSuccess();
}

inline void expect_same_feedback(const hemo::particle_feedback_t& a, const hemo::particle_feedback_t& b, long k) {
  const std::string at = " at step " + std::to_string(k);
  EXPECT_TRUE(same(a.solid_fraction, b.solid_fraction, "solid fraction" + at));
  EXPECT_TRUE(same(a.source_explicit, b.source_explicit, "explicit source" + at));
  EXPECT_TRUE(same(a.drag_coefficient, b.drag_coefficient, "drag coefficient" + at));
  EXPECT_TRUE(same({a.total_particle_force[0], a.total_particle_force[1], a.total_particle_force[2]},
                   {b.total_particle_force[0], b.total_particle_force[1], b.total_particle_force[2]},
                   "total particle force" + at));
}

inline void expect_same_snapshot(const std::string& a_file, const std::string& b_file, long k) {
  const auto a = read_snapshot(a_file, k), b = read_snapshot(b_file, k);
  const std::string at = " at step " + std::to_string(k);
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.species, b.species);
  EXPECT_EQ(a.time_s, b.time_s);
  EXPECT_TRUE(same(a.position, b.position, "position (z unwrapped)" + at));
  EXPECT_TRUE(same(a.velocity, b.velocity, "velocity" + at));
  EXPECT_TRUE(same(a.orientation, b.orientation, "orientation" + at));
}

// How many particles are outside [0, L) in z (have crossed a periodic end) in a snapshot.
inline long crossed(const std::string& file, long k) {
  const auto s = read_snapshot(file, k);
  long n = 0;
  for (std::size_t i = 0; i < s.size(); ++i) n += s.position[3 * i + 2] < 0 || s.position[3 * i + 2] >= kL;
  return n;
}

}  // namespace hemo::particles::testing::checkpoint_case
