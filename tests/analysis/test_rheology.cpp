// Apparent viscosity, tube and discharge hematocrit, margination index on constructed cases.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "observables.h"
#include "synthetic.h"

#include <gtest/gtest.h>

#include <cmath>
#include <utility>

using namespace hemo::analysis;
using namespace hemo::analysis::test;

namespace {
const Tube kTube{50 * kUm, 600 * kUm};
}

// mu_app / mu = gamma_w / (8 U / d): the calibration value 1.4 for the U that gives it, and 1
// for Poiseuille flow of plasma alone (U = gamma_w d / 8).
TEST(ApparentViscosity, RatioOfImposedToApparentWallShearRate) {
  const double d = 100 * kUm, gamma = 799;
  const double u = gamma * d / (8 * 1.4);
  const auto a = apparent_viscosity(u, d, gamma);
  EXPECT_NEAR(a.apparent_wall_shear_rate, 799 / 1.4, 1e-9);
  EXPECT_NEAR(a.relative_viscosity, 1.4, 1e-12);
  EXPECT_NEAR(apparent_viscosity(gamma * d / 8, d, gamma).relative_viscosity, 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(apparent_viscosity(0, d, gamma).relative_viscosity));
}

TEST(ApparentViscosity, TimeMeanOverTheWindowOnly) {
  const std::vector<double> t{0, 0.5, 1.0, 1.5, 2.0}, v{100, 100, 1, 2, 3};
  EXPECT_DOUBLE_EQ(time_mean(t, v, 1.0, 2.0), 2);
  EXPECT_TRUE(std::isnan(time_mean(t, v, 3, 4)));
}

TEST(Hematocrit, TubeHematocritIsRbcVolumeOverVesselVolume) {
  const std::size_t n = 7854;
  EXPECT_NEAR(tube_hematocrit(n, 90e-18, kTube), n * 90e-18 / (kPi * 2500e-12 * 600e-6), 1e-15);
}

// Plug flow: plasma and cells all move at U, so the RBC share of the flux equals their share
// of the volume: H_D = H_T to round-off.
TEST(Hematocrit, PlugFlowDischargeEqualsTube) {
  const double u = 5e-3, v = 90e-18;
  Snapshot s;
  for (int i = 0; i < 1000; ++i)
    add_particle(s, i, kRbc, 40 * kUm * std::sqrt((i + 0.5) / 1000), 2.4 * i, 0.6 * i * kUm, u);
  const Cells rbc = select_species(s, kRbc);
  const double ht = tube_hematocrit(rbc.size(), v, kTube);
  const double q_rbc = cell_volume_flux(rbc.vz, v, kTube);
  const double q = total_volume_flux((1 - ht) * u, q_rbc, kTube);  // superficial plasma = alpha U
  EXPECT_NEAR(q, kTube.cross_section() * u, 1e-12 * q);
  EXPECT_NEAR(discharge_hematocrit(q_rbc, q), ht, 1e-12);
}

// Parabolic flow u = 2U (1 - r^2/R^2) with RBCs spread evenly by area over r < R/2 and moving
// with the flow: <v_RBC> = 2U (1 - <r^2>/R^2) = 2U (1 - 1/8) = 1.75 U, so H_D / H_T = 1.75
// (the Fahraeus effect) when the total flux is pi R^2 U.
TEST(Hematocrit, ParabolicFlowWithCentralRbcsGivesFahraeusRatio) {
  const double u = 5e-3, v = 90e-18, R = kTube.radius;
  const int n = 1000;
  Snapshot s;
  for (int i = 0; i < n; ++i) {
    const double r = 0.5 * R * std::sqrt((i + 0.5) / n);  // <r^2> = R^2/8 exactly
    add_particle(s, i, kRbc, r, 2.4 * i, 0.6 * i * kUm, 2 * u * (1 - r * r / (R * R)));
  }
  const Cells rbc = select_species(s, kRbc);
  const double ht = tube_hematocrit(rbc.size(), v, kTube);
  const double hd = discharge_hematocrit(cell_volume_flux(rbc.vz, v, kTube), kTube.cross_section() * u);
  EXPECT_NEAR(hd / ht, 1.75, 1e-12);
}

// Platelets at r = 1..10 in a tube of radius 10 with delta = 2.5: r > 7.5 holds 8, 9, 10
// (plain numbers, so that the edge case r = R - delta is exact).
TEST(Margination, FractionOfPlateletsInTheLayer) {
  std::vector<double> r;
  for (int i = 1; i <= 10; ++i) r.push_back(i);
  EXPECT_DOUBLE_EQ(margination_index(r, 10, 2.5), 0.3);
  EXPECT_DOUBLE_EQ(margination_index(r, 10, 3), 0.3);  // r = 7 is on the edge, not in the layer
  EXPECT_DOUBLE_EQ(margination_index(r, 10, 0), 0);
  EXPECT_TRUE(std::isnan(margination_index(r, 10, std::nan(""))));
  EXPECT_TRUE(std::isnan(margination_index({}, 10, 1)));
}

