// Verification of the fluid node (issue #3): the real hemocosim-fluid under the coordinator,
// over the real bus, driven by hemocosim-prescribed-particles instead of particles.
//
// Every number these tests assert is printed; docs/fluid-verification.md quotes them.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_case.h"
#include "fluid_run.h"
#include "geometry.h"
#include "vessel_mesh.h"

#include <gtest/gtest.h>
#include <suspension_viscosity.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <tuple>
#include <vector>

using namespace hemo::fluidtest;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMu = 1.2e-3, kRho = 1025;  // the scene defaults

std::string prescribed(const std::string& args) { return bin("hemocosim-prescribed-particles") + " " + args; }

// Per cell, the mean of r^2 = x^2 + y^2 over the cell: the cells are prisms of the
// cross-section polygon, so it is the polygon's polar second moment over its area.
std::vector<double> cell_mean_r2(const hemo::PolyMesh& mesh) {
  const auto geo = hemo::compute_geometry(mesh);
  std::vector<double> out(static_cast<std::size_t>(mesh.n_cells), -1);
  auto take = [&](int cell, int f) {
    if (out[static_cast<std::size_t>(cell)] >= 0) return;
    const auto& a = geo.face_areas[static_cast<std::size_t>(f)];
    if (std::abs(a[2]) < 0.999 * std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])) return;  // not a z face
    const auto& pts = mesh.faces[static_cast<std::size_t>(f)];
    double area = 0, moment = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const auto& p = mesh.points[static_cast<std::size_t>(pts[i])];
      const auto& q = mesh.points[static_cast<std::size_t>(pts[(i + 1) % pts.size()])];
      const double cross = p[0] * q[1] - q[0] * p[1];
      area += cross / 2;
      moment += cross * (p[0] * p[0] + p[0] * q[0] + q[0] * q[0] + p[1] * p[1] + p[1] * q[1] + q[1] * q[1]) / 12;
    }
    out[static_cast<std::size_t>(cell)] = moment / area;
  };
  for (int f = 0; f < mesh.n_faces(); ++f) {
    take(mesh.owner[static_cast<std::size_t>(f)], f);
    if (f < mesh.n_internal_faces()) take(mesh.neighbour[static_cast<std::size_t>(f)], f);
  }
  return out;
}

struct PoiseuilleRun {
  int core = 0, ring = 0;
  double h = 0;                  // relative cell size, 1/core
  double error_average = 0;      // L2 relative error of u_z against the cell averages of the analytic profile
  double error_centre = 0;       // ... against its values at the cell centres
  double error_max = 0;          // max |u_z - average| / u_max
  double tau = 0;                // wall_shear_stress_Pa reported
  double tau_polygon = 0;        // dP/l * A_h/P_h: the force balance on the polygonal cross-section
  double wall_over_driving = 0;  // wall force / driving force at the end
  double wall_force = 0;         // wall_force_z_N at the end, N
  double relative_viscosity = 0; // gamma_w / (8 U / d): mu_app/mu of plasma alone, 1 on the circle
  double seconds = 0;
  std::vector<hemo::fluidtest::CellState> cells;
};

// A steady particle-free Poiseuille run: d = 100 um, l = 600 um, gamma_w = 799 1/s, 2 axial
// cells (the flow does not vary along z), 20 implicit steps of 2 ms (10 viscous times R^2/nu).
PoiseuilleRun poiseuille(int core, int ring, const std::string& mode = "--mode none", const std::string& extra = "",
                         const std::string& wall_polygon = "circumscribed") {
  SceneSpec s;
  s.name = "poiseuille-" + std::to_string(core) + "-" + wall_polygon;
  s.wall_polygon = wall_polygon;
  s.extra = extra;
  s.core = core;
  s.ring = ring;
  s.particle_command = prescribed(mode + " --record state.csv");
  const auto r = run_scene(s);
  EXPECT_EQ(r.command.exit_code, 0) << r.command.output;

  PoiseuilleRun out;
  out.core = core;
  out.ring = ring;
  out.h = 1.0 / core;
  out.seconds = r.command.seconds;
  const auto m = read_metrics(r.dir);
  const auto& mean = m.at({"fluid", "mean_velocity_m_s"});
  EXPECT_LT(std::abs(mean.rbegin()->second / std::next(mean.rbegin())->second - 1), 1e-9) << "not steady";
  out.relative_viscosity = 799 / (8 * mean.rbegin()->second / 100e-6);

  const hemo::Vessel vessel{100e-6, 600e-6};
  const double R = vessel.radius(), dP = 4 * kMu * vessel.length * 799 / vessel.diameter;
  const double a = dP / (4 * kMu * vessel.length), umax = a * R * R;
  hemo::MeshSpec spec{core, ring, s.axial};
  hemo::choice_named(wall_polygon, spec.wall_polygon);
  const auto mesh = hemo::make_vessel_mesh(vessel, spec);
  const auto r2 = cell_mean_r2(mesh);
  out.cells = read_state(r.dir + "/state.csv");
  EXPECT_EQ(out.cells.size(), static_cast<std::size_t>(mesh.n_cells));
  double num_a = 0, num_c = 0, den = 0, volume = 0;
  for (std::size_t i = 0; i < out.cells.size(); ++i) {
    const auto& c = out.cells[i];
    const double average = a * (R * R - r2[i]);
    const double centre = a * (R * R - c.x * c.x - c.y * c.y);
    num_a += (c.u[2] - average) * (c.u[2] - average) * c.volume;
    num_c += (c.u[2] - centre) * (c.u[2] - centre) * c.volume;
    den += average * average * c.volume;
    volume += c.volume;
    out.error_max = std::max(out.error_max, std::abs(c.u[2] - average) / umax);
  }
  out.error_average = std::sqrt(num_a / den);
  out.error_centre = std::sqrt(num_c / den);

  double wall_area = 0;
  const auto geo = hemo::compute_geometry(mesh);
  const auto& wall = mesh.patch(hemo::patch_name::wall);
  for (int f = wall.start; f < wall.start + wall.size; ++f) {
    const auto& A = geo.face_areas[static_cast<std::size_t>(f)];
    wall_area += std::sqrt(A[0] * A[0] + A[1] * A[1] + A[2] * A[2]);
  }
  out.tau = last(m, "fluid", "wall_shear_stress_Pa");
  out.tau_polygon = dP / vessel.length * volume / wall_area;
  out.wall_over_driving = -last(m, "fluid", "wall_force_z_N") / last(m, "fluid", "driving_force_z_N");
  out.wall_force = last(m, "fluid", "wall_force_z_N");
  return out;
}

