// The Gaussian kernel (particle-node/gaussian_kernel.h) on a real CellLocator mesh of cells
// narrower than the particle: 2.5-um cubes (a 30-um parent's d/12) and a red cell of 5.56 um.
// Its fractions are the formula's, brute-forced over every cell (so nothing is shared behind a
// wall and the periodic end is crossed as the interior is); the deposition keeps sum phi V and the
// feedback identity cell by cell; the shares change smoothly as a centre crosses faces; the fluid
// a particle sees over the kernel is exact for a linear field and a uniform flow; the existing
// models read and share as before.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "synthetic_case.h"
#include "cell_fields.h"
#include "deposition.h"
#include "gaussian_kernel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <stdexcept>
#include <vector>

using namespace hemo::particles;
using hemo::particles::synthetic::box_mesh;
using hemo::particles::synthetic::fluid_state;

namespace {

constexpr double kHalf = 15e-6, kLength = 40e-6, kCube = 2.5e-6;
constexpr double kRadius = 0.5 * 5.56e-6;  // a red cell's volume-equivalent sphere

hemo::mesh_t cubes() { return box_mesh(12, 12, 16, -kHalf, kHalf, -kHalf, kHalf, kLength, 2 * kHalf); }

// The kernel's fractions from its formula over every cell of the box (convex: every cell within
// reach is reached), the nearest periodic image in z.
std::map<int, double> brute_force(const CellLocator& loc, const Vec3& x, double sigma) {
  const double reach = hemo::kKernelReachSigmas * sigma, floor = std::exp(-0.5 * hemo::kKernelReachSigmas * hemo::kKernelReachSigmas);
  std::map<int, double> w;
  double total = 0;
  for (int c = 0; c < loc.n_cells(); ++c) {
    Vec3 d = loc.centre(c) - x;
    d.z() -= kLength * std::round(d.z() / kLength);
    if (d.norm() >= reach) continue;
    w[c] = loc.volume(c) * (std::exp(-d.squaredNorm() / (2 * sigma * sigma)) - floor);
    total += w[c];
  }
  for (auto& [c, v] : w) v /= total;
  return w;
}

std::map<int, double> shares_of(const SolidFractionModel& model, const CellLocator& loc, const Vec3& x) {
  std::vector<CellShare> s;
  model.share(loc.locate(x), loc.wrap(x), kRadius, s);
  std::map<int, double> m;
  for (const CellShare& c : s) m[c.cell] += c.fraction;
  return m;
}

// u = U0 + A x with no dependence on z (so it is periodic along the box), G = A^T.
const double A[3][3] = {{0.1e3, -2.0e3, 0}, {3.0e3, 0.2e3, 0}, {0.7e3, 1.5e3, 0}};
const double U0[3] = {0.01, -0.02, 0.3};
void linear(const std::array<double, 3>& x, std::array<double, 3>& u, std::array<double, 9>& g) {
  for (int j = 0; j < 3; ++j) {
    u[j] = U0[j];
    for (int i = 0; i < 3; ++i) {
      u[j] += A[j][i] * x[i];
      g[3 * i + j] = A[j][i];
    }
  }
}

// Centres near the walls, across the periodic end and inside.
std::vector<Vec3> probe_positions() {
  std::vector<Vec3> xs = {{0, 0, 20e-6},           {-kHalf + 0.3e-6, 0.1e-6, 20e-6}, {kHalf - 1e-6, kHalf - 1e-6, 7e-6},
                          {0.2e-6, -0.4e-6, 0.3e-6}, {3e-6, 2e-6, kLength - 0.2e-6},  {-kHalf + 0.5e-6, 1e-6, 0.1e-6}};
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> ux(-kHalf + 1e-9, kHalf - 1e-9), uz(0, kLength);
  for (int k = 0; k < 40; ++k) xs.emplace_back(ux(rng), ux(rng), uz(rng));
  return xs;
}

}  // namespace

