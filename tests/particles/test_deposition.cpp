// SPDX-License-Identifier: GPL-3.0-or-later
#include "synthetic_case.h"
#include "cell_fields.h"
#include "deposition.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace hemo::particles;
using hemo::particles::synthetic::box_mesh;
using hemo::particles::synthetic::fluid_state;
using hemo::particles::synthetic::poiseuille;

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
    dep.add_particle(c, loc.wrap(x), 1e-6, vp, Vec3::Zero(), 0.0);
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
    const Vec3 s = Eigen::Map<const Vec3>(hemo::source_of(fb, c));
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
  dep.add_particle(3, loc.centre(3), 0.1, 0.01, Vec3::Zero(), 0.0);
  dep.clear_drag();
  EXPECT_EQ(dep.total_force(1.0).norm(), 0.0);
  EXPECT_DOUBLE_EQ(dep.total_volume(), 0.01);  // volumes are cleared separately
  dep.clear_volume();
  EXPECT_EQ(dep.total_volume(), 0.0);
  hemo::particle_feedback_t fb;
  dep.finish(0.0, nullptr, fb);  // step 0: no interval yet
  for (int c = 0; c < fb.n_cells; ++c) EXPECT_EQ(fb.drag_coefficient[c], 0.0);
}

namespace {
// phi_c V_c per cell for one particle of radius r at x, sphere_overlap model.
std::vector<double> shares_of(const CellLocator& loc, const Vec3& x, double r) {
  Deposition dep(loc, make_solid_fraction_model("sphere_overlap", loc));
  const int c = loc.locate(x);
  EXPECT_GE(c, 0);
  dep.add_particle(c, loc.wrap(x), r, 1.0, Vec3::Zero(), 0.0);
  std::vector<double> v(loc.n_cells());
  for (int k = 0; k < loc.n_cells(); ++k) v[k] = dep.data()[k * Deposition::kStride + Deposition::kVolume];
  return v;
}
constexpr double kPi = 3.14159265358979323846;
}  // namespace

TEST(SphereOverlap, ExactCapAcrossOneFace) {
  // Cells of 10 um; a sphere of radius 2 um whose centre is 0.5 um from the face x = 0.
  const auto mesh = box_mesh(4, 4, 4, -20e-6, 20e-6, -20e-6, 20e-6, 40e-6, 40e-6);
  const CellLocator loc(mesh);
  const double r = 2e-6, inside = 0.5e-6, h = r - inside;
  const Vec3 x(-inside, -5e-6, 15e-6);  // cell i = 1 (x in [-10, 0]), centred in y and z
  const auto v = shares_of(loc, x, r);
  const int own = loc.locate(x), beyond = loc.locate(Vec3(1e-6, -5e-6, 15e-6));
  const double cap = h * h * (3 * r - h) / (4 * r * r * r);
  EXPECT_NEAR(v[beyond], cap, 1e-14);
  EXPECT_NEAR(v[own], 1 - cap, 1e-14);
  // A centre on the face shares half and half; a sphere inside one cell stays whole.
  EXPECT_NEAR(shares_of(loc, Vec3(1e-18, -5e-6, 15e-6), r)[beyond], 0.5, 1e-9);
  EXPECT_EQ(shares_of(loc, Vec3(-5e-6, -5e-6, 15e-6), r)[own], 1.0);
}

TEST(SphereOverlap, WrapsAcrossThePeriodicEndsAndKeepsWhatIsBehindAWall) {
  const auto mesh = box_mesh(4, 4, 4, -20e-6, 20e-6, -20e-6, 20e-6, 40e-6, 40e-6);
  const CellLocator loc(mesh);
  const double r = 2e-6;
  // Centre 1 um above z = 0: the cap below goes to the top layer (periodic partner).
  const auto v = shares_of(loc, Vec3(-5e-6, -5e-6, 1e-6), r);
  const int top = loc.locate(Vec3(-5e-6, -5e-6, 39.5e-6));
  const double h = 1e-6;
  EXPECT_NEAR(v[top], h * h * (3 * r - h) / (4 * r * r * r), 1e-14);
  // Next to the wall x = -20 um: nothing goes beyond it.
  const auto w = shares_of(loc, Vec3(-19.5e-6, -5e-6, 15e-6), r);
  EXPECT_NEAR(w[loc.locate(Vec3(-19.5e-6, -5e-6, 15e-6))], 1.0, 1e-15);
}