// Least-squares slope of log(error) against log(h).
double observed_order(const std::vector<double>& h, const std::vector<double>& e) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(h.size());
  for (std::size_t i = 0; i < h.size(); ++i) {
    const double x = std::log(h[i]), y = std::log(e[i]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

double tau_exact() { return 100e-6 * (4 * kMu * 600e-6 * 799 / 100e-6) / (4 * 600e-6); }

PoiseuilleRun inscribed(int core, int ring) { return poiseuille(core, ring, "--mode none", "", "inscribed"); }

void print_profile_errors(const std::vector<PoiseuilleRun>& runs) {
  std::printf("  core/ring  cells/section  L2 err (cell avg)  L2 err (centre)  max err/u_max  run s\n");
  for (const auto& r : runs)
    std::printf("  %4d/%-4d  %13d  %17.4e  %15.4e  %13.4e  %5.1f\n", r.core, r.ring,
                r.core * r.core + 4 * r.core * r.ring, r.error_average, r.error_centre, r.error_max, r.seconds);
  for (std::size_t i = 1; i < runs.size(); ++i)
    std::printf("  order %d/%d -> %d/%d: %.3f (cell averages), %.3f (centres)\n", runs[i - 1].core, runs[i - 1].ring,
                runs[i].core, runs[i].ring,
                std::log(runs[i - 1].error_average / runs[i].error_average) / std::log(runs[i - 1].h / runs[i].h),
                std::log(runs[i - 1].error_centre / runs[i].error_centre) / std::log(runs[i - 1].h / runs[i].h));
}

// Wall shear stress: the reported value is -mu dU_z/dn from the wall cells, exactly the wall
// flux of the discrete Laplacian, so in the steady state it balances the driving force to solver
// tolerance: tau = dP/l * A_h/P_h with A_h, P_h the area and perimeter of the mesh's polygonal
// cross-section. Returns |tau / (d dP/(4l)) - 1| per run.
std::vector<double> wall_shear_errors(const std::vector<PoiseuilleRun>& runs) {
  std::printf("  core/ring  tau_w Pa     error vs d dP/(4l)  error vs polygon balance  wall/driving - 1\n");
  std::vector<double> et;
  for (const auto& r : runs) {
    const double err = r.tau / tau_exact() - 1;
    std::printf("  %4d/%-4d  %.6f  %+17.4e  %+24.3e  %+16.3e\n", r.core, r.ring, r.tau, err, r.tau / r.tau_polygon - 1,
                r.wall_over_driving - 1);
    EXPECT_NEAR(r.tau / r.tau_polygon, 1, 1e-8);
    EXPECT_NEAR(r.wall_over_driving, 1, 1e-8);
    et.push_back(std::abs(err));
  }
  return et;
}

std::vector<double> profile_errors(const std::vector<PoiseuilleRun>& runs) {
  std::vector<double> e;
  for (const auto& r : runs) e.push_back(r.error_average);
  return e;
}

std::vector<double> cell_sizes(const std::vector<PoiseuilleRun>& runs) {
  std::vector<double> h;
  for (const auto& r : runs) h.push_back(r.h);
  return h;
}

// Prints the runs' profile errors and returns their observed order; the errors fall with the
// mesh, a few per cent on the paper mesh and below 0.6 % at 16/12.
double profile_order(const std::vector<PoiseuilleRun>& runs, const char* wall_polygon) {
  std::printf("Poiseuille, d = 100 um, gamma_w = 799 1/s, steady, %s wall polygon:\n", wall_polygon);
  print_profile_errors(runs);
  const auto h = cell_sizes(runs), ea = profile_errors(runs);
  for (std::size_t i = 1; i < runs.size(); ++i) EXPECT_LT(ea[i], ea[i - 1]);
  EXPECT_LT(ea.front(), 0.06);
  EXPECT_LT(ea.back(), 0.006);
  const double order = observed_order(h, ea);
  std::printf("  observed order (least squares over the three): %.3f (cell averages)\n", order);
  return order;
}

}  // namespace

// No particles, the default wall (a polygon tangent to the vessel circle, hydraulic diameter d):
// the axial velocity converges to (dP/(4 mu l)) (R^2 - r^2) over three O-grids, each twice as fine
// as the one before across the section (core/ring cells 4/3 = the paper's, 8/6, 16/12), and the
// wall carries d dP/(4l) — the paper's exact balance — at every resolution, to solver tolerance.
// The profile converges faster than on the inscribed polygon (observed order above 2): the
// polygon's extra area near its corners and the O-grid's own error have opposite signs.
TEST(FluidPoiseuille, ConvergesToTheAnalyticProfileAndTheWallCarriesTheExactBalance) {
  const std::vector<PoiseuilleRun> runs{poiseuille(4, 3), poiseuille(8, 6), poiseuille(16, 12)};
  EXPECT_GT(profile_order(runs, "circumscribed"), 1.3);
  for (const double e : wall_shear_errors(runs)) EXPECT_LT(e, 1e-8);
  // The price: the tangent polygon has more area than the circle (16 tan(pi/16) / pi = 1.013 on
  // the paper's mesh), so plasma alone flows faster than Poiseuille's circle at the same drop and
  // its mu_app/mu, gamma_w / (8 U / d), is below 1 by a few per cent on the paper's mesh, the
  // error falling with the mesh.
  EXPECT_LT(runs.front().relative_viscosity, 1);
  double previous = 1;
  for (const auto& r : runs) {
    std::printf("  %4d/%-4d  plasma alone: mu_app/mu = %.4f\n", r.core, r.ring, r.relative_viscosity);
    EXPECT_LT(std::abs(1 - r.relative_viscosity), previous);
    previous = std::abs(1 - r.relative_viscosity);
  }
}

// The same on the inscribed polygon (corners on the circle, as blockMesh's arcs put them). The
// observed order of the L2 error is between 1.3 and 2: second order at coarse resolution,
// falling toward first order as the O-grid's non-smooth lines (the corners of the core block,
// the jump in cell size between core and ring) take over. The wall shear stress's error against
// d dP/(4 l) is that of the inscribed polygon, 1 - cos(pi/n) (second order: -1.9 % with the
// paper's 16 wall faces per section), within 1 % from 8 core cells (32 wall faces) on.
TEST(FluidPoiseuille, OnTheInscribedPolygonTheWallCarriesCosPiOverNOfTheBalance) {
  const std::vector<PoiseuilleRun> runs{inscribed(4, 3), inscribed(8, 6), inscribed(16, 12)};
  const double order = profile_order(runs, "inscribed");
  EXPECT_GT(order, 1.3);
  EXPECT_LT(order, 2.0);
  const auto h = cell_sizes(runs);
  const auto et = wall_shear_errors(runs);
  for (std::size_t i = 0; i < runs.size(); ++i) EXPECT_NEAR(et[i], 1 - std::cos(kPi / (4 * runs[i].core)), 1e-8);
  const double tau_order = observed_order(h, et);
  std::printf("  observed order of the wall shear stress error: %.3f\n", tau_order);
  EXPECT_NEAR(tau_order, 2.0, 0.05);
  EXPECT_LT(et[1], 0.01);  // 8/6 meets 1 %
  for (const auto& r : runs) std::printf("  %4d/%-4d  plasma alone: mu_app/mu = %.4f\n", r.core, r.ring, r.relative_viscosity);
}

// The same table with a fourth, finer O-grid (32/24, 8,192 cells per section; about a minute):
// run with --gtest_also_run_disabled_tests for docs/fluid-verification.md.
TEST(FluidPoiseuille, DISABLED_FourResolutionsForTheDocs) {
  std::vector<PoiseuilleRun> runs{poiseuille(4, 3), poiseuille(8, 6), poiseuille(16, 12), poiseuille(32, 24)};
  std::printf("  core/ring  L2 err (cell avg)  L2 err (centre)  max err/u_max  tau_w error  run s\n");
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const auto& r = runs[i];
    std::printf("  %4d/%-4d  %17.4e  %15.4e  %13.4e  %+11.4e  %5.1f", r.core, r.ring, r.error_average, r.error_centre,
                r.error_max, r.tau / tau_exact() - 1, r.seconds);
    if (i > 0)
      std::printf("   order %.3f (avg) %.3f (centre) %.3f (max)",
                  std::log(runs[i - 1].error_average / r.error_average) / std::log(2.0),
                  std::log(runs[i - 1].error_centre / r.error_centre) / std::log(2.0),
                  std::log(runs[i - 1].error_max / r.error_max) / std::log(2.0));
    std::printf("\n");
  }
}