TEST(GaussianKernel, FractionsAreTheFormulasOverTheCellsInsideWallsAndAcrossThePeriodicEnd) {
  const auto mesh = cubes();
  const CellLocator loc(mesh);
  const GaussianKernelFraction kernel(loc, 1.0);
  const double sigma = kernel.sigma(kRadius);
  EXPECT_NEAR(sigma, 5.56e-6 / 2.3548200450309493, 1e-18);  // FWHM = one diameter
  for (const Vec3& x : probe_positions()) {
    const auto got = shares_of(kernel, loc, x);
    const auto want = brute_force(loc, loc.wrap(x), sigma);
    ASSERT_EQ(got.size(), want.size()) << x.transpose();
    double sum = 0;
    for (const auto& [c, f] : want) {
      ASSERT_TRUE(got.count(c)) << "cell " << c << " missing at " << x.transpose();
      EXPECT_NEAR(got.at(c), f, 1e-14) << "cell " << c << " at " << x.transpose();
      sum += got.at(c);
    }
    EXPECT_NEAR(sum, 1.0, 1e-14);
    EXPECT_GT(got.size(), 16u) << "more cells than the former 16-share cap held";
  }
  // A centre half a micron from the x wall keeps all of itself inside: the wall's layer of cubes
  // holds the Gaussian's share of that layer plus, by the normalisation, the share behind the wall,
  // (Phi(2 / s) - Phi(-0.5 / s)) / (1 - Phi(-0.5 / s)) in the continuum (s = sigma in um), 0.66;
  // untruncated by the wall it would hold 0.39. To the midpoint rule on cubes about a sigma wide.
  const Vec3 by_wall(-kHalf + 0.5e-6, 0, 20e-6);
  double layer = 0;
  for (const auto& [c, v] : shares_of(kernel, loc, by_wall))
    if (loc.centre(c).x() < -kHalf + kCube) layer += v;
  const double s_um = sigma * 1e6;
  auto Phi = [](double t) { return 0.5 * std::erfc(-t / std::sqrt(2.0)); };
  const double continuum = (Phi(2 / s_um) - Phi(-0.5 / s_um)) / (1 - Phi(-0.5 / s_um));
  EXPECT_NEAR(layer, continuum, 0.08);
  EXPECT_GT(layer, Phi(2 / s_um) - Phi(-0.5 / s_um) + 0.2);
}

TEST(GaussianKernel, DepositionConservesVolumeAndTheFeedbackIdentityCellByCell) {
  const auto mesh = cubes();
  const CellLocator loc(mesh);
  FluidSampler fluid(loc);
  fluid.set_state(fluid_state(mesh, linear));
  Deposition dep(loc, make_solid_fraction_model("gaussian_kernel", loc, 1.0));
  ASSERT_EQ(dep.model().name(), "gaussian_kernel");
  const GaussianKernelFraction kernel(loc, 1.0);

  const double interval = 1e-4;
  std::vector<Vec3> expected_force(loc.n_cells(), Vec3::Zero());  // interval-mean N per cell
  double volume_sum = 0;
  Vec3 force_sum = Vec3::Zero();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uf(-1e-9, 1e-9), ub(1e-9, 5e-9), uv(80e-18, 100e-18);
  dep.clear();
  for (const Vec3& x : probe_positions()) {
    const Vec3 impulse = Vec3(uf(rng), uf(rng), uf(rng)) * interval;
    const double vp = uv(rng);
    const int cell = loc.locate(x);
    ASSERT_GE(cell, 0);
    dep.add_particle(cell, loc.wrap(x), kRadius, vp, impulse, ub(rng) * interval);
    for (const auto& [c, f] : shares_of(kernel, loc, x)) expected_force[c] += f * impulse / interval;
    volume_sum += vp;
    force_sum += impulse / interval;
  }
  hemo::particle_feedback_t fb;
  dep.finish(interval, &fluid, fb);
  double phi_v = 0;
  Vec3 fluid_gets = Vec3::Zero();
  for (int c = 0; c < fb.n_cells; ++c) {
    phi_v += fb.solid_fraction[c] * loc.volume(c);
    // S - K u at the velocity the particles saw is minus their force, cell by cell.
    const Vec3 s = Eigen::Map<const Vec3>(hemo::source_of(fb, c));
    const Vec3 got = (s - fb.drag_coefficient[c] * fluid.cell_velocity(c)) * loc.volume(c);
    EXPECT_NEAR((got + expected_force[c]).norm(), 0, 1e-12 * force_sum.norm() + 1e-24) << "cell " << c;
    fluid_gets += got;
  }
  EXPECT_NEAR(phi_v, volume_sum, 1e-14 * volume_sum);
  EXPECT_NEAR(dep.total_volume(), volume_sum, 1e-14 * volume_sum);
  EXPECT_NEAR((fluid_gets + force_sum).norm(), 0, 1e-12 * force_sum.norm());
}

