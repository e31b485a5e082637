// SPDX-License-Identifier: GPL-3.0-or-later
// The particle node in an open vessel fed by a feeder (docs/design.md, "Open ends"), without the
// bus, on the real two-region mesh of the fluid node: a flow through both tubes carries cells out
// through the outlet and copies of the feeder's cells in through the inlet. At every step the
// cells present are those created plus those inserted minus those that left; the snapshots hold
// the vessel's cells only, each tag once, none past the outlet, and tags freed at the outlet are
// given again; a node resumed from a checkpoint goes on bit for bit as the node that wrote it,
// its counts included. On one rank and on two (ctest particles.OpenVessel.ranks2).
#include "checkpoint_case.h"

#include <vessel_ends.h>
#include <vessel_mesh.h>

#include <gtest/gtest.h>
#include <mpi.h>

#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

using namespace hemo::particles;
using namespace hemo::particles::testing;
namespace fs = std::filesystem;

namespace {

constexpr double kD = 50e-6, kL = 100e-6;
constexpr double kPlug = 0.1;  // m/s: a cell crosses the vessel in 100 coupling steps

hemo::Scene open_scene() {
  auto scene = synthetic::blood_scene(kD, kL, 0.15);
  synthetic::use_paper_closures(scene);
  scene.time.closure_every_dem_steps = 3;  // held closures: a copy's name the vessel's cell
  scene.vessel.ends = "open";
  scene.mesh.core_cells = 4;
  scene.mesh.ring_cells = 2;
  scene.mesh.axial_cells = 4;  // 25 um layers: the feeder is 2 longer (150 um)
  return scene;
}

hemo::mesh_t mesh_of(const hemo::Scene& scene) {
  const auto poly = hemo::make_vessel_mesh(scene.vessel, scene.mesh);
  hemo::mesh_t message;
  hemo::fill_mesh_message(poly, hemo::compute_geometry(poly), scene.vessel, message);
  return message;
}

// A plug flow with Poiseuille flow on it, in each tube about its own axis.
synthetic::FieldAt through_both_tubes(const hemo::FeederLayout& feeder) {
  const synthetic::FieldAt shear = synthetic::poiseuille(kD / 2, 0.05);
  return [=](const std::array<double, 3>& x, std::array<double, 3>& u, std::array<double, 9>& g) {
    const Vec3 local = feeder.in_vessel_frame(Vec3(x[0], x[1], x[2]));
    shear({local.x(), local.y(), local.z()}, u, g);
    u[2] += kPlug;
  };
}

using Diagnostic = std::map<std::string, double>;
Diagnostic diagnostic(ParticleNode& node) {
  Diagnostic d;
  for (const auto& [name, value] : node.diagnostics()) d[name] = value;
  return d;
}

long left_and_entered(const Diagnostic& d, const char* what) {
  return static_cast<long>(d.at(std::string("rbc_") + what) + d.at(std::string("platelet_") + what));
}

}  // namespace