namespace {

// Plasma alone through the stenosis at a fixed pressure drop, in Stokes flow: d = 100 um,
// l = 2400 um, a cosine constriction of L_s = 2000 um (20 R0: slowly varying, |R'| <= 0.023)
// halving the area at its throat, dP = 0.576 Pa (the straight tube's gamma_w = 5 1/s; Re at the
// throat 0.01). Returns the measured flow rate over lubrication theory's,
// Q_lub = pi dP / (8 mu int R(z)^-4 dz): the measured Q is the mesh's integral of u_z over the
// length, sum u_z V / l (the flow rate is the same at every station).
struct StenosisRun {
  int core = 0, ring = 0, axial = 0;
  double q_over_lubrication = 0, seconds = 0;
};

StenosisRun stenosis_flow(int core, int ring, int axial) {
  SceneSpec s;
  s.name = "stenosis-" + std::to_string(core);
  s.length_um = 2400;
  s.vessel = "shape = \"stenosis\"\nstenosis_area_reduction = 0.5\nstenosis_length_um = 2000";
  s.core = core;
  s.ring = ring;
  s.axial = axial;
  s.driving = "pressure_drop_Pa = 0.576";
  s.particle_command = prescribed("--mode none --record state.csv");
  const auto r = run_scene(s);
  EXPECT_EQ(r.command.exit_code, 0) << r.command.output;
  StenosisRun out{core, ring, axial, 0, r.command.seconds};
  const auto m = read_metrics(r.dir);
  const auto& mean = m.at({"fluid", "mean_velocity_m_s"});
  // Steady to the solver's tolerance (a change of a few 1e-9 per step): far below the 1e-3 asserted.
  EXPECT_LT(std::abs(mean.rbegin()->second / std::next(mean.rbegin())->second - 1), 1e-7) << "not steady";

  hemo::Vessel vessel{100e-6, 2400e-6};
  vessel.shape = "stenosis";
  vessel.stenosis_area_reduction = 0.5;
  vessel.stenosis_length = 2000e-6;
  const auto g = hemo::make_vessel_geometry(vessel);
  const double q_lub = kPi * 0.576 / (8 * kMu * g->axial_integral([](double R) { return std::pow(R, -4); }));
  double flux = 0;
  for (const auto& c : read_state(r.dir + "/state.csv")) flux += c.u[2] * c.volume;
  out.q_over_lubrication = flux / vessel.length / q_lub;
  return out;
}

}  // namespace

// Lubrication theory in the stenosed vessel (docs/fluid-verification.md §5): Stokes flow through
// a slowly varying constriction obeys dP = (8 mu Q / pi) int R(z)^-4 dz up to the theory's own
// slenderness error, O(R'^2) with max |R'| = pi s R0 / L_s = 0.023 here (R'^2 <= 5.3e-4). Each
// station is the straight section scaled to R(z), and Stokes flow in a scaled section has the same
// relative error, so the mesh's error is the straight tube's on the same O-grid (its Poiseuille
// Q over the exact one, 1 / relative_viscosity) plus the axial stations' error. Two resolutions,
// the O-grid and the stations refined together by 3/2 (measured, Q/Q_lub - 1: +5.0e-2, +2.0e-2;
// divided by the straight O-grid's Q/Q_P: +1.18e-2, +4.97e-3): both errors more than halve, and
// the corrected one extrapolated to the fine limit at the scheme's second order is -5e-4, within
// 2e-3 of lubrication theory (four times the slenderness bound: the theory's error, not the mesh's).
TEST(FluidStenosis, FlowRateConvergesToLubricationTheory) {
  std::printf("Stenosis, d = 100 um, A = 0.5, L_s = 2000 um, Stokes: Q / Q_lubrication\n");
  std::vector<double> raw, corrected;
  for (const auto& [core, ring, axial] : {std::tuple{4, 3, 24}, std::tuple{6, 5, 36}}) {
    const StenosisRun r = stenosis_flow(core, ring, axial);
    const double straight = 1 / poiseuille(core, ring).relative_viscosity;  // Q / Q_Poiseuille
    raw.push_back(r.q_over_lubrication - 1);
    corrected.push_back(r.q_over_lubrication / straight - 1);
    std::printf("  %d/%d x %2d  Q/Q_lub - 1 = %+.4e, straight O-grid Q/Q_P - 1 = %+.4e, ratio - 1 = %+.4e  (%.1f s)\n",
                core, ring, axial, raw.back(), straight - 1, corrected.back(), r.seconds);
  }
  EXPECT_LT(std::abs(raw[1]), std::abs(raw[0]) / 2);
  EXPECT_LT(std::abs(corrected[1]), std::abs(corrected[0]) / 2);
  const double refinement = 1.5, limit = corrected[1] - (corrected[0] - corrected[1]) / (refinement * refinement - 1);
  std::printf("  corrected, extrapolated at second order: %+.2e\n", limit);
  EXPECT_LT(std::abs(limit), 2e-3);
}

// A uniform, fixed fluid fraction alpha (phi = 0.3, no forces) gives the same flow: alpha
// multiplies every term of the momentum equation. Same fields as alpha = 1 to solver tolerance.
TEST(FluidUniformAlpha, GivesTheSamePoiseuilleProfile) {
  const auto plain = poiseuille(8, 6);
  const auto dense = poiseuille(8, 6, "--mode uniform --phi 0.3");
  ASSERT_EQ(plain.cells.size(), dense.cells.size());
  double worst = 0, umax = 0;
  for (std::size_t i = 0; i < plain.cells.size(); ++i) {
    EXPECT_DOUBLE_EQ(dense.cells[i].phi, 0.3);
    umax = std::max(umax, std::abs(plain.cells[i].u[2]));
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(dense.cells[i].u[k] - plain.cells[i].u[k]));
  }
  std::printf("uniform alpha = 0.7 vs alpha = 1 (8/6): max |du|/u_max = %.3e; L2 error vs Poiseuille %.4e vs %.4e\n",
              worst / umax, dense.error_average, plain.error_average);
  EXPECT_LT(worst / umax, 1e-8);
  EXPECT_NEAR(dense.error_average, plain.error_average, 1e-8);
  EXPECT_NEAR(dense.tau / plain.tau, 1, 1e-8);
}