TEST(GaussianKernel, SharesChangeSmoothlyAsTheCentreCrossesFaces) {
  const auto mesh = cubes();
  const CellLocator loc(mesh);
  const GaussianKernelFraction kernel(loc, 1.0);
  const double step = 1e-8, sigma = kernel.sigma(kRadius);
  // Oblique walks, one of them across the periodic end and one along a wall.
  const std::pair<Vec3, Vec3> walks[] = {{{-6e-6, -5e-6, 15e-6}, {1, 0.7, 0.4}},
                                         {{1e-6, 2e-6, kLength - 4e-6}, {0.2, -0.3, 1}},
                                         {{-kHalf + 1e-6, -8e-6, 10e-6}, {0, 1, 0.5}}};
  for (const auto& [start, dir] : walks) {
    const Vec3 u = dir.normalized();
    auto before = shares_of(kernel, loc, start);
    int cell = loc.locate(start), crossings = 0;
    double largest = 0;
    for (int k = 1; k <= 800; ++k) {
      const Vec3 x = start + k * step * u;
      const auto now = shares_of(kernel, loc, x);
      std::map<int, double> change = now;
      for (const auto& [c, f] : before) change[c] -= f;
      double l1 = 0;
      for (const auto& [c, d] : change) l1 += std::abs(d);
      largest = std::max(largest, l1);
      const int here = loc.locate(x);
      crossings += here != cell;
      cell = here;
      before = now;
    }
    EXPECT_GE(crossings, 2) << "the walk crossed faces";
    // The Gaussian's own slope: sum_c |d f_c| ~ (mean |x_c - x| / sigma^2) step, below 3 step / sigma;
    // the centre cell's sharing jumps by 2 (all of it from one cell to the next).
    EXPECT_LT(largest, 3 * step / sigma) << start.transpose();
  }
}

TEST(GaussianKernel, AParticleSeesTheKernelMeanExactForALinearFieldAndAUniformFlow) {
  const auto mesh = cubes();
  const CellLocator loc(mesh);
  const GaussianKernelFraction kernel(loc, 1.0);
  FluidSampler fluid(loc);
  fluid.read_over(&kernel);
  auto state = fluid_state(mesh, linear);
  // A uniform pressure gradient and viscous force: their means are themselves.
  state.n_pressure_gradient_values = state.n_viscous_values = 3 * state.n_cells;
  for (int c = 0; c < state.n_cells; ++c) {
    state.pressure_gradient.insert(state.pressure_gradient.end(), {-3.0, 1.0, -2.5e3});
    state.viscous_force.insert(state.viscous_force.end(), {0.5, -0.25, 4e2});
  }
  fluid.set_state(state);
  Mat3 G;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) G(i, j) = A[j][i];
  for (const Vec3& x : probe_positions()) {
    const Vec3 w = loc.wrap(x);
    const int cell = loc.locate(w);
    const FluidSampler::Seen s = fluid.seen(cell, w, kRadius, true);
    std::array<double, 3> u;
    std::array<double, 9> g;
    linear({w.x(), w.y(), w.z()}, u, g);
    EXPECT_NEAR((s.velocity - Vec3(u[0], u[1], u[2])).norm(), 0, 1e-14) << x.transpose();
    EXPECT_NEAR((s.gradient - G).norm(), 0, 1e-10) << x.transpose();
    EXPECT_NEAR(s.shear_rate, fluid.shear_rate(cell), 1e-10);
    EXPECT_NEAR((s.pressure_gradient - Vec3(-3.0, 1.0, -2.5e3)).norm(), 0, 1e-11);
    EXPECT_NEAR((s.viscous_force - Vec3(0.5, -0.25, 4e2)).norm(), 0, 1e-12);
  }
  // A uniform flow: every particle, by a wall or across the end, sees it.
  fluid.set_state(fluid_state(mesh, [](const std::array<double, 3>&, std::array<double, 3>& u, std::array<double, 9>& g) {
    u = {1e-3, -2e-3, 0.02};
    g.fill(0.0);
  }));
  for (const Vec3& x : probe_positions()) {
    const Vec3 w = loc.wrap(x);
    const FluidSampler::Seen s = fluid.seen(loc.locate(w), w, kRadius, true);
    EXPECT_NEAR((s.velocity - Vec3(1e-3, -2e-3, 0.02)).norm(), 0, 1e-16) << x.transpose();  // 5e-15 of it
    EXPECT_EQ(s.shear_rate, 0.0);
  }
}

