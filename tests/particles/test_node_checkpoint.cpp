// SPDX-License-Identifier: GPL-3.0-or-later
// Checkpoint and resume of the particle node without the bus: a node resumed from the
// checkpoint of step K goes on bit for bit as the node that wrote it (positions, velocities,
// orientations, unwrapped z, the feedback to the fluid), with contacts (pair and wall, with
// tangential history) in progress, platelets turning, closures held over DEM steps and
// particles crossing the periodic ends; its particles.h5 is cut back to the snapshots of steps
// <= K; a missing or damaged checkpoint is a one-line CheckpointError that changes nothing.
#include "checkpoint_case.h"
#include "checkpoint_file.h"
#include "engine_state.h"

#include <checkpoint.h>
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

using namespace hemo::particles;
using namespace hemo::particles::testing;
using namespace hemo::particles::testing::checkpoint_case;
namespace fs = std::filesystem;

// Also with coupling.implicit_drag = "co_relaxed", whose cells' plasma masses come from the
// last deposition (the checkpoint's, on resume), and with dem.neighbour_rebuild = "streaming",
// whose lists start from the checkpoint's rebuild on both sides.
struct CheckpointSettings {
  const char* implicit_drag;
  const char* neighbour_rebuild;
};
class NodeCheckpointDrag : public ::testing::TestWithParam<CheckpointSettings> {};
INSTANTIATE_TEST_SUITE_P(ImplicitDrag, NodeCheckpointDrag,
                         ::testing::Values(CheckpointSettings{"interval_response", "engine"},
                                           CheckpointSettings{"co_relaxed", "engine"},
                                           CheckpointSettings{"interval_response", "streaming"}));

TEST_P(NodeCheckpointDrag, ResumedNodeGoesOnBitForBitAsTheNodeThatWroteIt) {
  auto scene = contact_scene();
  hemo::choice_named(GetParam().implicit_drag, scene.implicit_drag);
  hemo::choice_named(GetParam().neighbour_rebuild, scene.neighbour_rebuild);
  const auto mesh = wedge_mesh(16, 8, kR, kL, "wedge16");
  const auto fluid = fluid_state(mesh, pressing_flow());
  const long K = 4, N = 4;
  const fs::path a_dir = fresh_dir("hemo_ckpt_a"), b_dir = fresh_dir("hemo_ckpt_b");

  std::map<long, hemo::particle_feedback_t> written;  // the uninterrupted node's feedback
  {
    ParticleNode node(scene, mesh, a_dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= K + N; ++k) written[k] = take_step(node, k, fluid, k == K);
  }
  const std::string a_h5 = (a_dir / "particles.h5").string(), b_h5 = (b_dir / "particles.h5").string();

  // The checkpoint holds what makes this test worth its name.
  const auto state = read_engine_state(engine_state_file(hemo::checkpoint_of(a_dir.string(), K, "particles"), 0));
  long pair_contacts = 0, wall_contacts = 0;  // with a tangential history (each pair on both partners)
  for (std::size_t p = 0; p < state.partner.size(); ++p) {
    const double* h = &state.contact_history[p * state.contact_values];
    pair_contacts += h[0] != 0 || h[1] != 0 || h[2] != 0;
  }
  for (std::size_t i = 0; i + 2 < state.wall_history.size(); i += 3)
    wall_contacts += state.wall_history[i] != 0 || state.wall_history[i + 1] != 0 || state.wall_history[i + 2] != 0;
  std::printf(
      "[ info ] %zu particles; at step %ld: %ld pair contacts and %ld wall contacts with tangential history; "
      "%ld, %ld particles crossed a periodic end by steps %ld, %ld\n",
      state.tag.size(), K, pair_contacts / 2, wall_contacts, crossed(a_h5, K), crossed(a_h5, K + N), K, K + N);
  EXPECT_GT(pair_contacts, 0);
  EXPECT_GT(wall_contacts, 0);
  EXPECT_GT(crossed(a_h5, K + N), crossed(a_h5, K));
  bool turned = false;
  for (std::size_t i = 0; i < state.rotation.size(); i += 7) turned |= state.rotation[i] != 1.0;
  EXPECT_TRUE(turned) << "no platelet has turned";

  fs::copy(a_dir, b_dir, fs::copy_options::recursive);
  ParticleNode resumed(scene, mesh, b_dir.string(), MPI_COMM_WORLD, K);
  EXPECT_EQ(resumed.step(), K);
  EXPECT_EQ(resumed.time(), K * kInterval);
  expect_same_feedback(resumed.feedback(), written[K], K);  // the first report after a resume
  resumed.diagnostics();
  // particles.h5 is opened again only at the first snapshot after the resume (until then both
  // nodes may not have started, and a failed start must leave it as it was).
  EXPECT_EQ(list_snapshots(b_h5), (std::vector<long>{0, 1, 2, 3, 4, 5, 6, 7, 8}));
  for (long k = K + 1; k <= K + N; ++k) {
    expect_same_feedback(take_step(resumed, k, fluid), written[k], k);
    expect_same_snapshot(a_h5, b_h5, k);
  }
  fs::remove_all(a_dir);
  fs::remove_all(b_dir);
}