// The suspension's own viscosity, beyond the paper (plasma.suspension_viscosity): with a uniform,
// fixed solid fraction phi = 0.3 and no particle forces the plasma is driven by alpha G and
// sheared by alpha nu + nu_s, nu_s = nu (mu_r(phi) - 1) (docs/model.md 7.5), so the flow is the
// plain Poiseuille profile slowed by alpha nu / (alpha nu + nu_s) in every cell, and the wall
// stress the node reports carries the suspension's viscosity on the wall faces: (mu + mu_s) du/dn.
TEST(FluidSuspensionViscosity, UniformSolidFractionSlowsPoiseuilleByTheMixturesViscosity) {
  const auto plain = poiseuille(8, 6);
  for (const std::string name : {"einstein", "krieger_dougherty"}) {
    const double phi = 0.3, alpha = 1 - phi;
    const double mu_r = hemo::suspension_viscosity(name).relative(phi);
    const double slowed = alpha / (alpha + mu_r - 1);
    const auto run =
        poiseuille(8, 6, "--mode uniform --phi 0.3", "[plasma]\nsuspension_viscosity = \"" + name + "\"\n");
    ASSERT_EQ(plain.cells.size(), run.cells.size());
    double worst = 0, umax = 0;
    for (std::size_t i = 0; i < plain.cells.size(); ++i) {
      umax = std::max(umax, std::abs(plain.cells[i].u[2]));
      worst = std::max(worst, std::abs(run.cells[i].u[2] - slowed * plain.cells[i].u[2]));
    }
    std::printf("%s, phi = 0.3: mu_r = %.4f, u / u_plain expected %.5f, max deviation %.3e of u_max; "
                "tau_w / tau_w,plain %.6f against %.6f\n",
                name.c_str(), mu_r, slowed, worst / umax, run.tau / plain.tau, mu_r * slowed);
    EXPECT_GT(mu_r, 1.5);  // the closure is on: the test would pass trivially with mu_r = 1
    EXPECT_LT(worst / umax, 1e-8) << name;
    EXPECT_NEAR(run.tau / plain.tau, mu_r * slowed, 1e-8) << name;
  }
}

// The paper's form (the default) puts F_p = -V_p grad P and F_v = V_p mu lap u on the particles,
// and the fluid node publishes grad P (the imposed drop included) and mu lap u per cell. In
// steady Poiseuille flow u = U_max (1 - r^2/R^2) both are the closed form, grad P = -dP/l e_z and
// mu lap u = -4 mu U_max / R^2 e_z = -dP/l e_z, so F_p + F_v = 0 on a particle at rest there;
// with a uniform solid fraction (0.3) too, since alpha multiplies every term of the plasma's
// equation alike. Per cell to solver tolerance (the steady discrete equation is
// nu lap u = grad p - G cell by cell; measured 1.5e-12 of dP/l). And the cells'
// sum of V mu lap u is the wall's viscous force to round-off: the fluid's own discrete
// Laplacian, whose interior fluxes telescope, so that plasma and particles together balance
// the whole drop (docs/model.md 1.1).
TEST(FluidStress, PoiseuilleGivesTheClosedFormsOfThePressureAndViscousForces) {
  const double dPdl = 4 * kMu * 799 / 100e-6;  // Pa/m, d = 100 um, gamma_w = 799 1/s
  for (const std::string mode : {"--mode none", "--mode uniform --phi 0.3"}) {
    const auto run = poiseuille(4, 3, mode);
    ASSERT_FALSE(run.cells.empty());
    double worst_p = 0, worst_v = 0, sum = 0;
    for (const auto& c : run.cells) {
      worst_p = std::max({worst_p, std::abs(c.pressure_gradient[2] + dPdl), std::abs(c.pressure_gradient[0]),
                          std::abs(c.pressure_gradient[1])});
      worst_v = std::max({worst_v, std::abs(c.viscous[2] + dPdl), std::abs(c.viscous[0]), std::abs(c.viscous[1])});
      sum += c.viscous[2] * c.volume;
    }
    std::printf("%s: worst |grad P + dP/l e_z| = %.2e, |mu lap u + dP/l e_z| = %.2e of dP/l; sum V mu lap u / wall "
                "force = %.15f\n",
                mode.c_str(), worst_p / dPdl, worst_v / dPdl, sum / run.wall_force);
    EXPECT_LT(worst_p / dPdl, 1e-9) << mode;
    EXPECT_LT(worst_v / dPdl, 1e-9) << mode;
    EXPECT_NEAR(sum / run.wall_force, 1.0, 1e-10) << mode;
  }
}

namespace {
// A solid-fraction blob (peak phi 0.3 on a background of 0.1, 15 um off the axis) travelling
// along the paper's vessel at 5 cm/s, coupled every 1e-4 s; `more`: more stand-in options.
SceneSpec moving_blob(const std::string& name, int axial_cells, double sigma_um, long steps,
                      const std::string& more = "") {
  SceneSpec s;
  s.name = name;
  s.axial = axial_cells;
  s.dt = 1e-4;
  s.steps = steps;
  s.particle_command = prescribed("--mode blob --phi 0.1 --blob-phi 0.3 --blob-sigma-um " + std::to_string(sigma_um) +
                                  " --blob-x-um 15 --blob-speed-m-s 0.05 " + more);
  return s;
}
}  // namespace

// The blob (sigma 12 um) on the paper mesh: the fluid must move out of its way. The discrete
// continuity residual sum |d(alpha)/dt + div(alpha U)| V dt / V_total stays at solver
// tolerance, relative to the same norm of d(alpha)/dt alone.
TEST(FluidContinuity, MovingSolidFractionBlobKeepsFluidMassToSolverTolerance) {
  const SceneSpec s = moving_blob("blob", 24, 12, 20);
  const auto r = run_scene(s);
  ASSERT_EQ(r.command.exit_code, 0) << r.command.output;
  const auto m = read_metrics(r.dir);
  const auto& cont = m.at({"fluid", "continuity_error"});
  const auto& ddt = m.at({"fluid", "alpha_ddt_norm"});
  const auto& removed = m.at({"fluid", "alpha_ddt_mean_removed_1_s"});
  const auto& solid = m.at({"particles", "solid_volume_m3"});
  double worst = 0, smallest_ddt = 1, worst_removed = 0;
  for (long k = 2; k <= s.steps; ++k) {  // step 1 starts from the first feedback: alpha does not move yet
    worst = std::max(worst, cont.at(k) / ddt.at(k));
    smallest_ddt = std::min(smallest_ddt, ddt.at(k));
    worst_removed = std::max(worst_removed, std::abs(removed.at(k)));
    EXPECT_NEAR(solid.at(k) / solid.at(0), 1, 1e-12) << "the prescription keeps the solid volume";
  }
  std::printf(
      "moving blob (paper mesh, dt = 1e-4 s): d(alpha)/dt norm >= %.3e, continuity residual / it <= %.3e, "
      "net d(alpha)/dt removed <= %.3e 1/s\n",
      smallest_ddt, worst, worst_removed);
  EXPECT_GT(smallest_ddt, 1e-4) << "the blob must really move";
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT(worst_removed, 1e-6);
}

