// SPDX-License-Identifier: GPL-3.0-or-later
// Checkpoint and resume on 1 and 2 MPI ranks (ctest runs particles_mpi_tests under mpirun -np 1
// and -np 2): every rank writes its own file, a node resumed on as many ranks goes on bit for bit
// (particles crossing between the ranks' slabs meanwhile), one on another number to round-off.
#include "checkpoint_case.h"
#include "engine_state.h"

#include <checkpoint.h>
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>

using namespace hemo::particles;
using namespace hemo::particles::testing;
using namespace hemo::particles::testing::checkpoint_case;
namespace fs = std::filesystem;

namespace {

int world_size() {
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return size;
}

}  // namespace

TEST(NodeCheckpointMpi, ResumedOnAsManyRanksGoesOnBitForBit) {
  const auto scene = contact_scene();
  const auto mesh = wedge_mesh(16, 8, kR, kL, "wedge16");
  const auto fluid = fluid_state(mesh, pressing_flow());
  const long K = 3, N = 3;
  const fs::path a_dir = shared_dir("hemo_mpi_ckpt_a"), b_dir = shared_dir("hemo_mpi_ckpt_b");
  std::map<long, hemo::particle_feedback_t> written, unwritten;
  {
    ParticleNode node(scene, mesh, a_dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= K + N; ++k) written[k] = take_step(node, k, fluid, k == K);
  }
  {  // Writing the checkpoint changed the run by round-off only (atoms it moved to another rank kept their forces).
    const fs::path c_dir = shared_dir("hemo_mpi_ckpt_c");
    ParticleNode node(scene, mesh, c_dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= K + N; ++k) {
      const auto fb = take_step(node, k, fluid);
      if (k <= K) continue;
      const std::vector<double>& a = written[k].source_explicit;
      const std::vector<double>& c = fb.source_explicit;
      double worst = 0, largest = 0;
      for (std::size_t i = 0; i < c.size(); ++i) {
        worst = std::max(worst, std::abs(a[i] - c[i]));
        largest = std::max(largest, std::abs(c[i]));
      }
      EXPECT_LT(worst, 1e-12 * largest) << "step " << k;
    }
    MPI_Barrier(MPI_COMM_WORLD);
    if (world_rank() == 0) fs::remove_all(c_dir);
  }
  // Every rank wrote its part, and holds particles.
  const std::string folder = hemo::checkpoint_of(a_dir.string(), K, "particles");
  const auto mine = read_engine_state(engine_state_file(folder, world_rank()));
  EXPECT_GT(mine.tag.size(), 0u) << "rank " << world_rank();
  EXPECT_EQ(mine.ranks, world_size());
  EXPECT_FALSE(fs::exists(engine_state_file(folder, world_size())));

  MPI_Barrier(MPI_COMM_WORLD);
  if (world_rank() == 0) fs::copy(a_dir, b_dir, fs::copy_options::recursive);
  MPI_Barrier(MPI_COMM_WORLD);
  ParticleNode resumed(scene, mesh, b_dir.string(), MPI_COMM_WORLD, K);
  expect_same_feedback(resumed.feedback(), written[K], K);
  resumed.diagnostics();
  for (long k = K + 1; k <= K + N; ++k) {
    expect_same_feedback(take_step(resumed, k, fluid), written[k], k);
    if (world_rank() == 0)
      expect_same_snapshot((a_dir / "particles.h5").string(), (b_dir / "particles.h5").string(), k);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  if (world_rank() == 0) {
    fs::remove_all(a_dir);
    fs::remove_all(b_dir);
  }
}

// A checkpoint of one rank resumed on two: each rank keeps the atoms in its own slab, and the
// run goes on as the one-rank node does, to round-off (other sums over the contacts).
TEST(NodeCheckpointMpi, ACheckpointOfOneRankResumedOnTwoGoesOnToRoundOff) {
  if (world_size() != 2) GTEST_SKIP() << "runs on 2 ranks";
  const auto scene = contact_scene();
  const auto mesh = wedge_mesh(16, 8, kR, kL, "wedge16");
  const auto fluid = fluid_state(mesh, pressing_flow());
  const long K = 3, N = 3;
  const fs::path dir = shared_dir("hemo_mpi_ckpt_ranks"), one_dir = shared_dir("hemo_mpi_ckpt_ranks_one");
  std::map<long, hemo::particle_feedback_t> alone;
  if (world_rank() == 0) {  // a node of one rank
    ParticleNode node(scene, mesh, one_dir.string(), MPI_COMM_SELF);
    for (long k = 1; k <= K + N; ++k) alone[k] = take_step(node, k, fluid, k == K);
    fs::copy(one_dir, dir, fs::copy_options::recursive);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  ParticleNode resumed(scene, mesh, dir.string(), MPI_COMM_WORLD, K);
  resumed.diagnostics();
  for (long k = K + 1; k <= K + N; ++k) {
    const auto fb = take_step(resumed, k, fluid);
    if (world_rank() != 0) continue;
    const std::vector<double>& a = alone[k].source_explicit;
    const std::vector<double>& b = fb.source_explicit;
    ASSERT_EQ(a.size(), b.size());
    double worst = 0, largest = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      worst = std::max(worst, std::abs(a[i] - b[i]));
      largest = std::max(largest, std::abs(a[i]));
    }
    EXPECT_GT(largest, 0) << "step " << k;
    EXPECT_LT(worst, 1e-12 * largest) << "step " << k;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  if (world_rank() == 0) {
    fs::remove_all(dir);
    fs::remove_all(one_dir);
  }
}
