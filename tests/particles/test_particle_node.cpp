// SPDX-License-Identifier: GPL-3.0-or-later
// The node's steps without the bus: set-up, step-0 feedback, a few coupled steps in a synthetic
// Poiseuille flow on a polygonal vessel mesh, output, diagnostics, fluid-state checks.
#include "synthetic_case.h"
#include "cell_fields.h"
#include "h5_output.h"
#include "particle_node.h"

#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>
#include <filesystem>
#include <map>

using namespace hemo::particles;
using namespace hemo::particles::synthetic;

TEST(ParticleNode, RunsCoupledStepsAndReportsWhatTheCoordinatorNeeds) {
  const double R = 25e-6, L = 100e-6;
  const auto scene = blood_scene(2 * R, L, 0.15);
  const auto mesh = wedge_mesh(16, 8, R, L, "wedge16");
  const auto dir = std::filesystem::temp_directory_path() / ("hemo_node_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD);

  // Step 0: the volumes, no force yet.
  auto fb = node.feedback();
  ASSERT_EQ(fb.n_cells, mesh.n_cells);
  EXPECT_EQ(fb.mesh_hash, "wedge16");
  double solid = 0;
  for (int c = 0; c < fb.n_cells; ++c) solid += fb.solid_fraction[c] * mesh.cell_volumes[c];
  EXPECT_NEAR(solid, rbc_count(scene) * scene.rbc.volume + platelet_count(scene) * scene.platelet.volume, 1e-6 * solid);
  EXPECT_EQ(fb.total_particle_force[2], 0.0);

  auto fluid = fluid_state(mesh, poiseuille(R, 799 * R / 2));
  EXPECT_EQ(node.check(fluid), "");
  for (int k = 1; k <= 5; ++k) {
    hemo::step_order_t order;
    order.envelope.step = k;
    order.dt_s = 1e-5;
    order.time_s = k * 1e-5;
    ASSERT_EQ(node.advance(order, fluid), "");
    if (k == 5) node.write_output(node.step(), node.time());
  }
  fb = node.feedback();
  std::map<std::string, double> diag;
  for (const auto& [name, value] : node.diagnostics()) diag[name] = value;
  for (const char* name :
       {"particles", "dem_substeps", "total_force_x_N", "total_force_y_N", "total_force_z_N",
        "core_particle_axial_velocity_m_s", "core_fluid_axial_velocity_m_s", "max_overlap", "particles_outside_mesh"})
    EXPECT_TRUE(diag.count(name)) << name;
  EXPECT_EQ(diag["particles"], rbc_count(scene) + platelet_count(scene));
  EXPECT_EQ(diag["particles_outside_mesh"], 0);
  EXPECT_NEAR(diag["core_particle_axial_velocity_m_s"], diag["core_fluid_axial_velocity_m_s"],
              0.02 * diag["core_fluid_axial_velocity_m_s"]);
  EXPECT_EQ(diag["total_force_z_N"], fb.total_particle_force[2]);
  // The fluid gets back minus the particle force: sum over cells of (S - K u_c) V = -F.
  double back = 0;
  for (int c = 0; c < fb.n_cells; ++c)
    back +=
        (hemo::source_of(fb, c)[2] - fb.drag_coefficient[c] * hemo::velocity_of(fluid, c)[2]) * mesh.cell_volumes[c];
  EXPECT_NEAR(back, -fb.total_particle_force[2], 1e-12 * std::abs(diag["core_fluid_axial_velocity_m_s"] * 1e-6));

  EXPECT_EQ(list_snapshots((dir / "particles.h5").string()), (std::vector<long>{0, 5}));
  const auto snap = read_snapshot((dir / "particles.h5").string(), 5);
  EXPECT_DOUBLE_EQ(snap.time_s, 5e-5);
  EXPECT_EQ(static_cast<double>(snap.size()), diag["particles"]);

  // A fluid state of another mesh, or with a NaN, is refused with a reason.
  auto other = fluid;
  other.mesh_hash = "other";
  EXPECT_NE(node.check(other).find("mesh"), std::string::npos);
  auto nan = fluid;
  hemo::gradient_of(nan, 3)[4] = std::nan("");
  EXPECT_NE(node.check(nan).find("cell 3"), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(ParticleNode, WarnsOnceWhenRedCellsLeaveTheDragFitsRange) {
  // Plasma at 0.3 m/s along z past cells at rest: RBC Re = 1.4 at the first steps, above the
  // rbc_fit law's 0.5; warned once however many steps follow. Orientation and the
  // sphere_overlap deposition are on (the paper's closures).
  const double R = 25e-6, L = 100e-6;
  auto scene = blood_scene(2 * R, L, 0.05);
  use_paper_closures(scene);
  const auto mesh = wedge_mesh(16, 8, R, L, "wedge16");
  const auto dir = std::filesystem::temp_directory_path() / ("hemo_node_re_" + std::to_string(::getpid()));
  ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD);
  const auto fluid = fluid_state(mesh, [](const auto&, auto& u, auto& g) {
    u = {0, 0, 0.3};
    g = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  });
  for (int k = 1; k <= 3; ++k) {
    hemo::step_order_t order;
    order.envelope.step = k;
    order.dt_s = 1e-5;
    order.time_s = k * 1e-5;
    ASSERT_EQ(node.advance(order, fluid), "");
    if (k == 1) {
      std::map<std::string, double> diag;
      for (const auto& [name, value] : node.diagnostics()) diag[name] = value;
      EXPECT_GT(diag["max_reynolds_rbc"], 0.5);
      EXPECT_NEAR(diag["solid_volume_m3"],
                  rbc_count(scene) * scene.rbc.volume + platelet_count(scene) * scene.platelet.volume,
                  1e-9 * diag["solid_volume_m3"]);
    }
  }
  EXPECT_EQ(node.reynolds_warnings(), 1);
  node.write_output(node.step(), node.time());
  const auto snap = read_snapshot((dir / "particles.h5").string(), 3);
  EXPECT_EQ(snap.orientation.size(), 4 * snap.size());
  std::filesystem::remove_all(dir);
}