// A wider blob (sigma 50 um, 48 axial cells: its d(alpha)/dt varies little as it crosses cells)
// across a change of coupling interval. The fluid applies in step k + 1 the
// particles' feedback of step k, so alpha's change it sees took the particles' interval k:
// d(alpha)/dt must divide it by that interval, not by its own. The stand-in reports a drag
// relaxation time of 1e-4 s, halved from 1 ms on, and the adaptive clock
// (time.coupling_relaxation_times = 1) takes intervals of 1e-4 s and then 5e-5 s. The blob
// moves at a constant speed, so d(alpha)/dt per unit time, alpha_ddt_norm / dt, must go on
// smoothly through the change: within 2 % of the step before at the first short step (dividing
// by the fluid's own interval doubles it there), as from step to step elsewhere.
TEST(FluidContinuity, BlobsSourceGoesOnSmoothlyWhenTheIntervalHalves) {
  SceneSpec s = moving_blob("blob-interval-change", 48, 50, 16,
                            "--relaxation-time-s 1e-4 --relaxation-time-later-s 5e-5 --later-from-s 1e-3");
  s.relaxation_times = 1;
  const auto r = run_scene(s);
  ASSERT_EQ(r.command.exit_code, 0) << r.command.output;
  const auto m = read_metrics(r.dir);
  const auto& time = m.at({"fluid", "time_s"});
  const auto& ddt = m.at({"fluid", "alpha_ddt_norm"});
  long first_short = 0;
  for (const auto& [k, t] : time)
    if (k >= 2 && first_short == 0 && t - time.at(k - 1) < 0.75e-4) first_short = k;
  ASSERT_EQ(first_short, 11) << "ten intervals of 1e-4 s, then 5e-5 s";
  ASSERT_EQ(time.rbegin()->first, 10 + 12);  // 1.6 ms
  double worst_elsewhere = 0;
  auto rate = [&](long k) { return ddt.at(k) / (time.at(k) - time.at(k - 1)); };
  for (long k = 3; k <= time.rbegin()->first; ++k)  // step 1: alpha does not move yet
    if (k != first_short) worst_elsewhere = std::max(worst_elsewhere, std::abs(rate(k) / rate(k - 1) - 1));
  const double at_change = rate(first_short) / rate(first_short - 1) - 1;
  std::printf(
      "moving blob, interval 1e-4 -> 5e-5 s at step %ld: d(alpha)/dt changes by %+.2e there, at most "
      "%.2e from step to step elsewhere\n",
      first_short, at_change, worst_elsewhere);
  EXPECT_LT(std::abs(at_change), 0.02);
  EXPECT_LT(worst_elsewhere, 0.02);
}

// A uniform explicit momentum source of known total F (and a uniform implicit drag K u, on a
// fixed phi = 0.2) in an undriven vessel starting at rest: the total fluid momentum
// P = sum rho alpha u V, computed by the prescribed node from the velocities it received,
// changes per unit time by F - sum K u V plus the plasma's viscous force, which the fluid
// reports (viscous_force_z_N: in the default form, the paper's alpha mu lap u summed over the
// cells; where alpha sits inside the divergence, the wall's force, wall_force_z_N), plus what
// the implicit drag kept back in the step before and hands back in this one
// (returned_force_z_N, coupling.return_held_back_momentum). The balance closes to solver
// tolerance at every step.
TEST(FluidMomentum, PrescribedSourceChangesMomentumByItsTotal) {
  const double F = 1e-7;  // N
  SceneSpec s;
  s.name = "momentum-source";
  s.axial = 4;
  s.driving = "pressure_drop_Pa = 0";
  s.dt = 1e-4;
  s.steps = 12;
  s.particle_command = prescribed("--mode source --phi 0.2 --drag-coefficient 1e6 --force-N 0,0,1e-7");
  const auto r = run_scene(s);
  ASSERT_EQ(r.command.exit_code, 0) << r.command.output;
  const auto m = read_metrics(r.dir);
  const auto& P = m.at({"particles", "fluid_momentum_z_kg_m_s"});
  const auto& drag = m.at({"particles", "fluid_drag_z_N"});
  const auto& sent = m.at({"particles", "source_total_z_N"});
  const auto& wall = m.at({"fluid", "viscous_force_z_N"});
  const auto& returned = m.at({"fluid", "returned_force_z_N"});
  const auto& own = m.at({"fluid", "momentum_budget_residual_z_N"});
  double worst = 0, worst_own = 0;
  std::printf(
      "momentum source F = %g N (phi = 0.2, K = 1e6 N s/m^4, at rest, no driving):\n"
      "  step  dP/dt N         F - drag + ret + visc N  visc/F  residual/F\n",
      F);
  for (long k = 1; k <= s.steps; ++k) {
    EXPECT_NEAR(sent.at(k - 1), F, 1e-12 * F);
    const double before = k == 1 ? 0.0 : P.at(k - 1);  // the fluid starts at rest
    const double rate = (P.at(k) - before) / s.dt;
    const double expected = sent.at(k - 1) - drag.at(k) + returned.at(k) + wall.at(k);
    const double residual = (rate - expected) / F;
    std::printf("  %4ld  %.9e  %.9e    %+.3e  %+.2e\n", k, rate, expected, wall.at(k) / F, residual);
    worst = std::max(worst, std::abs(residual));
    worst_own = std::max(worst_own, std::abs(own.at(k)) / F);
  }
  std::printf("  worst |residual|/F = %.3e (fluid's own budget: %.3e)\n", worst, worst_own);
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT(worst_own, 1e-9);
  EXPECT_LT(std::abs(wall.at(1)), std::abs(wall.at(s.steps))) << "wall friction grows as the flow develops";
  EXPECT_GT(std::abs(wall.at(s.steps)) / F, 0.1) << "the test must see the wall";
  EXPECT_GT(std::abs(returned.at(s.steps)) / F, 1e-3) << "the test must see the returned momentum";
}

// --- bad input: refused with one line naming the cause; the run stops keeping what it wrote ---

namespace {

SceneSpec small_scene(const std::string& name, const std::string& mode) {
  SceneSpec s;
  s.name = name;
  s.diameter_um = 40;
  s.length_um = 60;
  s.core = 2;
  s.ring = 2;
  s.axial = 6;
  s.dt = 1e-5;
  s.steps = 6;
  s.every_steps = 1;
  s.particle_command = prescribed(mode);
  return s;
}

// Runs a scene that must fail; checks the error line names `cause` and the run dir survives.
void expect_refused(const SceneSpec& s, const std::string& cause, long failed_step) {
  const auto r = run_scene(s);
  EXPECT_NE(r.command.exit_code, 0) << r.command.output;
  const std::string line = error_line(r.command.output);
  std::printf("%s: exit %d, %.1f s: %s\n", s.name.c_str(), r.command.exit_code, r.command.seconds, line.c_str());
  EXPECT_NE(line.find(cause), std::string::npos) << r.command.output;
  EXPECT_NE(line.find("fluid node"), std::string::npos) << line;
  EXPECT_NE(line.find("step " + std::to_string(failed_step)), std::string::npos) << line;
  // What was written is kept: scene copy, metrics up to the step before, the fluid's log.
  EXPECT_TRUE(std::filesystem::exists(r.dir + "/scene.toml"));
  EXPECT_TRUE(std::filesystem::exists(r.dir + "/fluid.log"));
  const auto m = read_metrics(r.dir);
  if (failed_step > 1) {
    const auto& t = m.at({"fluid", "time_s"});
    EXPECT_EQ(t.rbegin()->first, failed_step - 1);
    // ... and the fluid's output of the last good step (every step is written in these scenes).
    char name[64];
    std::snprintf(name, sizeof name, "%.12g", (failed_step - 1) * s.dt);
    EXPECT_TRUE(std::filesystem::exists(r.dir + "/fluid/" + name + "/U")) << name;
  }
}

}  // namespace