TEST(NodeCheckpoint, WritingACheckpointChangesTheRunOnlyByRoundOff) {
  // A checkpoint rebuilds LIGGGHTS's neighbour lists: the same contacts, summed in another order.
  // (Before contact histories were cleared on separation, a pair that separated and touched
  // again before the next rebuild found its old shear spring: 1e-14 m here.)
  const auto scene = contact_scene();
  const auto mesh = wedge_mesh(16, 8, kR, kL, "wedge16");
  const auto fluid = fluid_state(mesh, pressing_flow());
  const long K = 4, N = 6;
  const fs::path a_dir = fresh_dir("hemo_ckpt_with"), c_dir = fresh_dir("hemo_ckpt_without");
  std::map<long, hemo::particle_feedback_t> with, without;
  {
    ParticleNode node(scene, mesh, a_dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= K + N; ++k) with[k] = take_step(node, k, fluid, k == K);
  }
  {
    ParticleNode node(scene, mesh, c_dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= K + N; ++k) without[k] = take_step(node, k, fluid);
  }
  auto largest = [](const std::vector<double>& v) {
    double m = 0;
    for (const double x : v) m = std::max(m, std::abs(x));
    return m;
  };
  auto max_difference = [](const std::vector<double>& a, const std::vector<double>& b) {
    double m = 0;
    for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
    return m;
  };
  double worst_x = 0, worst_v = 0, worst_s = 0;
  for (long k = K + 1; k <= K + N; ++k) {
    const auto a = read_snapshot((a_dir / "particles.h5").string(), k);
    const auto c = read_snapshot((c_dir / "particles.h5").string(), k);
    ASSERT_EQ(a.position.size(), c.position.size());
    worst_x = std::max(worst_x, max_difference(a.position, c.position) / kL);
    worst_v = std::max(worst_v, max_difference(a.velocity, c.velocity) / largest(c.velocity));
    const std::vector<double>& sa = with[k].source_explicit;
    const std::vector<double>& sc = without[k].source_explicit;
    worst_s = std::max(worst_s, max_difference(sa, sc) / largest(sc));
  }
  std::printf(
      "[ info ] with a checkpoint at step %ld against without, over steps %ld..%ld: positions %.2e L, "
      "velocities %.2e, explicit sources %.2e of the largest\n",
      K, K + 1, K + N, worst_x, worst_v, worst_s);
  EXPECT_LT(worst_x, 1e-12);
  EXPECT_LT(worst_v, 1e-12);
  EXPECT_LT(worst_s, 1e-12);
  fs::remove_all(a_dir);
  fs::remove_all(c_dir);
}

TEST(NodeCheckpoint, AcknowledgesTheCheckpointInTheNextDiagnosticsOnly) {
  const auto scene = contact_scene(0.05);
  const auto mesh = wedge_mesh(16, 8, kR, kL, "wedge16");
  const auto fluid = fluid_state(mesh, poiseuille(kR, 799 * kR / 2));
  const fs::path dir = fresh_dir("hemo_ckpt_ack");
  ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD);
  auto acknowledged = [&] {
    for (const auto& [name, value] : node.diagnostics())
      if (name == hemo::kCheckpointDiagnostic) return value;
    return -1.0;
  };
  ASSERT_EQ(node.advance(order(1), fluid), "");
  EXPECT_EQ(acknowledged(), -1.0);
  ASSERT_EQ(node.advance(order(2), fluid), "");
  node.write_checkpoint();
  EXPECT_EQ(acknowledged(), 2.0);
  EXPECT_EQ(acknowledged(), -1.0);
  EXPECT_TRUE(fs::is_regular_file(dir / "checkpoints/step-2/particles/node.h5"));
  EXPECT_TRUE(fs::is_regular_file(dir / "checkpoints/step-2/particles/engine-rank0.h5"));
  EXPECT_FALSE(fs::exists(dir / "checkpoints/step-2/particles.partial"));
  fs::remove_all(dir);
}