TEST(SphereOverlap, ConservesVolumeAndMomentumCellByCellAndIsContinuous) {
  const double R = 25e-6, L = 100e-6;
  const auto mesh = box_mesh(4, 4, 6, -R, R, -R, R, L, 2 * R);
  const CellLocator loc(mesh);
  FluidSampler fluid(loc);
  fluid.set_state(fluid_state(mesh, poiseuille(R, 0.01)));
  Deposition dep(loc, make_solid_fraction_model("sphere_overlap", loc));
  EXPECT_EQ(dep.model().name(), "sphere_overlap");
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> ux(-R, R), uz(0, L), uf(-1e-9, 1e-9), ub(1e-8, 6e-8);
  const double interval = 1e-5, r = 2.78e-6, vp = 90e-18;
  std::vector<Vec3> per_cell_force(loc.n_cells(), Vec3::Zero());  // what each cell's share was
  Vec3 force_sum = Vec3::Zero();
  double volume_sum = 0;
  for (int p = 0; p < 400; ++p) {
    const Vec3 x(ux(rng), ux(rng), uz(rng));
    const int c = loc.locate(x);
    ASSERT_GE(c, 0);
    const Vec3 impulse = Vec3(uf(rng), uf(rng), uf(rng)) * interval;
    dep.add_particle(c, loc.wrap(x), r, vp, impulse, ub(rng) * interval);
    force_sum += impulse / interval;
    volume_sum += vp;
  }
  hemo::particle_feedback_t fb;
  dep.finish(interval, &fluid, fb);
  double phi_v = 0;
  Vec3 fluid_gets = Vec3::Zero();
  for (int c = 0; c < fb.n_cells; ++c) {
    phi_v += fb.solid_fraction[c] * loc.volume(c);
    const Vec3 s = Eigen::Map<const Vec3>(hemo::source_of(fb, c));
    // Cell by cell: (S - K u_c) V = -(the share of the force deposited in c).
    const double* a = dep.data() + c * Deposition::kStride;
    const Vec3 share_force = Vec3(a[0], a[1], a[2]) / interval;
    EXPECT_LT(((s - fb.drag_coefficient[c] * fluid.cell_velocity(c)) * loc.volume(c) + share_force).norm(),
              1e-15 * 400e-9);
    fluid_gets += (s - fb.drag_coefficient[c] * fluid.cell_velocity(c)) * loc.volume(c);
    EXPECT_GE(fb.solid_fraction[c], 0.0);
  }
  EXPECT_NEAR(phi_v, volume_sum, 1e-13 * volume_sum);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(fluid_gets[d], -force_sum[d], 1e-14 * 400e-9);

  // Continuity: a particle walked across faces, edges and the periodic end in 0.01 um steps;
  // no cell's share jumps by more than the step allows (centre_cell would jump by 1).
  double worst = 0;
  std::vector<double> prev = shares_of(loc, Vec3(-20e-6, -20e-6, L - 3e-6), r);
  for (int k = 1; k <= 2000; ++k) {
    const Vec3 x = Vec3(-20e-6, -20e-6, L - 3e-6) + k * Vec3(0.01e-6, 0.017e-6, 0.013e-6);
    const auto now = shares_of(loc, x, r);
    for (int c = 0; c < loc.n_cells(); ++c) worst = std::max(worst, std::abs(now[c] - prev[c]));
    prev = now;
  }
  std::printf("[ info ] sphere_overlap: largest change of a cell's share per 0.02 um step: %.3g\n", worst);
  EXPECT_LT(worst, 0.02);
}