// Poiseuille flow across the box, u_z = U (1 - (x^2 + y^2) / R^2), H_xx = H_yy = -2U/R^2: each cell's
// value carried to x by its own gradient alone would read U 2 sigma^2 / R^2 too fast (the tangent
// lies above a concave profile); by the mean of its own and the kernel's, the read is exact up to
// -(1/2) <d>^T H <d> = (U / R^2)(<d_x>^2 + <d_y>^2), <d> the kernel's weighted centre minus x,
// which is the error found to round-off, by the walls too.
TEST(GaussianKernel, APoiseuilleProfileIsReadToTheSecondOrder) {
  const auto mesh = cubes();
  const CellLocator loc(mesh);
  const GaussianKernelFraction kernel(loc, 1.0);
  FluidSampler fluid(loc);
  fluid.read_over(&kernel);
  constexpr double U = 0.01, R = kHalf;
  fluid.set_state(fluid_state(mesh, [](const std::array<double, 3>& x, std::array<double, 3>& u, std::array<double, 9>& g) {
    u = {0, 0, U * (1 - (x[0] * x[0] + x[1] * x[1]) / (R * R))};
    g.fill(0.0);
    g[2] = -2 * U * x[0] / (R * R);  // d u_z / d x
    g[5] = -2 * U * x[1] / (R * R);  // d u_z / d y
  }));
  const double sigma = kernel.sigma(kRadius);
  double largest_first_order = 0;
  for (const Vec3& x : probe_positions()) {
    const Vec3 w = loc.wrap(x);
    const int cell = loc.locate(w);
    std::vector<CellShare> shares;
    kernel.share(cell, w, kRadius, shares);
    Vec3 centre_offset = Vec3::Zero();
    for (const CellShare& c : shares)
      centre_offset += c.fraction * (loc.centre(c.cell) - Vec3(w.x(), w.y(), w.z() + c.dz));
    const double exact = U * (1 - (w.x() * w.x() + w.y() * w.y()) / (R * R));
    const double predicted = U / (R * R) * (centre_offset.x() * centre_offset.x() + centre_offset.y() * centre_offset.y());
    const double got = fluid.seen(cell, w, kRadius, false).velocity.z();
    EXPECT_NEAR(got - exact, predicted, 1e-15) << x.transpose();
    if (std::abs(w.x()) < kHalf - 3 * sigma && std::abs(w.y()) < kHalf - 3 * sigma) {
      EXPECT_LT(std::abs(got - exact), 0.01 * 2 * sigma * sigma / (R * R) * U) << "inside " << x.transpose();
    }
    largest_first_order = std::max(largest_first_order, predicted);
  }
  std::printf("[ info ] Poiseuille read by the kernel: largest error %.3g of U (by a wall); its own gradient alone "
              "would add 2 sigma^2/R^2 = %.3g of U\n",
              largest_first_order / U, 2 * sigma * sigma / (R * R));
}

