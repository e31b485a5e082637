// The partitioned exchange's messages (common/partition_exchange.h): a fluid rank's slice of its
// own cells for one particle rank, taken into the particle rank's whole-mesh state, and every
// way a partition can fail to be what the overlap map says, refused with one line that names
// both ranks and leaves the state as it was.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_fields.h"

#include <partition_exchange.h>

#include <gtest/gtest.h>

#include <string>
#include <vector>

using namespace hemo;

namespace {

// A state of `cells` (global ids) in that local order, every value telling its cell and component.
fluid_state_t local_state(const std::vector<int>& cells) {
  fluid_state_t s;
  s.mesh_hash = "m1";
  s.time_s = 0.25;
  resize_cells(s, static_cast<int>(cells.size()), /*pressure_gradient=*/true);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    for (int k = 0; k < kVectorValues; ++k) velocity_of(s, i)[k] = 100.0 * cells[i] + k;
    for (int k = 0; k < kTensorValues; ++k) gradient_of(s, i)[k] = -100.0 * cells[i] - k;
    for (int k = 0; k < kVectorValues; ++k) pressure_gradient_of(s, i)[k] = 0.5 + 100.0 * cells[i] + k;
  }
  return s;
}

fluid_state_t empty_whole(int n) {
  fluid_state_t w;
  w.mesh_hash = "m1";
  resize_cells(w, n);
  return w;
}

}  // namespace

TEST(PartitionExchange, APartitionFillsItsCellsOfTheWholeStateAndNoOther) {
  // Fluid rank 1 owns cells 5, 2, 7, 3 in its local order; particle rank 0 takes 2, 3 and 7.
  const fluid_state_t mine = local_state({5, 2, 7, 3});
  const fluid_partition_t msg = slice_partition(mine, {2, 3, 7}, {1, 3, 2}, 1, 0);
  EXPECT_EQ(msg.n_cells, 3);
  EXPECT_EQ(msg.n_velocity_values, 9);
  EXPECT_EQ(msg.n_pressure_gradient_values, 9);
  EXPECT_EQ(msg.n_viscous_values, 0);
  fluid_state_t whole = empty_whole(8);
  ASSERT_EQ(take_partition(msg, {2, 3, 7}, 1, 0, whole), "");
  EXPECT_DOUBLE_EQ(whole.time_s, 0.25);
  ASSERT_EQ(whole.n_pressure_gradient_values, 24);
  for (int c = 0; c < 8; ++c) {
    const bool taken = c == 2 || c == 3 || c == 7;
    for (int k = 0; k < kVectorValues; ++k) {
      EXPECT_EQ(velocity_of(whole, c)[k], taken ? 100.0 * c + k : 0.0) << "cell " << c;
      EXPECT_EQ(pressure_gradient_of(whole, c)[k], taken ? 0.5 + 100.0 * c + k : 0.0) << "cell " << c;
    }
    for (int k = 0; k < kTensorValues; ++k) EXPECT_EQ(gradient_of(whole, c)[k], taken ? -100.0 * c - k : 0.0);
  }
}

TEST(PartitionExchange, AWrongPartitionStopsWithOneLineAndLeavesTheStateAsItWas) {
  const fluid_state_t mine = local_state({5, 2, 7, 3});
  const fluid_state_t untouched = empty_whole(8);
  auto refused = [&](const fluid_partition_t& msg, const std::vector<int>& expected) {
    fluid_state_t whole = untouched;
    const std::string why = take_partition(msg, expected, 1, 0, whole);
    EXPECT_EQ(whole.velocity, untouched.velocity) << why;
    EXPECT_EQ(why.find('\n'), std::string::npos) << why;
    return why;
  };
  const auto msg = slice_partition(mine, {2, 3, 7}, {1, 3, 2}, 1, 0);
  EXPECT_EQ(refused(msg, {2, 3, 5, 7}),
            "fluid rank 1 -> particle rank 0: cell 5 is missing (3 cells received, 4 expected by the overlap map)");
  EXPECT_EQ(refused(msg, {2, 7}),
            "fluid rank 1 -> particle rank 0: cell 3 was not expected (3 cells received, 2 expected by the overlap map)");
  EXPECT_EQ(refused(slice_partition(mine, {2, 2, 7}, {1, 1, 2}, 1, 0), {2, 7}),
            "fluid rank 1 -> particle rank 0: cell 2 received twice (3 cells received, 2 expected by the overlap map)");
  EXPECT_EQ(refused(slice_partition(mine, {2, 3, 7}, {1, 3, 2}, 1, 1), {2, 3, 7}),
            "fluid rank 1 -> particle rank 0: the message is fluid rank 1's for particle rank 1");
  auto other_mesh = msg;
  other_mesh.mesh_hash = "m2";
  EXPECT_EQ(refused(other_mesh, {2, 3, 7}),
            "fluid rank 1 -> particle rank 0: the state is for mesh 'm2', not the mesh received ('m1')");
  auto short_values = msg;
  short_values.velocity.pop_back();
  EXPECT_EQ(refused(short_values, {2, 3, 7}),
            "fluid rank 1 -> particle rank 0: velocity has 8 values, not 3 per cell of 3 cells");
  auto outside = slice_partition(local_state({9}), {9}, {0}, 1, 0);
  EXPECT_EQ(refused(outside, {9}), "fluid rank 1 -> particle rank 0: cell 9 is outside the mesh of 8 cells");
}

TEST(PartitionExchange, DecompositionMessagesThatDoNotFitTheMeshAreRefused) {
  mesh_t mesh;
  mesh.mesh_hash = "m1";
  mesh.n_cells = 3;
  const auto msg = decomposition_message("m1", FluidDecomposition{2, {0, 1, 1}});
  EXPECT_EQ(fluid_decomposition_of(msg, mesh).owner, (std::vector<int>{0, 1, 1}));
  auto bad = msg;
  bad.owner[2] = 2;
  try {
    fluid_decomposition_of(bad, mesh);
    FAIL() << "an owner of rank 2 of 2 taken";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "the fluid's decomposition (PARTITION) gives cell 2 to rank 2 of 2");
  }
  ParticleDecomposition particles;
  particles.margin = 1e-6;
  particles.boxes = {{particles::Vec3(0, 0, 0), particles::Vec3(1, 1, 1)}};
  const auto domain = particle_decomposition_of(domain_message("m1", particles), mesh);
  ASSERT_EQ(domain.boxes.size(), 1u);
  EXPECT_EQ(domain.margin, 1e-6);
  EXPECT_EQ(domain.boxes[0].hi, particles::Vec3(1, 1, 1));
  try {
    particle_decomposition_of(domain_message("m0", particles), mesh);
    FAIL() << "another mesh's domain taken";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "the particles' domain (DOMAIN) is for mesh 'm0', not the mesh received ('m1')");
  }
}