TEST(FluidBadInput, MeshFinerThanTheParticlesIsRefused) {
  auto s = small_scene("too-fine", "--mode none");
  s.core = 8;
  s.ring = 6;
  s.axial = 30;
  s.extra = "[rbc]\nhematocrit = 0.1\n";
  // Refused with the scene, before any node starts (model/scene.cpp, by the mean cell volume);
  // the fluid node's own check (fluid_case.cpp, by the smallest cell) stays for the O-grid's
  // cells below the mean.
  const auto r = run_scene(s);
  EXPECT_EQ(r.command.exit_code, 2) << r.command.output;
  const std::string line = error_line(r.command.output);
  EXPECT_NE(line.find("mesh.axial_cells = 30: a rbc of 5.56 um is larger than the fluid cells"), std::string::npos)
      << r.command.output;
}

TEST(FluidBadInput, NanFeedbackIsRefused) {
  expect_refused(small_scene("nan-feedback", "--mode nan --bad-at-step 3"), "solid fraction nan", 4);
}

TEST(FluidBadInput, WrongSizedFeedbackIsRefused) {
  expect_refused(small_scene("wrong-size", "--mode wrong-size --bad-at-step 2"),
                 "particle feedback has 119 cells, the fluid mesh 120", 3);
}

TEST(FluidBadInput, FeedbackForAnotherMeshIsRefused) {
  expect_refused(small_scene("wrong-mesh", "--mode wrong-mesh --bad-at-step 1"),
                 "particle feedback is for mesh '0123456789abcdef'", 2);
}

// --- decomposed fluid: hemocosim-fluid --ranks N runs N solver ranks under mpirun ---

namespace {

struct FieldDifference {
  double velocity = 0;  // max |du| / max |u|
  double gradient = 0;  // max |dG| / max |G|
};

FieldDifference compare(const std::vector<CellState>& a, const std::vector<CellState>& b) {
  FieldDifference d;
  double umax = 0, gmax = 0;
  EXPECT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    EXPECT_DOUBLE_EQ(a[i].x, b[i].x);  // the same cell order
    for (int k = 0; k < 3; ++k) {
      umax = std::max(umax, std::abs(a[i].u[k]));
      d.velocity = std::max(d.velocity, std::abs(a[i].u[k] - b[i].u[k]));
    }
    for (int k = 0; k < 9; ++k) {
      gmax = std::max(gmax, std::abs(a[i].grad[k]));
      d.gradient = std::max(d.gradient, std::abs(a[i].grad[k] - b[i].grad[k]));
    }
  }
  d.velocity /= umax;
  d.gradient /= gmax;
  return d;
}

}  // namespace

// The moving blob of FluidContinuity on the paper mesh, serial and on 2 ranks (24 axial cells,
// 12 per rank): the whole-mesh fields the master publishes are the serial ones to solver
// tolerance. (They are not bit-identical: the first PISO correctors solve p only to 1 % of
// its initial residual, and GAMG's coarse levels differ with the decomposition.)
TEST(FluidParallel, TwoRanksPublishTheSerialFields) {
  SceneSpec s;
  s.name = "blob-serial";
  s.axial = 24;
  s.dt = 1e-4;
  s.steps = 10;
  s.particle_command = prescribed(
      "--mode blob --phi 0.1 --blob-phi 0.3 --blob-sigma-um 12 --blob-x-um 15 "
      "--blob-speed-m-s 0.05 --record state.csv");
  const auto serial = run_scene(s);
  ASSERT_EQ(serial.command.exit_code, 0) << serial.command.output;
  s.name = "blob-2-ranks";
  const auto parallel = run_scene(s, "--np-fluid 2");
  ASSERT_EQ(parallel.command.exit_code, 0) << parallel.command.output;
  EXPECT_TRUE(std::filesystem::exists(parallel.dir + "/fluid/processor1"));

  const auto d = compare(read_state(serial.dir + "/state.csv"), read_state(parallel.dir + "/state.csv"));
  const auto ms = read_metrics(serial.dir), mp = read_metrics(parallel.dir);
  double worst_cont = 0;
  for (long k = 2; k <= s.steps; ++k)
    worst_cont =
        std::max(worst_cont, mp.at({"fluid", "continuity_error"}).at(k) / mp.at({"fluid", "alpha_ddt_norm"}).at(k));
  std::printf(
      "2 ranks vs serial (moving blob, paper mesh, %ld steps): max |du|/u_max = %.3e, max |dG|/G_max = %.3e; "
      "continuity residual / d(alpha)/dt norm on 2 ranks <= %.3e; wall %.1f s vs %.1f s\n",
      s.steps, d.velocity, d.gradient, worst_cont, parallel.command.seconds, serial.command.seconds);
  EXPECT_LT(d.velocity, 1e-6);
  EXPECT_LT(d.gradient, 1e-6);
  EXPECT_LT(worst_cont, 1e-9);
  EXPECT_NEAR(last(mp, "fluid", "mean_velocity_m_s") / last(ms, "fluid", "mean_velocity_m_s"), 1, 1e-8);
  EXPECT_EQ(last(mp, "fluid", "piso_correctors"), last(ms, "fluid", "piso_correctors"));
}

// Steady Poiseuille (8/6, 4 axial cells) on 2 ranks: the same profile as serial.
TEST(FluidParallel, TwoRanksGiveTheSerialPoiseuille) {
  SceneSpec s;
  s.name = "poiseuille-serial";
  s.core = 8;
  s.ring = 6;
  s.axial = 4;
  s.particle_command = prescribed("--mode none --record state.csv");
  const auto serial = run_scene(s);
  ASSERT_EQ(serial.command.exit_code, 0) << serial.command.output;
  s.name = "poiseuille-2-ranks";
  const auto parallel = run_scene(s, "--np-fluid 2");
  ASSERT_EQ(parallel.command.exit_code, 0) << parallel.command.output;
  const auto d = compare(read_state(serial.dir + "/state.csv"), read_state(parallel.dir + "/state.csv"));
  std::printf("2 ranks vs serial (steady Poiseuille, 8/6): max |du|/u_max = %.3e, max |dG|/G_max = %.3e\n", d.velocity,
              d.gradient);
  EXPECT_LT(d.velocity, 1e-8);
  EXPECT_LT(d.gradient, 1e-8);
}

TEST(FluidParallel, BadFeedbackStopsEveryRankNamingTheCause) {
  const auto s = small_scene("nan-feedback-2-ranks", "--mode nan --bad-at-step 3");
  const auto r = run_scene(s, "--np-fluid 2");
  EXPECT_NE(r.command.exit_code, 0) << r.command.output;
  const std::string line = error_line(r.command.output);
  std::printf("%s: exit %d, %.1f s: %s\n", s.name.c_str(), r.command.exit_code, r.command.seconds, line.c_str());
  EXPECT_NE(line.find("fluid node failed at step 4"), std::string::npos) << r.command.output;
  EXPECT_NE(line.find("solid fraction nan"), std::string::npos) << r.command.output;
  EXPECT_LT(r.command.seconds, 30);
}

TEST(FluidParallel, MoreRanksThanAxialCellsIsRefused) {
  auto s = small_scene("too-many-ranks", "--mode none");
  s.axial = 2;
  const auto r = run_scene(s, "--np-fluid 3");
  EXPECT_NE(r.command.exit_code, 0) << r.command.output;
  const std::string line = error_line(r.command.output);
  std::printf("%s: %s\n", s.name.c_str(), line.c_str());
  EXPECT_NE(line.find("3 ranks need at least as many axial cells"), std::string::npos) << r.command.output;
}

