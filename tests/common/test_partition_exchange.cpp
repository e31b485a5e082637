// The partitioned exchange's messages (common/partition_exchange.h): a fluid rank's slice of its
// own cells for one particle rank, taken into the particle rank's whole-mesh state, and every
// way a partition can fail to be what the overlap map says, refused with one line that names
// both ranks and leaves the state as it was; and the feedback's partial sums back, added up on
// the fluid rank, checked the same way.
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

namespace {

// Particle rank p's partial feedback on a mesh of n cells: every value tells its rank, cell and
// component, and is zero outside `cells`.
particle_feedback_t partial_feedback(int p, int n, const std::vector<int>& cells) {
  particle_feedback_t fb;
  fb.mesh_hash = "m1";
  resize_cells(fb, n);
  for (int c : cells) {
    fb.solid_fraction[c] = 0.01 * c + p;
    fb.drag_coefficient[c] = 10.0 * c + p;
    for (int k = 0; k < kVectorValues; ++k) source_of(fb, c)[k] = 1000.0 * p + 10.0 * c + k;
  }
  return fb;
}

}  // namespace

// Fluid rank 1 owns cells 2, 3, 5, 7; particle rank 0 takes 2, 3, 7 of them and particle rank 1
// takes 5, 7: cell 7's feedback is the sum of both partials, each other cell's is its one rank's,
// and the cells the fluid rank does not own stay zero.
TEST(PartitionExchange, PartialFeedbackIsSummedOnItsCellsOfTheFluidRank) {
  const auto from0 = slice_feedback(partial_feedback(0, 8, {0, 2, 3, 7}), {2, 3, 7}, 1, 0);
  const auto from1 = slice_feedback(partial_feedback(1, 8, {5, 7}), {5, 7}, 1, 1);
  EXPECT_EQ(from0.n_cells, 3);
  EXPECT_EQ(from0.n_source_values, 9);
  EXPECT_EQ(from0.cells, (std::vector<std::int32_t>{2, 3, 7}));
  particle_feedback_t sum;
  sum.mesh_hash = "m1";
  resize_cells(sum, 8);
  ASSERT_EQ(add_feedback_partition(from0, {2, 3, 7}, 1, 0, sum), "");
  ASSERT_EQ(add_feedback_partition(from1, {5, 7}, 1, 1, sum), "");
  for (int c = 0; c < 8; ++c) {
    const bool by0 = c == 2 || c == 3 || c == 7, by1 = c == 5 || c == 7;
    const double phi = (by0 ? 0.01 * c : 0.0) + (by1 ? 0.01 * c + 1 : 0.0);
    EXPECT_EQ(sum.solid_fraction[c], phi) << "cell " << c;
    EXPECT_EQ(sum.drag_coefficient[c], (by0 ? 10.0 * c : 0.0) + (by1 ? 10.0 * c + 1 : 0.0)) << "cell " << c;
    for (int k = 0; k < kVectorValues; ++k)
      EXPECT_EQ(source_of(sum, c)[k], (by0 ? 10.0 * c + k : 0.0) + (by1 ? 1000.0 + 10.0 * c + k : 0.0)) << "cell " << c;
  }
}

TEST(PartitionExchange, AWrongPartialFeedbackStopsWithOneLineAndLeavesTheSumAsItWas) {
  const auto msg = slice_feedback(partial_feedback(0, 8, {2, 3, 7}), {2, 3, 7}, 1, 0);
  particle_feedback_t untouched;
  untouched.mesh_hash = "m1";
  resize_cells(untouched, 8);
  untouched.solid_fraction[3] = 0.5;
  auto refused = [&](const feedback_partition_t& m, const std::vector<int>& expected) {
    particle_feedback_t sum = untouched;
    const std::string why = add_feedback_partition(m, expected, 1, 0, sum);
    EXPECT_EQ(sum.solid_fraction, untouched.solid_fraction) << why;
    EXPECT_EQ(sum.source_explicit, untouched.source_explicit) << why;
    EXPECT_EQ(why.find('\n'), std::string::npos) << why;
    return why;
  };
  EXPECT_EQ(refused(msg, {2, 3, 5, 7}),
            "particle rank 0 -> fluid rank 1: cell 5 is missing (3 cells received, 4 expected by the overlap map)");
  EXPECT_EQ(refused(msg, {2, 7}),
            "particle rank 0 -> fluid rank 1: cell 3 was not expected (3 cells received, 2 expected by the overlap map)");
  EXPECT_EQ(refused(slice_feedback(partial_feedback(0, 8, {2}), {2, 3, 7}, 0, 0), {2, 3, 7}),
            "particle rank 0 -> fluid rank 1: the message is particle rank 0's for fluid rank 0");
  auto other_mesh = msg;
  other_mesh.mesh_hash = "m2";
  EXPECT_EQ(refused(other_mesh, {2, 3, 7}),
            "particle rank 0 -> fluid rank 1: the feedback is for mesh 'm2', not this mesh ('m1')");
  auto short_source = msg;
  short_source.source_explicit.pop_back();
  EXPECT_EQ(refused(short_source, {2, 3, 7}),
            "particle rank 0 -> fluid rank 1: explicit source has 8 values, not 3 per cell of 3 cells");
  auto short_phi = msg;
  short_phi.solid_fraction.pop_back();
  EXPECT_EQ(refused(short_phi, {2, 3, 7}),
            "particle rank 0 -> fluid rank 1: solid fraction has 2 values, not 1 per cell of 3 cells");
  const auto outside = slice_feedback(partial_feedback(0, 10, {9}), {9}, 1, 0);
  EXPECT_EQ(refused(outside, {9}), "particle rank 0 -> fluid rank 1: cell 9 is outside the mesh of 8 cells");
}
