// DemEngine's fluid-force callback and its reaction on the fluid: every DEM step each particle's
// cell, the plasma there, its species' closures (or the ones held since their last evaluation),
// the drag with the exponential update, the impulse accumulated for the feedback; after a run,
// deposit() hands the impulses to the fluid's cells (see dem_engine.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include <atom.h>
#include <clock.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "closures/exponential_drag.h"
#include "dem_engine.h"
#include "dem_fixes.h"

namespace hemo::particles {

using namespace dem;

void DemEngine::force_callback(void* self, std::int64_t ntimestep, int nlocal, int* tag, double** x, double** f) {
  auto* engine = static_cast<DemEngine*>(self);
  if (engine->rebuilding_) return;
  if (engine->bare_) {
    for (int i = 0; i < nlocal; ++i) f[i][0] = f[i][1] = f[i][2] = 0.0;
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  engine->on_force(ntimestep, nlocal, tag, x, f);
  engine->fluid_force_seconds_ += seconds_since(t0);
}

void DemEngine::on_force(std::int64_t ntimestep, int nlocal, const int* tag, double** x, double** f) {
  ++callbacks_;
  // Verlet: the setup force and the last force of a run act for half a step in this run (see
  // header); the other half of the last one is delivered by the next run and kept for it.
  ForceStep step;
  step.ntimestep = ntimestep;
  step.last = ntimestep == run_start_ + run_steps_;
  step.duration = (step.last || ntimestep == run_start_ ? 0.5 : 1.0) * dt_;
  // Orientation: a step's kick is applied once, at its first evaluation (a `pre yes` setup
  // re-evaluates the step the previous run ended on); the drift to this step comes first.
  step.advance = ntimestep > last_rotation_step_;
  step.drift = step.advance && last_rotation_step_ >= 0;
  step.held = per_atom(closure_fix_);
  // The closures at the run's first evaluation (a new flow) and every closure_every_ after;
  // a held fluid force only at the first (CFDEM: once per exchange).
  step.evaluate =
      step.held == nullptr ||
      (fluid_force_ == FluidForceUpdate::per_dem_step ? (callbacks_ - 1) % closure_every_ == 0 : callbacks_ == 1);
  step_forces_.resize(nlocal);
  step_cells_.assign(nlocal, -1);  // -1: no fluid force this step (problem noted)
  for (int i = 0; i < nlocal; ++i) step_fluid_force(step, i, tag[i], x[i], f[i]);
  finish_rotation_step(step);
  apply_fluid_forces(step, nlocal, f);
}

void DemEngine::step_fluid_force(const ForceStep& step, int i, int t, const double* x, double* f) {
  const int sp = species_of_type_[lmp_->atom->type[i]];
  const double* v = lmp_->atom->v[i];
  const double* contact = lmp_->atom->f[i];  // pair and wall forces of this step so far
  const Vec3 xi(x[0], x[1], x[2]);
  const Vec3 vi(v[0], v[1], v[2]);
  f[0] = f[1] = f[2] = 0.0;
  if (!xi.allFinite() || !vi.allFinite()) {
    note_problem(t, fmt::format("particle {} has a non-finite position or velocity at coupling step {} (DEM step {})",
                                t, coupling_step_, step.ntimestep));
    return;
  }
  const OrientationIntegrator* rotation = rotation_[sp].get();
  Spin spin;
  if (rotation) spin = spin_at_step(i, t, *rotation, step.drift);
  const Vec3& weight = weight_[sp];
  const Vec3 other = Vec3(contact[0], contact[1], contact[2]) + weight;
  FluidForce& ff = step_forces_[i];
  if (step.evaluate) {
    const Particle particle{t, sp, xi, vi, rotation ? symmetry_axis(spin.q) : Vec3::UnitZ()};
    Vec3 plasma_velocity;
    const int cell = evaluate_fluid_force(particle, other, step.ntimestep, ff, plasma_velocity);
    if (cell < 0) return;
    if (step.held) hold(ff, plasma_velocity, cell, step.held[i]);
    step_cells_[i] = cell;
  } else {
    ff = held_fluid_force(step.held[i], vi, other, fluid_force_ == FluidForceUpdate::held);
    step_cells_[i] = static_cast<int>(step.held[i][kCell]);
  }
  if (cell_plasma_) cell_plasma_->add(step_cells_[i], step.duration * ff.total(), step.duration * ff.ratio * ff.beta);
  if (rotation) kick_and_store_spin(step, i, t, *rotation, spin, ff.torque);
}

void DemEngine::apply_fluid_forces(const ForceStep& step, int nlocal, double** f) {
  const int* type = lmp_->atom->type;
  double** impulse = per_atom(impulse_fix_);
  // coupling.implicit_drag = "co_relaxed": each cell's plasma answers its particles' fluid force at this
  // step (cell_plasma.h), and the drag, linear in the plasma velocity, follows the answer.
  if (cell_plasma_) cell_plasma_->relax(comm_);
  for (int i = 0; i < nlocal; ++i) {
    const int cell = step_cells_[i];
    if (cell < 0) continue;
    FluidForce& ff = step_forces_[i];
    if (cell_plasma_) ff.drag += (ff.ratio * ff.beta) * cell_plasma_->shift(cell);
    const Vec3 fluid_force = ff.total();
    const Vec3 applied = fluid_force + ff.pressure + weight_[species_of_type_[type[i]]];
    f[i][0] = applied.x();
    f[i][1] = applied.y();
    f[i][2] = applied.z();
    accumulate_impulse(impulse[i], fluid_force, ff.beta, step.duration, step.last);
  }
}

int DemEngine::evaluate_fluid_force(const Particle& p, const Vec3& other, std::int64_t ntimestep, FluidForce& ff,
                                    Vec3& plasma_velocity) {
  unwrap_z(p.tag, p.x.z());
  const int cell = cell_of(p.tag, p.x);
  if (cell < 0) {
    ++outside_;
    // Mostly a cell pushed through the wall by a contact the DEM step cannot resolve: say so.
    note_problem(p.tag, fmt::format("particle {} is outside the fluid mesh at coupling step {} (DEM step {}), "
                                    "x = ({:.6g}, {:.6g}, {:.6g}) m, r = {:.6g} m; with a DEM step of {:.3g} s "
                                    "(if contacts pushed it through the wall, raise time.dem_steps_per_contact)",
                                    p.tag, coupling_step_, ntimestep, p.x.x(), p.x.y(), p.x.z(),
                                    std::hypot(p.x.x(), p.x.y()), dt_));
    return -1;
  }
  const SpeciesForces& forces = *forces_[p.species];
  ParticleFlow flow;
  flow.cell = cell;
  flow.velocity = fluid_->velocity(cell, locator_->wrap(p.x));
  flow.slip = flow.velocity - p.v;
  if (forces.needs_gradient()) {
    flow.gradient = fluid_->gradient(cell);
    flow.shear_rate = fluid_->shear_rate(cell);
    flow.centreline_speed = centreline_speed_;
  }
  flow.axis = p.axis;
  // The plasma's pressure on the particle's volume acts like its weight: on the particle, in
  // the drag's exponential update, not exchanged.
  const Vec3 pressure = pressure_force_ ? Vec3(-volume_[p.species] * fluid_->pressure_gradient(cell)) : Vec3::Zero();
  // CFDEM's explicit force (coupling.fluid_force = "held") is the closures at the exchange's own
  // slip, held: evaluated as over a step of no length (drag beta (u - v), lift at that slip).
  ff = forces.evaluate(flow, other + pressure, fluid_force_ == FluidForceUpdate::held ? 0.0 : dt_);
  ff.pressure = pressure;
  if (!ff.finite()) {
    note_problem(p.tag, fmt::format("the fluid force on particle {} is not finite at coupling step {} (DEM step {}): "
                                    "drag ({:.3g}, {:.3g}, {:.3g}) N, lift ({:.3g}, {:.3g}, {:.3g}) N, slip {:.3g} m/s",
                                    p.tag, coupling_step_, ntimestep, ff.drag.x(), ff.drag.y(), ff.drag.z(),
                                    ff.lift.x(), ff.lift.y(), ff.lift.z(), flow.slip.norm()));
    return -1;
  }
  max_slip_squared_[p.species] = std::max(max_slip_squared_[p.species], flow.slip.squaredNorm());
  max_beta_[p.species] = std::max(max_beta_[p.species], ff.beta);
  plasma_velocity = flow.velocity;
  return cell;
}

void DemEngine::hold(const FluidForce& ff, const Vec3& plasma_velocity, int cell, double* h) {
  h[kBeta] = ff.beta;
  h[kCell] = cell;
  h[kRatio] = ff.ratio;
  for (int d = 0; d < 3; ++d) {
    h[kVelocity + d] = plasma_velocity[d];
    h[kLift + d] = ff.lift[d];
    h[kTorque + d] = ff.torque[d];
    h[kDrag + d] = ff.drag[d];
    h[kPressure + d] = ff.pressure[d];
  }
}

FluidForce DemEngine::held_fluid_force(const double* h, const Vec3& v, const Vec3& other, bool constant_drag) {
  FluidForce ff;
  ff.beta = h[kBeta];
  ff.ratio = h[kRatio];
  ff.lift = Vec3(h[kLift], h[kLift + 1], h[kLift + 2]);
  ff.torque = Vec3(h[kTorque], h[kTorque + 1], h[kTorque + 2]);
  ff.pressure = Vec3(h[kPressure], h[kPressure + 1], h[kPressure + 2]);
  if (constant_drag) {
    ff.drag = Vec3(h[kDrag], h[kDrag + 1], h[kDrag + 2]);
  } else {
    const Vec3 slip = Vec3(h[kVelocity], h[kVelocity + 1], h[kVelocity + 2]) - v;
    ff.drag = exponential_drag_force(ff.ratio, ff.beta, slip, other + ff.lift + ff.pressure);
  }
  return ff;
}

void DemEngine::accumulate_impulse(double* acc, const Vec3& fluid_force, double beta, double duration, bool last) {
  for (int d = 0; d < 3; ++d) acc[d] += duration * fluid_force[d];
  acc[3] += duration * beta;
  if (last) {  // kept for the next run's first half kick
    for (int d = 0; d < 3; ++d) acc[4 + d] = fluid_force[d];
    acc[7] = beta;
  }
}

void DemEngine::start_accumulators(bool carry) {
  // With `pre no` the last force of the previous run acts for the first half step of this one:
  // its impulse belongs to this interval.
  double** acc = per_atom(impulse_fix_);
  const int nlocal = lmp_->atom->nlocal;
  for (int i = 0; i < nlocal; ++i)
    for (int d = 0; d < 4; ++d) acc[i][d] = carry ? 0.5 * dt_ * acc[i][4 + d] : 0.0;
}

void DemEngine::deposit(Deposition& deposition) {
  deposition.clear();
  const int nlocal = lmp_->atom->nlocal;
  const int* tag = lmp_->atom->tag;
  const int* type = lmp_->atom->type;
  double** x = lmp_->atom->x;
  double** acc = per_atom(impulse_fix_);
  for (int i = 0; i < nlocal; ++i) {
    const Vec3 xi(x[i][0], x[i][1], x[i][2]);
    const int cell = cell_of(tag[i], xi);
    const int sp = species_of_type_[type[i]];
    if (cell < 0) continue;
    const double beta_time = acc[i][3];
    // co_relaxed: the impulse already holds the plasma's answer; the fluid takes it explicitly.
    const double drag_response = cell_plasma_          ? 0.0
                                 : held_velocity_drag_ ? beta_time
                                                       : interval_drag_response(mass_[sp], beta_time);
    deposition.add_particle(cell, locator_->wrap(xi), 0.5 * diameter_[sp], volume_[sp],
                            Vec3(acc[i][0], acc[i][1], acc[i][2]), drag_response);
  }
  int size = 1;
  MPI_Comm_size(comm_, &size);
  if (size > 1) MPI_Allreduce(MPI_IN_PLACE, deposition.data(), deposition.size(), MPI_DOUBLE, MPI_SUM, comm_);
  take_plasma_mass(deposition);
}

void DemEngine::take_plasma_mass(const Deposition& deposition) {
  if (!cell_plasma_) return;
  for (int c = 0; c < locator_->n_cells(); ++c)
    cell_plasma_->set_plasma_mass(
        c, scene_.plasma.density * std::max(0.0, locator_->volume(c) - deposition.solid_volume(c)));
}

}  // namespace hemo::particles
