// Radial number-density and volume-fraction profiles: exact normalisation on constructed data.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "observables.h"
#include "synthetic.h"

#include <gtest/gtest.h>

#include <random>

using namespace hemo::analysis;
using namespace hemo::analysis::test;

namespace {
const Tube kTube{50 * kUm, 600 * kUm};
}

TEST(RadialProfile, BinEdgesAndAnnulusVolumesTileTheVessel) {
  const auto e = radial_bin_edges(kTube, 10);
  ASSERT_EQ(e.size(), 11u);
  EXPECT_DOUBLE_EQ(e.front(), 0);
  EXPECT_DOUBLE_EQ(e.back(), kTube.radius);
  double total = 0;
  for (double v : annulus_volumes(kTube, 10)) total += v;
  EXPECT_NEAR(total, kTube.volume(), 1e-12 * kTube.volume());
}

// k_b particles on the mid-radius of bin b: the density is k_b / annulus volume, to round-off.
TEST(RadialProfile, ParticlesOnKnownAnnuliGiveKnownDensity) {
  const int bins = 10;
  const auto e = radial_bin_edges(kTube, bins);
  std::vector<double> r;
  for (int b = 0; b < bins; ++b)
    for (int k = 0; k <= b; ++k) r.push_back(0.5 * (e[b] + e[b + 1]));
  const auto n = radial_number_density(r, kTube, bins);
  for (int b = 0; b < bins; ++b) {
    const double annulus = kPi * (e[b + 1] * e[b + 1] - e[b] * e[b]) * kTube.length;
    EXPECT_NEAR(n[b], (b + 1) / annulus, 1e-12 * (b + 1) / annulus) << "bin " << b;
  }
}

// Integral of profile x annulus volume = particle count, exactly, wherever the particles are
// (including a centre pushed a little past the wall, which is counted in the last bin).
TEST(RadialProfile, IntegratesToTheCount) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<double> r;
  for (int i = 0; i < 997; ++i) r.push_back(kTube.radius * std::sqrt(u(rng)));
  r.push_back(kTube.radius * 1.001);
  r.push_back(0);
  for (int bins : {1, 7, 50}) {
    const auto n = radial_number_density(r, kTube, bins);
    const auto v = annulus_volumes(kTube, bins);
    double count = 0;
    for (int b = 0; b < bins; ++b) count += n[b] * v[b];
    EXPECT_NEAR(count, static_cast<double>(r.size()), 1e-9) << bins << " bins";
  }
}

// Uniform by area: the density is flat at N / (pi R^2 L) (statistical: 4 sigma of a Poisson count).
TEST(RadialProfile, UniformPlacementIsFlat) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  const int N = 200000, bins = 10;
  std::vector<double> r(N);
  for (double& x : r) x = kTube.radius * std::sqrt(u(rng));
  const auto n = radial_number_density(r, kTube, bins);
  const double expected = N / kTube.volume();
  for (int b = 0; b < bins; ++b) {
    const double per_bin = N / double(bins * bins) * (2 * b + 1);  // expected count in bin b
    EXPECT_NEAR(n[b], expected, 4 * expected / std::sqrt(per_bin)) << "bin " << b;
  }
}

TEST(RadialProfile, TimeAverageIsElementwiseMean) {
  const auto m = average_profiles({{1, 2, 3}, {3, 4, 5}});
  EXPECT_EQ(m, (std::vector<double>{2, 3, 4}));
  EXPECT_TRUE(average_profiles({}).empty());
}

// ---- Volume fraction -------------------------------------------------------------------------

// A sphere on the axis inside a coaxial cylinder of radius rho < a: the sphere minus the
// two caps, V = 4/3 pi (a^3 - (a^2 - rho^2)^{3/2}). Quadrature tolerance 1e-6 relative.
TEST(VolumeFraction, SphereOnAxisMatchesClosedForm) {
  const double a = 2.78 * kUm;
  for (double rho : {0.3 * a, 0.7 * a, 0.99 * a}) {
    const double exact = 4.0 / 3.0 * kPi * (a * a * a - std::pow(a * a - rho * rho, 1.5));
    EXPECT_NEAR(sphere_volume_inside_cylinder(a, 0, rho), exact, 1e-6 * exact) << rho / a;
  }
  EXPECT_DOUBLE_EQ(sphere_volume_inside_cylinder(a, 0, 2 * a), 4.0 / 3.0 * kPi * a * a * a);
  EXPECT_DOUBLE_EQ(sphere_volume_inside_cylinder(a, 3 * a, 1.9 * a), 0);
}

// An off-axis sphere cut by the cylinder, against a brute-force count of a 200^3 lattice
// (lattice error ~1e-3: tolerance 3e-3).
TEST(VolumeFraction, OffAxisSphereMatchesLatticeCount) {
  const double a = 1, c = 2.3, rho = 2.6;
  const int n = 200;
  long inside = 0, total = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const double x = -a + (2 * i + 1) * a / n, y = -a + (2 * j + 1) * a / n, z = -a + (2 * k + 1) * a / n;
        if (x * x + y * y + z * z > a * a) continue;
        ++total;
        inside += std::hypot(c + x, y) < rho;
      }
  const double sphere = 4.0 / 3.0 * kPi * a * a * a;
  const double lattice = sphere * inside / double(total);
  EXPECT_NEAR(sphere_volume_inside_cylinder(a, c, rho), lattice, 3e-3 * sphere);
}

// Cells well inside the vessel: sum over annuli of fraction x annulus volume = N V_RBC
// (V_RBC = 90 um^3 is not the 5.56 um sphere's 90.0 um^3 exactly: the spread is rescaled).
TEST(VolumeFraction, IntegratesToTheCellVolume) {
  const double d = 5.56 * kUm, v = 90e-18;
  const std::vector<double> r{0, 1 * kUm, 10.3 * kUm, 25 * kUm, 44 * kUm, 47.2 * kUm};
  for (int bins : {5, 50, 200}) {
    const auto f = radial_volume_fraction(r, d, v, kTube, bins);
    const auto vol = annulus_volumes(kTube, bins);
    double total = 0;
    for (int b = 0; b < bins; ++b) total += f[b] * vol[b];
    EXPECT_NEAR(total, r.size() * v, 1e-9 * r.size() * v) << bins << " bins";
  }
}

// The window's fraction from a 4096-bin centre histogram (centres moved by at most R/8192 = 6 nm)
// agrees with spreading every cell exactly: per bin within 1e-3 of the core fraction; in the two
// innermost 1 um annuli, whose tiny volumes feel a 6 nm shift of a cell near the axis, within 0.5 %.
TEST(VolumeFraction, FineHistogramPathMatchesExactSpreading) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(0, 1);
  const double d = 5.56 * kUm, v = 90e-18;
  std::vector<double> r;
  for (int i = 0; i < 3000; ++i) r.push_back((44 * kUm - d / 2) * std::sqrt(u(rng)));
  const auto exact = radial_volume_fraction(r, d, v, kTube, 50);
  const auto binned = radial_volume_fraction_from_histogram(centre_histogram(r, kTube, 4096), d, v, kTube, 50);
  ASSERT_EQ(binned.size(), exact.size());
  const double core = exact[10];
  for (std::size_t b = 0; b < exact.size(); ++b)
    EXPECT_NEAR(binned[b], exact[b], b < 2 ? 5e-3 * exact[b] : 1e-3 * core) << "bin " << b;
  double count = 0;
  for (double c : centre_histogram(r, kTube, 4096)) count += c;
  EXPECT_DOUBLE_EQ(count, 3000);
}