// The in-vitro fits (docs/model.md §7.4) at their defining points: Pries et al. (1992) is built
// so that mu_rel = 1 without cells and equals its eta_0.45 at H_D = 0.45, and grows with H_D; its
// eta_0.45 tends to 3.2 in wide tubes and has the Fahraeus-Lindqvist minimum near 7 um. Pries et
// al. (1990): H_T/H_D tends to 1 in wide tubes and lies below 1 (the Fahraeus effect) in between.
TEST(InVitroBlood, RelativeViscosityFitHoldsItsDefiningPoints) {
  for (double d_um : {10.0, 30.0, 100.0, 300.0}) {
    const double d = d_um * kUm;
    EXPECT_NEAR(in_vitro_relative_viscosity(d, 0.0), 1.0, 1e-12) << d_um;
    const double eta_45 = 220 * std::exp(-1.3 * d_um) + 3.2 - 2.44 * std::exp(-0.06 * std::pow(d_um, 0.645));
    EXPECT_NEAR(in_vitro_relative_viscosity(d, 0.45), eta_45, 1e-12) << d_um;
    double previous = 1;
    for (double hd = 0.05; hd < 0.6; hd += 0.05) {
      EXPECT_GT(in_vitro_relative_viscosity(d, hd), previous) << d_um << " " << hd;
      previous = in_vitro_relative_viscosity(d, hd);
    }
  }
  EXPECT_NEAR(in_vitro_relative_viscosity(3000 * kUm, 0.45), 3.2, 1e-3);
  // The Fahraeus-Lindqvist effect: at H_D 0.45 the viscosity falls from wide tubes to ~7 um.
  EXPECT_LT(in_vitro_relative_viscosity(7 * kUm, 0.45), in_vitro_relative_viscosity(30 * kUm, 0.45));
  EXPECT_LT(in_vitro_relative_viscosity(30 * kUm, 0.45), in_vitro_relative_viscosity(300 * kUm, 0.45));
  EXPECT_LT(in_vitro_relative_viscosity(7 * kUm, 0.45), in_vitro_relative_viscosity(4 * kUm, 0.45));
}

TEST(InVitroBlood, FahraeusRatioBelowOneInMicrovesselsAndOneInWideTubes) {
  EXPECT_NEAR(in_vitro_fahraeus_ratio(5000 * kUm, 0.45), 1.0, 1e-6);
  for (double d_um : {15.0, 30.0, 100.0}) {
    const double r = in_vitro_fahraeus_ratio(d_um * kUm, 0.2);
    EXPECT_GT(r, 0.5) << d_um;
    EXPECT_LT(r, 1.0) << d_um;
  }
  // H_T/H_D = H_D + (1 - H_D) f(d): at H_D = 1 the tube is all cells, whatever d.
  EXPECT_NEAR(in_vitro_fahraeus_ratio(100 * kUm, 1.0), 1.0, 1e-12);
}

// A narrowing periodic vessel passes the same flux Q through every section, so the plasma's volume
// mean velocity gives Q over its mean section V/L, not over pi R0^2; its tube hematocrit is over
// its own volume. A straight tube's mean section is pi R^2.
TEST(Hematocrit, ANarrowedVesselTakesItsMeanSection) {
  const double section = kPi * 50e-6 * 50e-6;
  EXPECT_DOUBLE_EQ(kTube.mean_section(), section);
  Tube narrowed = kTube;
  narrowed.narrowed_section = 0.8 * section;
  EXPECT_NEAR(total_volume_flux(0.01, 2e-12, narrowed), 0.8 * section * 0.01 + 2e-12, 1e-24);
  EXPECT_NEAR(total_volume_flux(0.01, 2e-12, kTube), section * 0.01 + 2e-12, 1e-24);
  EXPECT_NEAR(tube_hematocrit(1000, 90e-18, narrowed), 1000 * 90e-18 / (0.8 * section * 600e-6), 1e-12);
  EXPECT_NEAR(narrowed.cross_section(), section, 1e-24);  // mu_app's pi R0^2 stays the nominal one
}

// Through an open vessel's end: a cumulative count's increase over the window per second, from the
// last samples at or before its ends; the blood's flux is the plasma's and the cells', H_D the red
// cells' share of it.
TEST(OpenEnds, CellsPerSecondAreTheCountsIncreaseOverTheWindow) {
  const std::vector<double> t = {0, 1e-4, 2e-4, 3e-4, 4e-4}, n = {0, 2, 5, 9, 14};
  EXPECT_NEAR(window_rate(t, n, 1e-4, 3e-4), (9 - 2) / 2e-4, 1e-6);
  EXPECT_NEAR(window_rate(t, n, 1.5e-4, 4e-4), (14 - 2) / 2.5e-4, 1e-6);  // N(1.5e-4) = N(1e-4)
  EXPECT_TRUE(std::isnan(window_rate(t, n, -1e-4, 2e-4)));                // nothing before the start
  EXPECT_TRUE(std::isnan(window_rate(t, n, 2e-4, 2e-4)));
  EndFlux e{"outlet", 4e-11, 1e5, 2e4, 1e5 * 90e-18, 2e4 * 6e-18};
  EXPECT_DOUBLE_EQ(e.blood_flux(), 4e-11 + 9e-12 + 1.2e-13);
  EXPECT_DOUBLE_EQ(e.discharge_hematocrit(), 9e-12 / (4e-11 + 9e-12 + 1.2e-13));
}