TEST(NodeCheckpoint, ResumingKeepsTheSnapshotsUpToTheCheckpointAndDropsTheLaterOnes) {
  const auto scene = contact_scene(0.05);
  const auto mesh = wedge_mesh(16, 8, kR, kL, "wedge16");
  const auto fluid = fluid_state(mesh, poiseuille(kR, 799 * kR / 2));
  const fs::path dir = fresh_dir("hemo_ckpt_snap");
  const std::string h5 = (dir / "particles.h5").string();
  {
    ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= 5; ++k) take_step(node, k, fluid, k == 3);
  }
  ASSERT_EQ(list_snapshots(h5), (std::vector<long>{0, 1, 2, 3, 4, 5}));
  const auto zero = read_snapshot(h5, 0), three = read_snapshot(h5, 3), four = read_snapshot(h5, 4);
  const auto log_size = fs::file_size(dir / "liggghts.log");

  ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD, 3);  // in place, as the coordinator resumes
  // Untouched until the resumed node writes its first snapshot: a start that fails loses nothing.
  EXPECT_EQ(list_snapshots(h5), (std::vector<long>{0, 1, 2, 3, 4, 5}));
  take_step(node, 4, fluid);
  EXPECT_TRUE(same(read_snapshot(h5, 0).position, zero.position, "snapshot 0"));  // not written again
  EXPECT_TRUE(same(read_snapshot(h5, 3).position, three.position, "snapshot 3"));
  EXPECT_EQ(list_snapshots(h5), (std::vector<long>{0, 1, 2, 3, 4}));
  EXPECT_TRUE(same(read_snapshot(h5, 4).position, four.position, "snapshot 4 written again"));
  EXPECT_GE(fs::file_size(dir / "liggghts.log"), log_size);  // appended to, not started again
  fs::remove_all(dir);
}

TEST(NodeCheckpoint, MissingOrDamagedCheckpointIsAOneLineErrorThatChangesNothing) {
  const auto scene = contact_scene(0.05);
  const auto mesh = wedge_mesh(16, 8, kR, kL, "wedge16");
  const auto fluid = fluid_state(mesh, poiseuille(kR, 799 * kR / 2));
  const fs::path dir = fresh_dir("hemo_ckpt_bad");
  const std::string h5 = (dir / "particles.h5").string();
  {
    ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= 3; ++k) take_step(node, k, fluid, k == 2);
  }
  auto resume_error = [&](long step) -> std::string {
    try {
      ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD, step);
    } catch (const CheckpointError& e) {
      return e.what();
    }
    return "";
  };
  const std::string missing = resume_error(7);
  EXPECT_NE(missing.find("cannot resume from step 7: no particles checkpoint of step 7 in"), std::string::npos)
      << missing;
  EXPECT_EQ(missing.find('\n'), std::string::npos);

  // A damaged file of the checkpoint (cut short) is named.
  const fs::path engine_file = dir / "checkpoints/step-2/particles/engine-rank0.h5";
  fs::resize_file(engine_file, fs::file_size(engine_file) / 2);
  const std::string damaged = resume_error(2);
  EXPECT_NE(damaged.find("cannot resume from step 2: checkpoint file"), std::string::npos) << damaged;
  EXPECT_NE(damaged.find("engine-rank0.h5"), std::string::npos) << damaged;
  EXPECT_EQ(damaged.find('\n'), std::string::npos);

  // A checkpoint of another mesh is refused.
  const auto other_mesh = wedge_mesh(16, 8, kR, kL, "other-mesh");
  try {
    ParticleNode node(scene, other_mesh, dir.string(), MPI_COMM_WORLD, 2);
    ADD_FAILURE() << "resumed on another mesh";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("mesh 'wedge16'"), std::string::npos) << e.what();
  }

  EXPECT_EQ(list_snapshots(h5), (std::vector<long>{0, 1, 2, 3}));  // nothing was dropped
  fs::remove_all(dir);
}