TEST(OpenVessel, CountsBalanceAtEveryStepAndTheCellsFlowThrough) {
  const auto scene = open_scene();
  const auto feeder = hemo::feeder_layout(scene);
  const auto mesh = mesh_of(scene);
  const auto fluid = synthetic::fluid_state(mesh, through_both_tubes(feeder));
  const fs::path dir = checkpoint_case::shared_dir("hemo_open_vessel");
  ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD);
  const Diagnostic start = diagnostic(node);
  const long created = static_cast<long>(start.at("particles"));
  EXPECT_EQ(left_and_entered(start, "inserted"), 0);
  EXPECT_GT(created, static_cast<long>(start.at("particles_in_vessel")));  // the feeder has its own

  const std::string h5 = (dir / "particles.h5").string();
  std::map<long, std::set<std::int64_t>> ids;  // the vessel's tags per step
  const long steps = 130;
  for (long k = 1; k <= steps; ++k) {
    const auto o = checkpoint_case::order(k);
    ASSERT_EQ(node.check(fluid), "");
    ASSERT_EQ(node.advance(o, fluid), "") << "step " << k;
    node.write_output(node.step(), node.time());
    const Diagnostic d = diagnostic(node);
    const long inserted = left_and_entered(d, "inserted"), out = left_and_entered(d, "left_outlet"),
               back = left_and_entered(d, "left_inlet");
    EXPECT_EQ(static_cast<long>(d.at("particles")), created + inserted - out - back) << "step " << k;
    EXPECT_EQ(d.at("particles_lost"), 0) << "step " << k;

    if (checkpoint_case::world_rank() != 0) continue;  // the first rank writes, and holds, particles.h5
    const auto snap = read_snapshot(h5, k);
    EXPECT_EQ(static_cast<double>(snap.size()), d.at("particles_in_vessel")) << "step " << k;
    for (std::size_t i = 0; i < snap.size(); ++i) {
      EXPECT_TRUE(ids[k].insert(snap.id[i]).second) << "tag " << snap.id[i] << " twice at step " << k;
      const double x = snap.position[3 * i], z = snap.position[3 * i + 2];
      EXPECT_LT(x, feeder.split_x) << "a feeder cell written at step " << k;
      EXPECT_GE(z, 0.0) << "tag " << snap.id[i] << " before the inlet at step " << k;
      EXPECT_LT(z, kL) << "tag " << snap.id[i] << " past the outlet at step " << k;
    }
  }
  const Diagnostic end = diagnostic(node);
  std::printf("[ info ] %ld created; by step %ld: %ld inserted (%g RBC), %ld left through the outlet, %ld back\n",
              created, steps, left_and_entered(end, "inserted"), end.at("rbc_inserted"),
              left_and_entered(end, "left_outlet"), left_and_entered(end, "left_inlet"));
  // The plug carries every vessel cell past the outlet within the run, and the feeder's in.
  EXPECT_GT(end.at("rbc_inserted"), 0);
  EXPECT_GT(end.at("platelet_inserted"), 0);
  EXPECT_GT(end.at("rbc_left_outlet"), 0);
  EXPECT_GT(end.at("platelet_left_outlet"), 0);
  EXPECT_EQ(left_and_entered(end, "left_inlet"), 0);  // nothing flows back
  if (checkpoint_case::world_rank() != 0) return;
  std::set<std::int64_t> reused;  // tags in the vessel at step 1, gone, and in it again
  for (const auto id : ids[1])
    for (long a = 2; a < steps && !reused.count(id); ++a)
      if (!ids[a].count(id))
        for (long b = a + 1; b <= steps && !reused.count(id); ++b)
          if (ids[b].count(id)) reused.insert(id);
  EXPECT_FALSE(reused.empty()) << "no tag freed at the outlet was given again";
  fs::remove_all(dir);
}

TEST(OpenVessel, ResumedNodeGoesOnBitForBitWithItsCounts) {
  const auto scene = open_scene();
  const auto feeder = hemo::feeder_layout(scene);
  const auto mesh = mesh_of(scene);
  const auto fluid = synthetic::fluid_state(mesh, through_both_tubes(feeder));
  const long K = 40, N = 8;  // by step 40 cells have left and entered
  const fs::path a_dir = checkpoint_case::shared_dir("hemo_open_a"), b_dir = checkpoint_case::shared_dir("hemo_open_b");
  std::map<long, hemo::particle_feedback_t> written;
  std::map<long, Diagnostic> counted;
  {
    ParticleNode node(scene, mesh, a_dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= K + N; ++k) {
      const auto o = checkpoint_case::order(k);
      ASSERT_EQ(node.advance(o, fluid), "") << "step " << k;
      written[k] = node.feedback();
      node.write_output(node.step(), node.time());
      if (k == K) node.write_checkpoint();
      counted[k] = diagnostic(node);
    }
  }
  EXPECT_GT(counted[K].at("rbc_inserted"), 0);
  EXPECT_GT(counted[K].at("rbc_left_outlet"), 0);
  EXPECT_GT(counted[K + N].at("rbc_inserted"), counted[K].at("rbc_inserted"));
  if (checkpoint_case::world_rank() == 0) fs::copy(a_dir, b_dir, fs::copy_options::recursive);
  MPI_Barrier(MPI_COMM_WORLD);
  ParticleNode resumed(scene, mesh, b_dir.string(), MPI_COMM_WORLD, K);
  checkpoint_case::expect_same_feedback(resumed.feedback(), written[K], K);
  resumed.diagnostics();
  const std::string a_h5 = (a_dir / "particles.h5").string(), b_h5 = (b_dir / "particles.h5").string();
  for (long k = K + 1; k <= K + N; ++k) {
    const auto o = checkpoint_case::order(k);
    ASSERT_EQ(resumed.advance(o, fluid), "") << "step " << k;
    checkpoint_case::expect_same_feedback(resumed.feedback(), written[k], k);
    resumed.write_output(resumed.step(), resumed.time());
    if (checkpoint_case::world_rank() == 0) checkpoint_case::expect_same_snapshot(a_h5, b_h5, k);
    const Diagnostic d = diagnostic(resumed);
    for (const char* count : {"particles", "rbc_inserted", "platelet_inserted", "rbc_left_outlet",
                              "platelet_left_outlet", "rbc_left_inlet", "platelet_left_inlet"})
      EXPECT_EQ(d.at(count), counted[k].at(count)) << count << " at step " << k;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  if (checkpoint_case::world_rank() == 0) {
    fs::remove_all(a_dir);
    fs::remove_all(b_dir);
  }
}