// --- the fluid solver's settings: cost against error on the calibration mesh ---

namespace {

struct SettingsRun {
  std::string label, keys;
  double ms_per_step = 0;                                     // median fluid compute_s over steps 3..
  double correctors = 0, p_iterations = 0, U_iterations = 0;  // per step
  double continuity = 0;                                      // max continuity_error / alpha_ddt_norm, steps 2..
  double budget = 0;                                          // max |momentum_budget_residual_z_N| / driving_force_z_N
  std::map<long, double> mean;                                // mean_velocity_m_s per step
  std::vector<CellState> cells;                               // last state
  double poiseuille_error = 0;                                // L2 error (cell averages), steady particle-free 4/3
};

SettingsRun settings_run(const std::string& label, const std::string& keys, long steps, bool with_poiseuille) {
  SettingsRun out;
  out.label = label;
  out.keys = keys;
  SceneSpec s;
  s.name = "settings-" + label;
  s.axial = 24;  // the calibration scene's 1,536 cells
  s.dt = 1e-4;   // its coupling interval
  s.steps = steps;
  s.particle_command = prescribed(
      "--mode blob --phi 0.1 --blob-phi 0.3 --blob-sigma-um 12 --blob-x-um 15 "
      "--blob-speed-m-s 0.05 --record state.csv");
  s.extra = "[fluid]\n" + keys + "\n";
  const auto r = run_scene(s);
  EXPECT_EQ(r.command.exit_code, 0) << r.command.output;
  const auto m = read_metrics(r.dir);
  std::vector<double> t;
  for (long k = 3; k <= steps; ++k) {
    t.push_back(m.at({"fluid", "compute_s"}).at(k));
    out.correctors += m.at({"fluid", "piso_correctors"}).at(k) / double(steps - 2);
    out.p_iterations += m.at({"fluid", "p_iterations"}).at(k) / double(steps - 2);
    out.U_iterations += m.at({"fluid", "U_iterations"}).at(k) / double(steps - 2);
  }
  std::sort(t.begin(), t.end());
  out.ms_per_step = 1e3 * (t.size() % 2 ? t[t.size() / 2] : 0.5 * (t[t.size() / 2 - 1] + t[t.size() / 2]));
  for (long k = 2; k <= steps; ++k) {
    out.continuity =
        std::max(out.continuity, m.at({"fluid", "continuity_error"}).at(k) / m.at({"fluid", "alpha_ddt_norm"}).at(k));
    out.budget = std::max(out.budget, std::abs(m.at({"fluid", "momentum_budget_residual_z_N"}).at(k)) /
                                          m.at({"fluid", "driving_force_z_N"}).at(k));
  }
  out.mean = m.at({"fluid", "mean_velocity_m_s"});
  out.cells = read_state(r.dir + "/state.csv");
  // The steady Poiseuille check asserts steadiness to 1e-9, which the looser tolerances are not
  // meant to reach in 20 steps; only the settings asserted on it are compared there.
  if (with_poiseuille)
    out.poiseuille_error = poiseuille(4, 3, "--mode none", "[fluid]\n" + keys + "\n").error_average;
  return out;
}

// Every pressure corrector solved to 1e-10, the velocity to 1e-12: the flow the others are held to.
const char* const kTightSettings = "pressure_relative_tolerance = 0\nvelocity_tolerance = 1e-12\npressure_tolerance = 1e-10";

// The largest relative difference of the mean velocity over the steps, and the largest
// difference of a velocity component in a cell at the end over the reference's largest.
std::pair<double, double> flow_difference(const SettingsRun& r, const SettingsRun& reference) {
  double mean_err = 0, du = 0, umax = 0;
  for (const auto& [k, v] : r.mean)
    if (k >= 1) mean_err = std::max(mean_err, std::abs(v / reference.mean.at(k) - 1));
  for (std::size_t i = 0; i < r.cells.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      umax = std::max(umax, std::abs(reference.cells[i].u[c]));
      du = std::max(du, std::abs(r.cells[i].u[c] - reference.cells[i].u[c]));
    }
  return {mean_err, du / umax};
}

}  // namespace

// The calibration mesh (4/3/24, 1,536 cells) at its coupling interval (1e-4 s) with a moving
// solid-fraction blob: the default solver settings against tight ones (every pressure corrector
// solved to 1e-10, the velocity to 1e-12). The defaults must give the same flow: mean velocity
// within 1e-4 relative at every step (measured: far closer), continuity to 1e-9, a momentum-budget
// residual no larger than the tight settings' own, the same steady Poiseuille error; so must the
// defaults with fluid.pressure_solver = "PCG" instead of GAMG. The time per
// step is printed, side by side, not asserted; docs/fluid-verification.md quotes the table.
// "The same flow": the mean velocity within this fraction of itself and every cell's within this
// fraction of u_max, after the blob's steps.
constexpr double kSameFlow = 1e-4;

TEST(FluidSolverSettings, DefaultsGiveTheTightSettingsFlow) {
  const long steps = 30;
  std::vector<SettingsRun> runs;
  runs.push_back(settings_run("tight", kTightSettings, steps, true));
  runs.push_back(settings_run("defaults", "", steps, true));
  runs.push_back(settings_run("U-1e-6", "velocity_tolerance = 1e-6", steps, false));
  runs.push_back(settings_run("corr-1e-2", "corrector_tolerance = 1e-2", steps, false));
  runs.push_back(settings_run("p-1e-7", "pressure_tolerance = 1e-7", steps, false));
  runs.push_back(settings_run("PCG", "pressure_solver = \"PCG\"", steps, true));
  const auto& tight = runs.front();
  std::printf(
      "fluid solver settings, calibration mesh 4/3/24, dt = 1e-4 s, moving blob, %ld steps:\n"
      "  %-10s %8s %6s %7s %6s %12s %12s %11s %11s %12s\n",
      steps, "settings", "ms/step", "corr", "p it", "U it", "mean U err", "max du/umax", "contin.", "budget",
      "Poiseuille");
  for (const auto& r : runs) {
    const auto [mean_err, du] = flow_difference(r, tight);
    std::printf("  %-10s %8.2f %6.2f %7.1f %6.1f %12.3e %12.3e %11.2e %11.2e %12.6e\n", r.label.c_str(), r.ms_per_step,
                r.correctors, r.p_iterations, r.U_iterations, mean_err, du, r.continuity, r.budget,
                r.poiseuille_error);
    if (r.label == "defaults" || r.label == "PCG") {  // the defaults, and the other p solver
      EXPECT_LT(mean_err, kSameFlow);
      EXPECT_LT(du, kSameFlow);
      EXPECT_LT(r.continuity, 1e-9);
      // The moving blob leaves a budget residual of ~6e-5 of the driving force even with tight
      // settings; the defaults must not add to it.
      EXPECT_LT(r.budget, tight.budget * (1 + 1e-3) + 1e-12);
      EXPECT_NEAR(r.poiseuille_error, tight.poiseuille_error, 1e-6);
    }
  }
}