TEST(GaussianKernel, TheOtherModelsReadAtTheCentreAndShareAsBefore) {
  const auto mesh = cubes();
  const CellLocator loc(mesh);
  FluidSampler fluid(loc);
  const auto overlap = make_solid_fraction_model("sphere_overlap", loc);
  fluid.read_over(overlap.get());  // a model that does not sample over its shares: the centre's cell
  fluid.set_state(fluid_state(mesh, linear));
  for (const Vec3& x : probe_positions()) {
    const Vec3 w = loc.wrap(x);
    const int cell = loc.locate(w);
    const FluidSampler::Seen s = fluid.seen(cell, w, kRadius, true);
    EXPECT_EQ(s.velocity, fluid.velocity(cell, w));
    EXPECT_EQ(s.gradient, fluid.gradient(cell));
    EXPECT_EQ(s.shear_rate, fluid.shear_rate(cell));
  }
  try {
    make_solid_fraction_model("tophat", loc);
    FAIL() << "an unknown model was made";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "unknown solid fraction model 'tophat' (known: centre_cell, gaussian_kernel, sphere_overlap)");
  }
  EXPECT_THROW(GaussianKernelFraction(loc, 0.0), std::invalid_argument);
}

// A cell straddling an open end: the share of it inside the end's plane (inside_share) is the
// kernel's mass on that side, not renormalised, against the kernel integrated numerically (the
// midpoint rule over 2000 slices along the plane's normal, each sliced into 2000 rings; the
// sphere's: its volume on that side, the same way); 1 and 0 a reach inside and outside, a half on
// the plane, falling as the centre moves out.
TEST(GaussianKernel, AStraddlingCellsInsideShareIsTheKernelsMassInside) {
  const auto mesh = cubes();
  const CellLocator loc(mesh);
  const GaussianKernelFraction kernel(loc, 1.0);
  const SphereOverlapFraction sphere(loc);
  const double s = kernel.sigma(kRadius), reach = kernel.reach(kRadius);
  const double floor = std::exp(-0.5 * hemo::kKernelReachSigmas * hemo::kKernelReachSigmas);
  // The share of the ball of radius `ball` at t < -beyond (t along the normal), of the kernel or
  // of a uniform density.
  auto integrated = [&](double beyond, double ball, bool gaussian) {
    constexpr int n = 2000;
    double in = 0, all = 0;
    for (int i = 0; i < n; ++i) {
      const double t = -ball + (i + 0.5) * 2 * ball / n;
      const double disc = std::sqrt(ball * ball - t * t);
      double slice = 0;
      for (int j = 0; j < n; ++j) {
        const double rho = (j + 0.5) * disc / n;
        slice += 2 * M_PI * rho * disc / n * (gaussian ? std::exp(-(t * t + rho * rho) / (2 * s * s)) - floor : 1.0);
      }
      all += slice;
      if (t < -beyond) in += slice;
    }
    return in / all;
  };
  EXPECT_EQ(kernel.inside_share(-reach, kRadius), 1.0);
  EXPECT_EQ(kernel.inside_share(reach, kRadius), 0.0);
  EXPECT_NEAR(kernel.inside_share(0, kRadius), 0.5, 1e-15);
  EXPECT_EQ(sphere.inside_share(-kRadius, kRadius), 1.0);
  EXPECT_NEAR(sphere.inside_share(0, kRadius), 0.5, 1e-15);
  double last = 1;
  for (const double f : {-0.8, -0.5, -0.2, 0.1, 0.4, 0.7}) {
    const double b = f * reach;
    const double share = kernel.inside_share(b, kRadius);
    EXPECT_NEAR(share, integrated(b, reach, true), 2e-3) << "kernel, " << f << " of its reach past";
    EXPECT_LT(share, last);
    last = share;
    const double bs = f * kRadius;
    EXPECT_NEAR(sphere.inside_share(bs, kRadius), integrated(bs, kRadius, false), 2e-3) << "sphere, " << f << " r past";
  }
}
