// SPDX-License-Identifier: GPL-3.0-or-later
// The LIGGGHTS engine on a synthetic fluid: a few hundred cells in a 50 um x 100 um vessel.
#include "box_mesh.h"
#include "dem_engine.h"
#include "dem_timing.h"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

using namespace hemo::particles;
using namespace hemo::particles::testing;

namespace {

struct Fixture {
  double interval = 1e-5;
  hemo::Scene scene;
  hemo::mesh_t mesh;
  CellLocator locator;
  FluidSampler fluid;
  Deposition deposition;
  DemEngine engine;
  DemTiming timing;

  explicit Fixture(double hematocrit = 0.15)
      : scene(blood_scene(50e-6, 100e-6, hematocrit)),
        mesh(box_mesh(6, 6, 8, -25e-6, 25e-6, -25e-6, 25e-6, 100e-6, 50e-6)),
        locator(mesh),
        fluid(locator),
        deposition(locator),
        engine(scene, locator, log_path(), MPI_COMM_WORLD),
        timing(derive_dem_timing(scene, interval)) {}

  static std::string log_path() {
    return (std::filesystem::temp_directory_path() / ("hemo_engine_" + std::to_string(::getpid()) + ".log")).string();
  }

  double mass(int species) const { return species == kRbc ? scene.rbc.mass : scene.platelet.mass; }

  Vec3 momentum() {
    const auto s = engine.snapshot(0, 0);
    Vec3 p = Vec3::Zero();
    for (std::size_t i = 0; i < s.size(); ++i)
      p += mass(s.species[i]) * Vec3(s.velocity[3 * i], s.velocity[3 * i + 1], s.velocity[3 * i + 2]);
    return p;
  }
};

}  // namespace

TEST(DemEngine, FollowsPoiseuilleAndConservesMomentum) {
  Fixture fx(0.05);
  const double R = 25e-6, L = 100e-6, u_max = 799 * R / 2;
  fx.fluid.set_state(fluid_state(fx.mesh, poiseuille(R, u_max)));
  // Particles within 0.6 R: no wall contact in this short run, so the fluid is the only
  // external force and the particles' momentum must change by exactly the reported impulse.
  auto requests = placement_requests(fx.scene);
  const auto placed = place_particles(0.6 * R, L, 0, requests, 9);
  fx.engine.create_particles(placed);
  ASSERT_EQ(fx.engine.particle_count(), static_cast<long>(placed.size()));
  ASSERT_GT(placed.size(), 100u);

  Vec3 p_before = fx.momentum();
  double worst = 0;
  EXPECT_EQ(p_before.norm(), 0.0);
  for (int step = 1; step <= 20; ++step) {
    const std::string error = fx.engine.run(step, fx.timing.substeps, fx.timing.dt, fx.fluid);
    ASSERT_EQ(error, "");
    fx.engine.deposit(fx.deposition);
    const Vec3 p_after = fx.momentum();
    const Vec3 impulse = fx.deposition.total_force(fx.interval) * fx.interval;
    worst = std::max(worst, (p_after - p_before - impulse).norm() / p_after.norm());
    if (std::getenv("HEMO_VERBOSE")) std::printf("step %d dp %.6e impulse %.6e diff %.3e\n", step, (p_after - p_before).z(), impulse.z(), (p_after - p_before - impulse).norm());
    EXPECT_NEAR((p_after - p_before - impulse).norm(), 0.0, 1e-12 * (p_after.norm() + 1e-30))
        << "step " << step << ": dp = " << (p_after - p_before).transpose() << ", impulse = " << impulse.transpose();
    p_before = p_after;
  }
  // Solid volume: every particle's volume, once.
  double expected_volume = 0;
  for (const auto& p : placed) expected_volume += p.species == kRbc ? fx.scene.rbc.volume : fx.scene.platelet.volume;
  EXPECT_NEAR(fx.deposition.total_volume(), expected_volume, 1e-12 * expected_volume);

  const auto d = fx.engine.diagnostics(&fx.fluid);
  std::printf("[ info ] %ld particles, %d substeps of %.3g s; worst |dp - impulse| / |p| = %.2e; core v_z %.6g "
              "vs fluid %.6g m/s (%ld particles); max overlap %.3g\n",
              d.particles, fx.timing.substeps, fx.timing.dt, worst, d.core_particle_axial_velocity,
              d.core_fluid_axial_velocity, d.core_particles, d.max_overlap);
  EXPECT_EQ(d.outside_mesh, 0);
  EXPECT_EQ(d.particles, static_cast<long>(placed.size()));
  ASSERT_GT(d.core_particles, 20);
  // 0.2 ms is > 100 drag relaxation times: core particles move with the plasma.
  EXPECT_NEAR(d.core_particle_axial_velocity, d.core_fluid_axial_velocity, 0.01 * d.core_fluid_axial_velocity);
  EXPECT_GT(d.core_fluid_axial_velocity, 0.75 * u_max);
  EXPECT_LT(d.max_overlap, 0.05);
}