// The cheaper readings of docs/performance.md ("The fluid's solvers") on top of the calibration
// scene's settings (corrector_tolerance 1e-2, PCG, pressure_relative_tolerance 0.1), on the
// calibration mesh at its interval with the moving blob, 30 steps:
// - one pressure solve per corrector (fluid.non_orthogonal_correctors = 0; the O-grid is within
//   15.3 deg of orthogonal) must add no more to the scene's settings than they already differ
//   from the tight ones (mean velocity and the largest cell difference);
// - the U predictor to 1 % of its initial residual (velocity_relative_tolerance = 0.01), alone and
//   with the above, moves the mean velocity by more than that (2.5e-5 against 1.5e-6): it is held
//   to the bar DefaultsGiveTheTightSettingsFlow sets for "the same flow", 1e-4 relative in the mean
//   velocity and 1e-4 of u_max in any cell, against the scene's settings;
// - with two PISO correctors besides, cells move by ~3e-3 of u_max: printed, not asserted (not
//   the same flow by that bar; docs/performance.md).
// A lagged non-orthogonal correction and a looser predictor change the path to the steady state,
// not the state: each must reach the tight settings' steady Poiseuille flow (its L2 error
// against the analytic profile the same to 1e-6), and continuity holds to 1e-9.
TEST(FluidSolverSettings, CheaperReadingsKeepThePoiseuilleFlowAndTheScenesFlow) {
  const long steps = 30;
  const std::string scene = "corrector_tolerance = 1e-2\npressure_solver = \"PCG\"\npressure_relative_tolerance = 0.1\n";
  const auto tight = settings_run("tight", kTightSettings, steps, true);
  const auto calibration = settings_run("calibration", scene, steps, true);
  const auto [scene_mean, scene_du] = flow_difference(calibration, tight);
  std::printf("cheaper readings on the calibration scene's settings, 4/3/24, dt = 1e-4 s, moving blob, %ld steps:\n"
              "  %-28s %8s %6s %7s %6s %13s %12s %13s %12s %11s %12s\n",
              steps, "settings", "ms/step", "corr", "p it", "U it", "mean vs tight", "du vs tight", "mean vs scene",
              "du vs scene", "contin.", "Poiseuille");
  const auto print = [&](const SettingsRun& r) {
    const auto [mean_t, du_t] = flow_difference(r, tight);
    const auto [mean_s, du_s] = flow_difference(r, calibration);
    std::printf("  %-28s %8.2f %6.2f %7.1f %6.1f %13.3e %12.3e %13.3e %12.3e %11.2e %12.6e\n", r.label.c_str(),
                r.ms_per_step, r.correctors, r.p_iterations, r.U_iterations, mean_t, du_t, mean_s, du_s, r.continuity,
                r.poiseuille_error);
  };
  print(tight);
  print(calibration);
  enum class Bar { scenes_own, same_flow, none };
  struct Reading {
    std::string label, keys;
    Bar bar;
    bool one_p_solve, loose_u;  // what must show in the work: fewer p iterations, fewer U iterations
  };
  const std::vector<Reading> readings{
      {"nonorth-0", "non_orthogonal_correctors = 0", Bar::scenes_own, true, false},
      {"U-rel-0.01", "velocity_relative_tolerance = 0.01", Bar::same_flow, false, true},
      {"nonorth-0-U-rel-0.01", "non_orthogonal_correctors = 0\nvelocity_relative_tolerance = 0.01", Bar::same_flow,
       true, true},
      {"nonorth-0-U-rel-0.01-piso-2",
       "non_orthogonal_correctors = 0\nvelocity_relative_tolerance = 0.01\nmax_correctors = 2", Bar::none, true,
       true}};
  for (const auto& reading : readings) {
    const auto r = settings_run(reading.label, scene + reading.keys, steps, reading.bar != Bar::none);
    print(r);
    // The setting reached the solver: its work changed as it says.
    if (reading.one_p_solve) {
      EXPECT_LT(r.p_iterations, 0.9 * calibration.p_iterations) << reading.label;
    }
    if (reading.loose_u) {
      EXPECT_LT(r.U_iterations, 0.5 * calibration.U_iterations) << reading.label;
    }
    if (reading.bar == Bar::none) continue;
    const auto [mean_s, du_s] = flow_difference(r, calibration);
    EXPECT_LE(mean_s, reading.bar == Bar::scenes_own ? scene_mean : kSameFlow) << reading.label;
    EXPECT_LE(du_s, reading.bar == Bar::scenes_own ? scene_du : kSameFlow) << reading.label;
    EXPECT_LT(r.continuity, 1e-9) << reading.label;
    EXPECT_NEAR(r.poiseuille_error, tight.poiseuille_error, 1e-6) << reading.label;
  }
}

// coupling.plasma_velocity = "face_flux": the fluid publishes U rebuilt from its conservative face
// fluxes (and that field's gradient) instead of the cell-centre U. In particle-free Poiseuille
// flow both are the same flow to the mesh's discretisation error (here, where the O-grid's
// cells are largest, a few % of u_max at most); where a solid-fraction blob moves through the
// plasma they part by far more than solver tolerance: the option changes what the particles see,
// not the flow (the fluid's own U, and so its mean velocity, are the same in both runs).
TEST(FluidState, FaceFluxVelocityIsTheSameFlowWhereNothingForcesTheCells) {
  SceneSpec s;
  s.name = "poiseuille-face-flux";
  s.particle_command = prescribed("--mode none --record state.csv");
  s.extra = "[coupling]\nplasma_velocity = \"face_flux\"\n";
  const auto flux = run_scene(s);
  ASSERT_EQ(flux.command.exit_code, 0) << flux.command.output;
  s.name = "poiseuille-cell-centre";
  s.extra = "[coupling]\nplasma_velocity = \"cell_centre\"\n";
  const auto centre = run_scene(s);
  ASSERT_EQ(centre.command.exit_code, 0) << centre.command.output;
  const auto still = compare(read_state(centre.dir + "/state.csv"), read_state(flux.dir + "/state.csv"));

  SceneSpec blob = moving_blob("blob-cell-centre", 24, 12, 10, "--record state.csv");
  blob.extra = "[coupling]\nplasma_velocity = \"cell_centre\"\n";
  const auto b_centre = run_scene(blob);
  ASSERT_EQ(b_centre.command.exit_code, 0) << b_centre.command.output;
  blob.name = "blob-face-flux";
  blob.extra = "[coupling]\nplasma_velocity = \"face_flux\"\n";
  const auto b_flux = run_scene(blob);
  ASSERT_EQ(b_flux.command.exit_code, 0) << b_flux.command.output;
  const auto moving = compare(read_state(b_centre.dir + "/state.csv"), read_state(b_flux.dir + "/state.csv"));
  std::printf(
      "face-flux against cell-centre velocity, max |du| / u_max: Poiseuille %.3e (gradient %.3e), moving blob "
      "%.3e\n",
      still.velocity, still.gradient, moving.velocity);
  EXPECT_GT(still.velocity, 0.0);    // the option is in effect
  EXPECT_LT(still.velocity, 0.05);   // the same flow, to discretisation error
  EXPECT_GT(moving.velocity, 1e-4);  // far above solver tolerance where the solid fraction moves
  EXPECT_EQ(last(read_metrics(b_centre.dir), "fluid", "mean_velocity_m_s"),
            last(read_metrics(b_flux.dir), "fluid", "mean_velocity_m_s"));
}