// A bifurcation's outlets: each one's share of the blood, the plasma, the red cells and the
// platelets that leave through them all (the phase-separation curve's points). A branch that takes
// 40 % of the blood but 30 % of the red cells is skimmed; the shares add to one.
TEST(OpenEnds, EachOutletsSharesAreOfWhatLeavesThroughThemAll) {
  const double v_rbc = 90e-18, v_plt = 6e-18;
  EndFlux skimmed{"outlet_1", 0, 3e4, 1e4, 3e4 * v_rbc, 1e4 * v_plt};
  EndFlux other{"outlet_2", 0, 7e4, 3e4, 7e4 * v_rbc, 3e4 * v_plt};
  // Plasma such that the blood splits 40 / 60.
  const double blood = 1e-10;
  skimmed.plasma_flux = 0.4 * blood - skimmed.rbc_volume_flux - skimmed.platelet_volume_flux;
  other.plasma_flux = 0.6 * blood - other.rbc_volume_flux - other.platelet_volume_flux;
  const auto shares = branch_shares({skimmed, other});
  ASSERT_EQ(shares.size(), 2u);
  EXPECT_EQ(shares[0].outlet, "outlet_1");
  EXPECT_NEAR(shares[0].blood, 0.4, 1e-12);
  EXPECT_NEAR(shares[1].blood, 0.6, 1e-12);
  EXPECT_NEAR(shares[0].rbc, 0.3, 1e-12);
  EXPECT_NEAR(shares[0].platelet, 0.25, 1e-12);
  EXPECT_NEAR(shares[0].plasma + shares[1].plasma, 1.0, 1e-12);
  EXPECT_NEAR(shares[0].plasma, skimmed.plasma_flux / (skimmed.plasma_flux + other.plasma_flux), 1e-12);
  // Nothing left yet: no share.
  EXPECT_TRUE(std::isnan(branch_shares({EndFlux{"outlet_1"}, EndFlux{"outlet_2"}})[0].rbc));
}

// The in-vivo phase-separation fit (Pries et al. 1989; Pries & Secomb 2005) by what it is built to
// hold: the daughters' shares of the red cells add to one (swapping the daughters flips A), equal
// daughters split evenly at an even split, a branch below X0 takes plasma alone, a wide parent
// separates nothing, and a narrow one enriches the faster branch (the Zweifach-Fung effect). And
// one point of scenes/studies/bifurcation.toml's sweep worked by hand: D_F = 100 um, 90.4 and
// 63.9 um daughters, H_D = 0.17, F_B = 0.8: A = -0.0368, B = 1.0579, X0 = 0.0080, F_E = 0.8119.
TEST(InVivoBlood, PhaseSeparationFitHoldsWhatItIsBuiltToHold) {
  for (const double parent_um : {30.0, 100.0})
    for (const double hd : {0.15, 0.45})
      for (const auto& [a_um, b_um] : {std::pair{20.0, 20.0}, std::pair{25.0, 15.0}})
        for (double f = 0.05; f < 1; f += 0.05) {
          const double here = in_vivo_rbc_share(f, parent_um * kUm, a_um * kUm, b_um * kUm, hd);
          const double there = in_vivo_rbc_share(1 - f, parent_um * kUm, b_um * kUm, a_um * kUm, hd);
          EXPECT_NEAR(here + there, 1, 1e-12) << parent_um << " " << hd << " " << a_um << " " << f;
        }
  EXPECT_NEAR(in_vivo_rbc_share(0.5, 30 * kUm, 20 * kUm, 20 * kUm, 0.45), 0.5, 1e-15);
  const double x0 = 0.964 * (1 - 0.45) / 10;  // a 10-um parent
  EXPECT_EQ(in_vivo_rbc_share(0.9 * x0, 10 * kUm, 8 * kUm, 8 * kUm, 0.45), 0);
  EXPECT_EQ(in_vivo_rbc_share(1 - 0.9 * x0, 10 * kUm, 8 * kUm, 8 * kUm, 0.45), 1);
  EXPECT_NEAR(in_vivo_rbc_share(0.8, 1e5 * kUm, 8e4 * kUm, 8e4 * kUm, 0.45), 0.8, 1e-4);
  EXPECT_GT(in_vivo_rbc_share(0.8, 30 * kUm, 24 * kUm, 24 * kUm, 0.45), 0.8);
  EXPECT_NEAR(in_vivo_rbc_share(0.8, 100 * kUm, 90.4 * kUm, 63.9 * kUm, 0.17), 0.8119, 1e-4);
  EXPECT_TRUE(std::isnan(in_vivo_rbc_share(1.2, 100 * kUm, 80 * kUm, 80 * kUm, 0.17)));
  EXPECT_TRUE(std::isnan(in_vivo_rbc_share(0.5, 0, 80 * kUm, 80 * kUm, 0.17)));
}