TEST(DemEngine, UnwrapsZAcrossThePeriodicEnds) {
  Fixture fx;
  const double R = 25e-6, L = 100e-6, u = 0.5;  // plug flow: 50 um per 0.1 ms
  fx.fluid.set_state(fluid_state(fx.mesh, [&](const auto&, auto& vel, auto& grad) {
    vel = {0, 0, u};
    grad = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  }));
  const auto placed = place_particles(0.8 * R, L, 0, {{kPlatelet, fx.scene.platelet.diameter, 40}}, 3);
  fx.engine.create_particles(placed);
  const auto start = fx.engine.snapshot(0, 0);
  const int steps = 40;  // 0.4 ms: 2 periods
  for (int step = 1; step <= steps; ++step) ASSERT_EQ(fx.engine.run(step, fx.timing.substeps, fx.timing.dt, fx.fluid), "");
  const auto end = fx.engine.snapshot(steps, steps * fx.interval);
  const double travel = u * steps * fx.interval;  // 200 um
  for (std::size_t i = 0; i < end.size(); ++i) {
    const double dz = end.position[3 * i + 2] - start.position[3 * i + 2];
    EXPECT_GT(dz, travel - 2e-6) << "particle " << end.id[i];  // lags by u tau ~ 0.15 um only
    EXPECT_LE(dz, travel + 1e-9) << "particle " << end.id[i];
  }
  EXPECT_EQ(fx.engine.diagnostics(&fx.fluid).outside_mesh, 0);
}

TEST(DemEngine, ParticleOutsideTheMeshStopsTheRunNamingIt) {
  // The fluid mesh covers only r < R/2 of the vessel the DEM wall bounds.
  const double R = 25e-6, L = 100e-6;
  const auto scene = blood_scene(2 * R, L, 0.05);
  auto mesh = wedge_mesh(8, 4, 0.5 * R, L);
  mesh.vessel_diameter_m = 2 * R;
  const CellLocator locator(mesh);
  FluidSampler fluid(locator);
  fluid.set_state(fluid_state(mesh, poiseuille(R, 0.01)));
  DemEngine engine(scene, locator, "none", MPI_COMM_WORLD);
  engine.create_particles(place_particles(R, L, 0, placement_requests(scene), 4));
  const std::string error = engine.run(7, 10, 1e-7, fluid);
  EXPECT_NE(error.find("particle 1 is outside the fluid mesh at coupling step 7"), std::string::npos) << error;
  EXPECT_GT(engine.diagnostics(&fluid).outside_mesh, 0);
}

TEST(DemEngine, RefusesClosuresItDoesNotHave) {
  const auto mesh = box_mesh(2, 2, 2, -25e-6, 25e-6, -25e-6, 25e-6, 100e-6, 50e-6);
  const CellLocator locator(mesh);
  auto scene = blood_scene(50e-6, 100e-6);
  scene.platelet.lift = "saffman";
  EXPECT_THROW(DemEngine(scene, locator, "none", MPI_COMM_WORLD), std::invalid_argument);
  scene.platelet.lift = "none";
  scene.rbc.drag = "unknown";
  EXPECT_THROW(DemEngine(scene, locator, "none", MPI_COMM_WORLD), std::invalid_argument);
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  const int result = RUN_ALL_TESTS();
  MPI_Finalize();
  return result;
}
