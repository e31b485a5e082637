// SPDX-License-Identifier: GPL-3.0-or-later
// A cell's plasma relaxing with its particles within a coupling interval (cell_plasma.h), driven
// here as the engine drives it: each step a particle's exponential drag at U_seen and its slope
// are added, the cell relaxes, and the particle gets the drag at U_seen + shift.
#include "cell_plasma.h"
#include "closures/exponential_drag.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace hemo::particles;

namespace {

struct Body {
  double mass, beta;
  Vec3 v;
};

// Steps `bodies` (all in cell 0, plasma of mass `plasma` at U_seen = u_seen + shift) over `time`
// in `steps` steps; returns the plasma's velocity at the end.
Vec3 relax(std::vector<Body>& bodies, double plasma, const Vec3& u_seen, double time, int steps) {
  CellPlasmaRelaxation cell(2);
  cell.set_plasma_mass(0, plasma);
  cell.set_plasma_mass(1, 1.0);
  const double dt = time / steps;
  std::vector<Vec3> drag(bodies.size());
  for (int s = 0; s < steps; ++s) {
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      const Body& b = bodies[i];
      const double r = exponential_drag_ratio(b.mass, b.beta, dt);
      drag[i] = exponential_drag_force(r, b.beta, u_seen - b.v, Vec3::Zero());
      cell.add(0, dt * drag[i], dt * r * b.beta);
    }
    cell.relax(nullptr, MPI_COMM_NULL);
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      Body& b = bodies[i];
      const double r = exponential_drag_ratio(b.mass, b.beta, dt);
      b.v += dt * (drag[i] + r * b.beta * cell.shift(0)) / b.mass;
    }
  }
  EXPECT_EQ(cell.shift(1), Vec3::Zero());  // a cell without particles keeps its plasma
  return u_seen + cell.shift(0);
}

}  // namespace

// One particle of mass m from rest in plasma of mass M at u: both relax to the common velocity
// M u / (M + m) at the rate beta (1/m + 1/M); momentum is conserved at every step count.
// The scheme is first order in the step (implicit in the plasma, exponential in the particle):
// the error at t = 1/rate must halve with the step (observed order within 0.8-1.2), and be
// below 1 % at 64 steps per relaxation time.
TEST(CellPlasma, OneParticleAndItsPlasmaRelaxTogether) {
  const double m = 2e-12, M = 1e-12, beta = 1e-7, u = 1e-3;
  const double rate = beta * (1 / m + 1 / M), time = 1 / rate;
  const double exact = M * u / (M + m) * (1 - std::exp(-rate * time));
  double previous_error = 0;
  for (int steps : {16, 32, 64, 128}) {
    std::vector<Body> one{{m, beta, Vec3::Zero()}};
    const Vec3 plasma = relax(one, M, Vec3(0, 0, u), time, steps);
    EXPECT_NEAR(m * one[0].v.z() + M * plasma.z(), M * u, 1e-12 * M * u) << steps << " steps";
    EXPECT_EQ(one[0].v.x(), 0.0);
    const double error = std::abs(one[0].v.z() - exact) / exact;
    if (steps == 64) {
      EXPECT_LT(error, 0.01);
    }
    if (previous_error > 0) {
      const double order = std::log2(previous_error / error);
      EXPECT_GT(order, 0.8) << steps << " steps";
      EXPECT_LT(order, 1.2) << steps << " steps";
    }
    previous_error = error;
  }
}

// Steps far longer than the relaxation time, particles 100 times heavier than the plasma (where
// a plasma that does not answer within the step is kicked past them): the plasma lands between
// its starting velocity and the particles', never beyond, and momentum is conserved.
TEST(CellPlasma, LongStepsNeverOvershoot) {
  const double M = 1e-13, u = 1e-3;
  std::vector<Body> heavy{{1e-11, 1e-7, Vec3::Zero()}, {5e-12, 3e-7, Vec3(0, 0, 2e-4)}};
  const double p0 = M * u + 5e-12 * 2e-4;
  const Vec3 plasma = relax(heavy, M, Vec3(0, 0, u), 1.0, 3);  // ~1e4 relaxation times per step
  EXPECT_GE(plasma.z(), 0.0);
  EXPECT_LE(plasma.z(), u);
  EXPECT_NEAR(1e-11 * heavy[0].v.z() + 5e-12 * heavy[1].v.z() + M * plasma.z(), p0, 1e-12 * p0);
  // and all have reached the common velocity
  const double common = p0 / (M + 1.5e-11);
  EXPECT_NEAR(plasma.z(), common, 1e-6 * common);
  EXPECT_NEAR(heavy[0].v.z(), common, 1e-6 * common);
  EXPECT_NEAR(heavy[1].v.z(), common, 1e-6 * common);
}

// A new interval starts from the fluid's state: the shifts are forgotten.
TEST(CellPlasma, StartIntervalForgetsTheShift) {
  CellPlasmaRelaxation cell(1);
  cell.set_plasma_mass(0, 1e-12);
  cell.add(0, Vec3(0, 0, 1e-16), 1e-13);
  cell.relax(nullptr, MPI_COMM_NULL);
  EXPECT_LT(cell.shift(0).z(), 0.0);
  cell.start_interval();
  EXPECT_EQ(cell.shift(0), Vec3::Zero());
}
