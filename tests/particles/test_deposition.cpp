// SPDX-License-Identifier: GPL-3.0-or-later
#include "box_mesh.h"
#include "deposition.h"

#include <gtest/gtest.h>

#include <random>

using namespace hemo::particles;
using hemo::particles::testing::box_mesh;
using hemo::particles::testing::fluid_state;
using hemo::particles::testing::poiseuille;

TEST(Deposition, ConservesVolumeAndMomentumToRoundOff) {
  const double R = 25e-6, L = 100e-6;
  const auto mesh = box_mesh(4, 4, 6, -R, R, -R, R, L, 2 * R);
  const CellLocator loc(mesh);
  FluidSampler fluid(loc);
  fluid.set_state(fluid_state(mesh, poiseuille(R, 0.01)));
  Deposition dep(loc);

  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(-R, R), uz(0, 3 * L), uf(-1e-9, 1e-9), ub(1e-8, 6e-8), uv(1e-17, 9e-17);
  const double interval = 1e-5;
  const int substeps = 7;
  const double dt = interval / substeps;
  Vec3 force_sum = Vec3::Zero();
  double volume_sum = 0;
  dep.clear_drag();
  dep.clear_volume();
  for (int p = 0; p < 300; ++p) {
    const Vec3 x(ux(rng), ux(rng), uz(rng));
    const int c = loc.locate(x);
    ASSERT_GE(c, 0);
    for (int s = 0; s < substeps; ++s) {
      const Vec3 f(uf(rng), uf(rng), uf(rng));
      dep.add_drag(c, f, ub(rng), dt);
      force_sum += f * dt / interval;
    }
    const double vp = uv(rng);
    dep.add_volume(c, loc.wrap(x), vp);
    volume_sum += vp;
  }
  hemo::particle_feedback_t fb;
  dep.finish(interval, &fluid, fb);
  ASSERT_EQ(fb.n_cells, loc.n_cells());

  double phi_v = 0;
  Vec3 fluid_gets = Vec3::Zero();  // sum over cells of (S - K u) V at the velocity the particles saw
  for (int c = 0; c < fb.n_cells; ++c) {
    EXPECT_GE(fb.drag_coefficient[c], 0.0);
    phi_v += fb.solid_fraction[c] * loc.volume(c);
    const Vec3 s(fb.source_explicit[c][0], fb.source_explicit[c][1], fb.source_explicit[c][2]);
    fluid_gets += (s - fb.drag_coefficient[c] * fluid.cell_velocity(c)) * loc.volume(c);
  }
  EXPECT_NEAR(phi_v, volume_sum, 1e-13 * volume_sum);
  EXPECT_NEAR(dep.total_volume(), volume_sum, 1e-13 * volume_sum);
  const Vec3 total(fb.total_particle_force[0], fb.total_particle_force[1], fb.total_particle_force[2]);
  const double scale = 300 * 1e-9;
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(total[d], force_sum[d], 1e-14 * scale);
    EXPECT_NEAR(fluid_gets[d], -force_sum[d], 1e-14 * scale);
    EXPECT_NEAR(dep.total_force(interval)[d], force_sum[d], 1e-14 * scale);
  }
}

TEST(Deposition, ClearingStartsAFreshInterval) {
  const auto mesh = box_mesh(2, 2, 2, 0, 1, 0, 1, 1, 1);
  const CellLocator loc(mesh);
  Deposition dep(loc);
  dep.add_drag(3, Vec3(1, 2, 3), 4, 0.5);
  dep.add_volume(3, loc.centre(3), 0.01);
  dep.clear_drag();
  EXPECT_EQ(dep.total_force(1.0).norm(), 0.0);
  EXPECT_DOUBLE_EQ(dep.total_volume(), 0.01);  // volumes are cleared separately
  dep.clear_volume();
  EXPECT_EQ(dep.total_volume(), 0.0);
  hemo::particle_feedback_t fb;
  dep.finish(0.0, nullptr, fb);  // step 0: no interval yet
  for (int c = 0; c < fb.n_cells; ++c) EXPECT_EQ(fb.drag_coefficient[c], 0.0);
}
