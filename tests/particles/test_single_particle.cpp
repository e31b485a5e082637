// SPDX-License-Identifier: GPL-3.0-or-later
// Single particles stepped as the engine steps them (single_particle.h), in analytic flows:
// terminal slip under a constant force for each drag law; a spherical-surrogate platelet in
// Poiseuille flow settles near 0.6 R; an RBC migrates toward the axis.
#include "flows.h"
#include "single_particle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace hemo::particles;
using namespace hemo::particles::testing;

namespace {

const double kR = 50e-6, kUmax = 799 * kR / 2;  // the calibration vessel at gamma_w = 799 1/s

hemo::Scene vessel() {
  hemo::Scene s;
  s.vessel.diameter = 2 * kR;
  s.vessel.length = 600e-6;
  return s;
}

hemo::Species rbc(const std::string& drag, const std::string& lift = "none") {
  hemo::Species s{"rbc"};
  s.diameter = 5.56e-6;
  s.volume = 90e-18;
  s.mass = 1100 * 90e-18;
  s.drag = drag;
  s.lift = lift;
  return s;
}

hemo::Species platelet(const std::string& drag, const std::string& lift = "none", const std::string& torque = "none") {
  hemo::Species s{"platelet"};
  s.diameter = 2.66e-6;
  s.mass = 8.79e-15;
  s.volume = 7.4e-18;
  s.semi_axis_a = 2.06e-6;
  s.semi_axis_c = 0.52e-6;
  s.drag = drag;
  s.lift = lift;
  s.torque = torque;
  return s;
}

FlowAt at_rest() {
  return [](const Vec3&, const Vec3& v) {
    ParticleFlow f;
    f.slip = -v;
    return f;
  };
}

FlowAt poiseuille_at() {
  return [](const Vec3& x, const Vec3& v) { return poiseuille_flow(x, kR, kUmax, v); };
}

// The speed U below `hi` at which the law's drag balances `force`: beta(U) U = F (bisection on
// the branch where beta(U) U grows; the RBC fit turns over near Re 0.9).
double terminal_speed(const SpeciesForces& forces, const Vec3& direction, const Vec3& axis, double force, double hi) {
  double lo = 0;
  for (int i = 0; i < 200; ++i) {
    const double u = 0.5 * (lo + hi);
    ParticleFlow f;
    f.slip = -u * direction;
    f.axis = axis;
    (forces.drag().coefficient(f) * u < force ? lo : hi) = u;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

TEST(SingleParticle, TerminalSlipUnderAConstantForceMatchesEachDragLaw) {
  struct Case {
    hemo::Species species;
    double reynolds;  // of the terminal slip
    Vec3 direction;   // of the force; platelets' axis stays along z
  };
  const Vec3 z = Vec3::UnitZ(), x = Vec3::UnitX();
  const std::vector<Case> cases = {
      {rbc("stokes"), 1e-3, x},
      {rbc("rbc_fit"), 1e-3, x},
      {rbc("rbc_fit"), 0.4, x},
      {rbc("rbc_fit"), 0.7, x},
      {platelet("schiller_naumann"), 0.1, x},
      {platelet("schiller_naumann"), 5, x},
      {platelet("oblate"), 0.01, z},
      {platelet("oblate"), 0.01, x},
      {platelet("oblate"), 2, z},
  };
  const double nu = 1.2e-3 / 1025;
  for (const auto& c : cases) {
    const SpeciesForces forces(c.species, vessel());
    const double u_star = c.reynolds * nu / c.species.diameter;
    ParticleFlow at_star;
    at_star.slip = -u_star * c.direction;
    const double force = forces.drag().coefficient(at_star) * u_star;
    const double tau = forces.mass() / forces.max_coefficient_at_rest();
    for (double dt_over_tau : {0.1, 1.0, 10.0}) {
      SingleParticle p;
      const SingleParticleStepper stepper(forces, nullptr, at_rest());
      for (int n = 0; n < 4000; ++n) stepper.step(p, dt_over_tau * tau, force * c.direction);
      EXPECT_NEAR(p.v.dot(c.direction), u_star, 1e-9 * u_star)
          << c.species.drag << " Re " << c.reynolds << " dt/tau " << dt_over_tau;
      EXPECT_NEAR((p.v - p.v.dot(c.direction) * c.direction).norm(), 0, 1e-12 * u_star);
    }
    const double hi = std::min(2 * u_star, 0.85 * nu / c.species.diameter / (c.species.drag == "rbc_fit" ? 1 : 1e-3));
    EXPECT_NEAR(terminal_speed(forces, c.direction, z, force, hi), u_star, 1e-9 * u_star);
    std::printf("[ info ] %-16s Re %-5g terminal slip %.6g m/s under %.4g N (Stokes would give %.6g m/s)\n",
                c.species.drag.c_str(), c.reynolds, u_star, force, force / (3 * kPi * 1.2e-3 * c.species.diameter));
  }
}

TEST(SingleParticle, SphericalPlateletSettlesNearSixTenthsOfTheRadius) {
  // Schiller-Naumann drag and the shear-induced lift: inertial migration is slow at these Re
  // (~5 nm/s, a time constant of ~1000 s), so the particle is stepped at dt = 0.5 s: 1.7e6
  // drag relaxation times per step, which the exponential update takes in its stride.
  const SpeciesForces forces(platelet("schiller_naumann", "shear_lift"), vessel());
  const SingleParticleStepper stepper(forces, nullptr, poiseuille_at());
  for (double start : {0.2, 0.45, 0.9}) {
    SingleParticle p;
    p.x = Vec3(start * kR * 0.6, start * kR * 0.8, 0);
    p.v = Vec3(0, 0, kUmax * (1 - start * start));
    const double dt = 0.5;
    for (int n = 0; n < 40000; ++n) stepper.step(p, dt);  // 2e4 s
    const double r = std::hypot(p.x.x(), p.x.y()) / kR;
    std::printf("[ info ] spherical platelet from r = %.2f R settles at r = %.4f R\n", start, r);
    EXPECT_NEAR(r, 0.6056, 0.005) << "from " << start;
    EXPECT_NEAR(std::atan2(p.x.y(), p.x.x()), std::atan2(0.8, 0.6), 1e-9);  // radial migration only
  }
}

TEST(SingleParticle, RedCellMigratesTowardTheAxisAtTheQuasiSteadyRate) {
  const SpeciesForces forces(rbc("rbc_fit", "rbc_lift"), vessel());
  const SingleParticleStepper stepper(forces, nullptr, poiseuille_at());
  // Quasi-steady migration dr/dt = F_L(r) / beta, integrated with RK4 for comparison.
  const auto rate = [&](double r) {
    const ParticleFlow f = poiseuille_flow(Vec3(r, 0, 0), kR, kUmax, Vec3(0, 0, kUmax * (1 - r * r / (kR * kR))));
    return forces.evaluate(f, Vec3::Zero(), 0).lift.x() / forces.drag().coefficient(f);
  };
  double r_qs = 0.8 * kR;
  const double t_end = 0.02, h = 1e-4;
  for (double t = 0; t < t_end - 1e-12; t += h) {
    const double k1 = rate(r_qs), k2 = rate(r_qs + 0.5 * h * k1), k3 = rate(r_qs + 0.5 * h * k2),
                 k4 = rate(r_qs + h * k3);
    r_qs += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  SingleParticle p;
  p.x = Vec3(0.8 * kR, 0, 0);  // released at rest
  const double dt = 1e-6;      // 2 drag relaxation times
  for (int n = 0; n < static_cast<int>(t_end / dt + 0.5); ++n) stepper.step(p, dt);
  const double drift = 0.8 * kR - p.x.x();
  std::printf(
      "[ info ] RBC from 0.8 R: %.3f um toward the axis in %.0f ms (quasi-steady %.3f um), initial rate %.1f um/s\n",
      drift * 1e6, t_end * 1e3, (0.8 * kR - r_qs) * 1e6, -rate(0.8 * kR) * 1e6);
  EXPECT_GT(drift, 0.5e-6);
  EXPECT_NEAR(drift, 0.8 * kR - r_qs, 0.01 * drift);
  EXPECT_NEAR(p.x.y(), 0, 1e-15);
}
