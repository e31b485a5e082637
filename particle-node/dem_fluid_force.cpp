// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_fluid_force.h"

#include <atom.h>
#include <clock.h>
#include <fmt/format.h>
#include <traffic.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "closures/exponential_drag.h"
#include "dem_fixes.h"
#include "dem_open_ends.h"

namespace hemo::particles {

using namespace dem;

namespace {

constexpr int kPrefetchAhead = 8;  // atoms

}  // namespace

DemFluidForce::DemFluidForce(const Scene& scene, const CellLocator& locator, const DemSpecies& species,
                             LiggghtsSession& liggghts, ParticleTracking& tracking, OrientationTracker& orientation,
                             FirstProblem& problems, MPI_Comm comm)
    : scene_(scene),
      locator_(locator),
      species_(species),
      liggghts_(liggghts),
      tracking_(tracking),
      orientation_(orientation),
      problems_(problems),
      comm_(comm) {
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (species_.forces[sp] && species_.forces[sp]->needs_centreline_speed() && !locator.wall().defines_centreline_speed())
      throw std::invalid_argument(fmt::format(
          "the {} closures ({}) need the vessel's centre-line speed at each section, which an imported surface "
          "does not define (it would take the vessel's flow split): choose another lift",
          (sp == kRbc ? scene.rbc : scene.platelet).name, species_.forces[sp]->describe()));
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    splitting_[sp] = dynamic_cast<const SplittingIntegrator*>(species_.rotation[sp].get());
  if (scene_.implicit_drag == ImplicitDrag::co_relaxed) {
    cell_plasma_ = std::make_unique<CellPlasmaRelaxation>(locator.n_cells());
    end_shares_ = make_solid_fraction_model(scene.solid_fraction, locator, scene.kernel_width_diameters);
    take_plasma_mass(Deposition(locator));  // no particles deposited yet: all plasma
  }
}

void DemFluidForce::callback(void* self, std::int64_t ntimestep, int nlocal, int* tag, double** x, double** f) {
  auto* force = static_cast<DemFluidForce*>(self);
  const auto t0 = std::chrono::steady_clock::now();
  force->on_force(ntimestep, nlocal, tag, x, f);
  force->seconds_ += seconds_since(t0);
}

void DemFluidForce::start_run(const Run& run, bool carry) {
  if ((form_.pressure_force && !run.fluid->has_pressure_gradient()) ||
      (form_.viscous_force && !run.fluid->has_viscous_force()))
    throw std::invalid_argument("coupling.momentum = \"" + form_.name +
                                "\" puts F_p and F_v on the particles, and the fluid state carries no " +
                                (run.fluid->has_pressure_gradient() ? "viscous force" : "pressure gradient"));
  run_ = run;
  centreline_speed_ = run.fluid->max_cell_speed();
  evaluations_ = 0;
  outside_ = 0;
  max_slip_squared_.fill(0.0);
  max_beta_.fill(0.0);
  // With `pre no` the last force of the previous run acts for the first half step of this one:
  // its impulse belongs to this interval.
  double** acc = per_atom(liggghts_.fixes().impulse);
  const int nlocal = liggghts_.atom().nlocal;
  for (int i = 0; i < nlocal; ++i)
    for (int d = 0; d < 4; ++d) acc[i][d] = carry ? 0.5 * run.dt * acc[i][4 + d] : 0.0;
  if (cell_plasma_) cell_plasma_->start_interval();
}

void DemFluidForce::finish_run(long evaluations) {
  run_.fluid = nullptr;
  if (evaluations_ != evaluations)
    throw std::runtime_error(fmt::format("LIGGGHTS evaluated the fluid forces {} times in a run of {} steps, not {}",
                                         evaluations_, run_.steps, evaluations));
  outside_total_ = static_cast<long>(sum_all(static_cast<double>(outside_), comm_));
  // The largest slips and drag coefficients over the ranks in one reduction (a maximum is exact
  // in any order: the same values as one reduction each).
  std::array<double, 2 * kSpeciesCount> largest;
  std::copy(max_slip_squared_.begin(), max_slip_squared_.end(), largest.begin());
  std::copy(max_beta_.begin(), max_beta_.end(), largest.begin() + kSpeciesCount);
  MPI_Allreduce(MPI_IN_PLACE, largest.data(), static_cast<int>(largest.size()), MPI_DOUBLE, MPI_MAX, comm_);
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    max_re_[sp] =
        species_.forces[sp] ? species_.forces[sp]->params().reynolds(Vec3(std::sqrt(largest[sp]), 0, 0)) : 0.0;
  min_relaxation_time_ = std::numeric_limits<double>::infinity();
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (const double beta = largest[kSpeciesCount + sp]; beta > 0)
      min_relaxation_time_ = std::min(min_relaxation_time_, species_.mass[sp] / beta);
}

void DemFluidForce::on_force(std::int64_t ntimestep, int nlocal, const int* tag, double** x, double** f) {
  ++evaluations_;
  // Verlet: the setup force and the last force of a run act for half a step in this run (see
  // DemEngine's header); the other half of the last one is delivered by the next run and kept
  // for it.
  ForceStep step;
  step.ntimestep = ntimestep;
  step.last = ntimestep == run_.first_step + run_.steps;
  step.duration = (step.last || ntimestep == run_.first_step ? 0.5 : 1.0) * run_.dt;
  step.spin = orientation_.step(ntimestep, run_.dt, run_.coupling_step);
  step.held = per_atom(liggghts_.fixes().closures);
  // The closures at the run's first evaluation (a new flow) and every closure_every_ after;
  // a held fluid force only at the first (CFDEM: once per exchange).
  step.evaluate = step.held == nullptr ||
                  (update_ == Update::per_dem_step ? (evaluations_ - 1) % closure_every_ == 0 : evaluations_ == 1);
  if (cell_plasma_ || two_pass_) {
    step_forces_.resize(nlocal);
    step_cells_.assign(nlocal, -1);  // -1: no fluid force this step (problem noted)
    for (int i = 0; i < nlocal; ++i) step_fluid_force(step, i, tag[i], x[i]);
    orientation_.finish_step(step.spin);
    apply_fluid_forces(step, nlocal, f);
    return;
  }
  one_pass(step, nlocal, tag, x, f);
  orientation_.finish_step(step.spin);
}

void DemFluidForce::one_pass(const ForceStep& step, int nlocal, const int* tag, double** x, double** f) {
  // Locals, so that the loop does not reload them through this object for every particle. The
  // held step is written out per component: the same operations in the same order as
  // held_fluid_force's and apply_fluid_forces's vectors, without the copies between them.
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  const int* type = atom.type;
  double** v = atom.v;
  double** impulse = per_atom(liggghts_.fixes().impulse);
  double** held = step.held;
  const bool constant_drag = update_ == Update::held;
  const bool stress_exchanged = form_.stress_exchanged;
  const double duration = step.duration;
  const bool last = step.last;
  double** spins = step.spin.spins;
  for (int i = 0; i < nlocal; ++i) {
    // Each atom's rows lie in arrays of their own, read once per step and too large together
    // for the core's cache: an atom's rows are asked for a few atoms ahead (a platelet's spin
    // rows, one atom in seven, are beyond the hardware's own prefetching).
    if (const int ahead = i + kPrefetchAhead; ahead < nlocal) {
      if (held) {
        __builtin_prefetch(held[ahead]);
        __builtin_prefetch(held[ahead] + kClosureSlots / 2);
        __builtin_prefetch(held[ahead] + kClosureSlots - 1);
      }
      __builtin_prefetch(impulse[ahead], 1);
      if (spins) __builtin_prefetch(spins[ahead], 1);
    }
    double* fi = f[i];  // the contacts' force of this step so far; the fluid's is added to it
    const int t = tag[i];
    const int sp = liggghts_.species_of_type(type[i]);
    const double* xi = x[i];
    const double* vi = v[i];
    if (!(std::isfinite(xi[0]) && std::isfinite(xi[1]) && std::isfinite(xi[2]) && std::isfinite(vi[0]) &&
          std::isfinite(vi[1]) && std::isfinite(vi[2]))) {
      note_not_finite(t, step.ntimestep);
      continue;
    }
    const OrientationIntegrator* rotation = species_.rotation[sp].get();
    const SplittingIntegrator* splitting = splitting_[sp];
    OrientationTracker::Spin spin;
    if (splitting)
      spin = orientation_.at_step(step.spin, i, t, *splitting);
    else if (rotation)
      spin = orientation_.at_step(step.spin, i, t, *rotation);
    const Vec3& weight = species_.weight[sp];
    double beta, total[3], stress[3];
    Vec3 torque;
    if (step.evaluate) {
      const Vec3 velocity(vi[0], vi[1], vi[2]);
      const Vec3 other = Vec3(fi[0], fi[1], fi[2]) + weight;
      const Particle particle{t, sp, Vec3(xi[0], xi[1], xi[2]), velocity,
                              rotation ? symmetry_axis(spin.q) : Vec3::UnitZ()};
      FluidForce ff;
      Vec3 plasma_velocity;
      const int cell = evaluate_fluid_force(particle, other, step.ntimestep, ff, plasma_velocity);
      if (cell < 0) continue;
      if (held) hold(ff, plasma_velocity, cell, held[i]);
      beta = ff.beta;
      for (int d = 0; d < 3; ++d) {
        total[d] = ff.drag[d] + ff.lift[d];
        stress[d] = ff.stress[d];
      }
      torque = ff.torque;
    } else {
      const double* h = held[i];
      beta = h[kBeta];
      const double ratio = h[kRatio], rb = ratio * beta, rm1 = ratio - 1;
      for (int d = 0; d < 3; ++d) {
        const double lift = h[kLift + d];
        stress[d] = h[kStress + d];
        // exponential_drag_force(ratio, beta, u - v, other + lift + stress)
        const double drag = constant_drag
                                ? h[kDrag + d]
                                : rb * (h[kVelocity + d] - vi[d]) + rm1 * (((fi[d] + weight[d]) + lift) + stress[d]);
        total[d] = drag + lift;
      }
      if (rotation) torque = Vec3(h[kTorque], h[kTorque + 1], h[kTorque + 2]);
    }
    if (splitting)
      orientation_.kick_and_store(step.spin, i, t, *splitting, spin, torque);
    else if (rotation)
      orientation_.kick_and_store(step.spin, i, t, *rotation, spin, torque);
    double* acc = impulse[i];
    for (int d = 0; d < 3; ++d) {
      fi[d] += ((total[d] + stress[d]) + weight[d]);
      const double exchanged = stress_exchanged ? total[d] + stress[d] : total[d];
      acc[d] += duration * exchanged;
      if (last) acc[4 + d] = exchanged;  // kept for the next run's first half kick
    }
    acc[3] += duration * beta;
    if (last) acc[7] = beta;
  }
}

void DemFluidForce::note_not_finite(int tag, std::int64_t ntimestep) {
  problems_.note(tag, fmt::format("particle {} has a non-finite position or velocity at coupling step {} (DEM step {})",
                                  tag, run_.coupling_step, ntimestep));
}

void DemFluidForce::step_fluid_force(const ForceStep& step, int i, int t, const double* x) {
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  const int sp = liggghts_.species_of_type(atom.type[i]);
  const double* v = atom.v[i];
  const double* contact = atom.f[i];  // pair and wall forces of this step so far
  const Vec3 xi(x[0], x[1], x[2]);
  const Vec3 vi(v[0], v[1], v[2]);
  if (!xi.allFinite() || !vi.allFinite()) {
    note_not_finite(t, step.ntimestep);
    return;
  }
  const OrientationIntegrator* rotation = species_.rotation[sp].get();
  OrientationTracker::Spin spin;
  if (rotation) spin = orientation_.at_step(step.spin, i, t, *rotation);
  const Vec3& weight = species_.weight[sp];
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
    ff = held_fluid_force(step.held[i], vi, other, update_ == Update::held);
    step_cells_[i] = static_cast<int>(step.held[i][kCell]);
  }
  if (cell_plasma_) {
    // Straddling an open end, the plasma inside answers only the share the fluid is handed (deposit).
    const double inside = inside_share(x, sp);
    cell_plasma_->add(step_cells_[i], inside * step.duration * exchanged(ff), inside * step.duration * ff.ratio * ff.beta);
  }
  if (rotation) orientation_.kick_and_store(step.spin, i, t, *rotation, spin, ff.torque);
}

void DemFluidForce::apply_fluid_forces(const ForceStep& step, int nlocal, double** f) {
  // Locals, so that the loop does not reload them through this object for every particle.
  const LiggghtsSession& liggghts = liggghts_;
  const std::array<Vec3, kSpeciesCount>& weight = species_.weight;
  const int* type = liggghts.atom().type;
  double** impulse = per_atom(liggghts.fixes().impulse);
  // coupling.implicit_drag's co-relaxation: each cell's plasma answers its particles' fluid force at this
  // step (cell_plasma.h), and the drag, linear in the plasma velocity, follows the answer.
  if (cell_plasma_) cell_plasma_->relax(halo_.get(), comm_);
  for (int i = 0; i < nlocal; ++i) {
    const int cell = step_cells_[i];
    if (cell < 0) continue;
    FluidForce& ff = step_forces_[i];
    if (cell_plasma_) ff.drag += (ff.ratio * ff.beta) * cell_plasma_->shift(cell);
    const Vec3 applied = ff.total() + ff.stress + weight[liggghts.species_of_type(type[i])];
    f[i][0] += applied.x();
    f[i][1] += applied.y();
    f[i][2] += applied.z();
    accumulate_impulse(impulse[i], exchanged(ff), ff.beta, step.duration, step.last);
  }
}

int DemFluidForce::evaluate_fluid_force(const Particle& p, const Vec3& other, std::int64_t ntimestep, FluidForce& ff,
                                        Vec3& plasma_velocity) {
  tracking_.unwrap_z(p.tag, p.x.z());
  AtEnds at;
  const int cell = locate(p.tag, p.x, 0.5 * species_.diameter[p.species], at);
  if (cell < 0) {
    ++outside_;
    // Mostly a cell pushed through the wall by a contact the DEM step cannot resolve: say so.
    problems_.note(p.tag, fmt::format("particle {} is outside the fluid mesh at coupling step {} (DEM step {}), "
                                      "x = ({:.6g}, {:.6g}, {:.6g}) m, r = {:.6g} m; with a DEM step of {:.3g} s "
                                      "(if contacts pushed it through the wall, raise time.dem_steps_per_contact)",
                                      p.tag, run_.coupling_step, ntimestep, p.x.x(), p.x.y(), p.x.z(),
                                      std::hypot(p.x.x(), p.x.y()), run_.dt));
    return -1;
  }
  const FluidSampler& fluid = *run_.fluid;
  if (!fluid.holds(cell)) {
    // The partitioned exchange gave this rank the cells its box and margin reach, not this one:
    // sampling it would read a zero flow.
    problems_.note(p.tag, fmt::format("particle {} is in fluid cell {} at coupling step {} (DEM step {}), which its "
                                      "rank did not take from the fluid: it is beyond its rank's box and margin",
                                      p.tag, cell, run_.coupling_step, ntimestep));
    return -1;
  }
  const SpeciesForces& forces = *species_.forces[p.species];
  ParticleFlow flow;
  flow.cell = cell;
  const FluidSampler::Seen seen =
      fluid.seen(cell, locator_.wrap(at.probe), 0.5 * species_.diameter[p.species], forces.needs_gradient());
  flow.velocity = seen.velocity;
  flow.slip = flow.velocity - p.v;
  if (forces.needs_gradient()) {
    flow.gradient = seen.gradient;
    flow.shear_rate = seen.shear_rate;
  }
  if (forces.needs_centreline_speed()) {
    // The fastest cell is at the narrowest section: the local section's own centre-line speed.
    // A feeder cell is in the section it stands for, the inlet's (the vessel frame).
    const VesselWall::Section section = locator_.section(at.probe);
    flow.centreline_speed = section.centreline_speed(centreline_speed_);
    flow.vessel_diameter = 2 * section.radius;
  }
  flow.axis = p.axis;
  // The plasma's stress on the particle's volume acts like its weight in the drag's exponential
  // update.
  const Vec3 stress = stress_force(seen, species_.volume[p.species]);
  const double drag_scale = void_fraction_.empty() ? 1.0 : 1.0 / void_fraction_[cell];
  // CFDEM's explicit force (coupling.fluid_force = "held") is the closures at the exchange's own
  // slip, held: evaluated as over a step of no length (drag beta (u - v), lift at that slip).
  ff = forces.evaluate(flow, other + stress, update_ == Update::held ? 0.0 : run_.dt, drag_scale);
  ff.stress = stress;
  if (!ff.finite()) {
    problems_.note(p.tag,
                   fmt::format("the fluid force on particle {} is not finite at coupling step {} (DEM step {}): "
                               "drag ({:.3g}, {:.3g}, {:.3g}) N, lift ({:.3g}, {:.3g}, {:.3g}) N, slip {:.3g} m/s",
                               p.tag, run_.coupling_step, ntimestep, ff.drag.x(), ff.drag.y(), ff.drag.z(), ff.lift.x(),
                               ff.lift.y(), ff.lift.z(), flow.slip.norm()));
    return -1;
  }
  max_slip_squared_[p.species] = std::max(max_slip_squared_[p.species], flow.slip.squaredNorm());
  max_beta_[p.species] = std::max(max_beta_[p.species], ff.beta);
  plasma_velocity = flow.velocity;
  return cell;
}

void DemFluidForce::hold(const FluidForce& ff, const Vec3& plasma_velocity, int cell, double* h) {
  h[kBeta] = ff.beta;
  h[kCell] = cell;
  h[kRatio] = ff.ratio;
  for (int d = 0; d < 3; ++d) {
    h[kVelocity + d] = plasma_velocity[d];
    h[kLift + d] = ff.lift[d];
    h[kTorque + d] = ff.torque[d];
    h[kDrag + d] = ff.drag[d];
    h[kStress + d] = ff.stress[d];
  }
}

FluidForce DemFluidForce::held_fluid_force(const double* h, const Vec3& v, const Vec3& other, bool constant_drag) {
  FluidForce ff;
  ff.beta = h[kBeta];
  ff.ratio = h[kRatio];
  ff.lift = Vec3(h[kLift], h[kLift + 1], h[kLift + 2]);
  ff.torque = Vec3(h[kTorque], h[kTorque + 1], h[kTorque + 2]);
  ff.stress = Vec3(h[kStress], h[kStress + 1], h[kStress + 2]);
  if (constant_drag) {
    ff.drag = Vec3(h[kDrag], h[kDrag + 1], h[kDrag + 2]);
  } else {
    const Vec3 slip = Vec3(h[kVelocity], h[kVelocity + 1], h[kVelocity + 2]) - v;
    ff.drag = exponential_drag_force(ff.ratio, ff.beta, slip, other + ff.lift + ff.stress);
  }
  return ff;
}

void DemFluidForce::accumulate_impulse(double* acc, const Vec3& fluid_force, double beta, double duration, bool last) {
  for (int d = 0; d < 3; ++d) acc[d] += duration * fluid_force[d];
  acc[3] += duration * beta;
  if (last) {  // kept for the next run's first half kick
    for (int d = 0; d < 3; ++d) acc[4 + d] = fluid_force[d];
    acc[7] = beta;
  }
}

void DemFluidForce::deposit(Deposition& deposition) {
  deposition.clear();
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  const int nlocal = atom.nlocal;
  const int* tag = atom.tag;
  const int* type = atom.type;
  double** x = atom.x;
  double** acc = per_atom(liggghts_.fixes().impulse);
  inside_volume_ = 0;
  for (int i = 0; i < nlocal; ++i) {
    const int sp = liggghts_.species_of_type(type[i]);
    const double radius = 0.5 * species_.diameter[sp];
    AtEnds at;
    const int cell = locate(tag[i], Vec3(x[i][0], x[i][1], x[i][2]), radius, at);
    if (cell < 0) continue;
    const double beta_time = acc[i][3];
    double drag_response = 0;  // co_relaxed: the impulse already holds the plasma's answer; the fluid takes it explicitly
    switch (scene_.implicit_drag) {
      case ImplicitDrag::interval_response: drag_response = interval_drag_response(species_.mass[sp], beta_time); break;
      case ImplicitDrag::instantaneous: drag_response = beta_time; break;
      case ImplicitDrag::co_relaxed: break;
    }
    // Straddling an open end, its volume and its exchange with the plasma are the inside share's.
    const double inside = deposition.model().inside_share(at.beyond, radius);
    inside_volume_ += inside * species_.volume[sp];
    deposition.add_particle(cell, at.centre, radius, species_.volume[sp], Vec3(acc[i][0], acc[i][1], acc[i][2]),
                            drag_response, inside);
  }
  if (halo_) {
    // Each rank's own; the fluid sums them. The cells its particles can be in next interval are
    // its own cells, whose other depositors the halo holds.
    if (!form_.drag_over_void_fraction && !cell_plasma_) return;
    std::vector<double> solid(static_cast<std::size_t>(locator_.n_cells()));
    for (int c = 0; c < locator_.n_cells(); ++c) solid[static_cast<std::size_t>(c)] = deposition.solid_volume(c);
    halo_->sum(solid, 1);
    take_solid_volume([&](int c) { return solid[static_cast<std::size_t>(c)]; });
    return;
  }
  int size = 1;
  MPI_Comm_size(comm_, &size);
  if (size > 1) MPI_Allreduce(MPI_IN_PLACE, deposition.data(), deposition.size(), MPI_DOUBLE, MPI_SUM, comm_);
  RankTraffic::all_reduce(sizeof(double) * static_cast<std::uint64_t>(deposition.size()), size);
  take_plasma_mass(deposition);
}

double DemFluidForce::inside_share(const double* x, int species) const {
  const dem::FixOpenEnds* ends = liggghts_.fixes().open_ends;
  if (ends == nullptr) return 1.0;
  const dem::FixOpenEnds::Place place = ends->place(x);
  if (place.end == dem::FixOpenEnds::kNone) return 1.0;
  return end_shares_->inside_share(place.beyond, 0.5 * species_.diameter[species]);
}

int DemFluidForce::locate(int tag, const Vec3& x, double radius, AtEnds& at) {
  at.centre = locator_.wrap(x);
  at.probe = x;
  at.beyond = -std::numeric_limits<double>::infinity();
  const dem::FixOpenEnds* ends = liggghts_.fixes().open_ends;
  if (ends == nullptr) return tracking_.cell_of(tag, x);
  const double raw[3] = {x.x(), x.y(), x.z()};
  const dem::FixOpenEnds::Place place = ends->place(raw);
  if (place.end == dem::FixOpenEnds::kNone) return tracking_.cell_of(tag, x);
  at.beyond = place.beyond;
  const Vec3 normal(place.normal[0], place.normal[1], place.normal[2]);
  if (!dem::FixOpenEnds::outside(place)) {
    const int cell = tracking_.cell_of(tag, x);
    // A cell that was pushed out beyond an outlet's rim while past it, and came back inside its
    // plane outside the vessel (no wall holds it there), reads the plasma as one past it does.
    if (cell >= 0 || place.beyond <= -ends->reach() * radius) return cell;
  } else {
    at.centre = Vec3(place.centre[0], place.centre[1], place.centre[2]);
  }
  // Just inside the end's plane; deeper when a snapped end's faces are not quite on it.
  for (double inset = 1e-3 * radius; inset <= radius && place.beyond >= 0; inset *= 4) {
    at.probe = at.centre - (place.beyond + inset) * normal;
    const int cell = tracking_.cell_of(tag, at.probe);
    if (cell >= 0) return cell;
  }
  // Past an outlet no wall holds a cell, and one pushed out beyond the rim's line reads the plasma
  // where the line from it to the outlet's centre enters the vessel (measured: 14.3 and 16.5 um off
  // the axis of a 13.6-um daughter, 1.6 and 9.6 um past its outlet, in scenes/bifurcation-30.toml
  // at 80:20).
  // Its centre a radius inside, where the snapped end's cells are whole.
  const Vec3 beside = at.centre - place.beyond * normal;
  const Vec3 centre = Vec3(place.inside[0], place.inside[1], place.inside[2]);
  for (const double inset : {0.1 * radius, radius})
    for (int k = 1; k <= 16; ++k) {
      at.probe = beside + (k / 16.0) * (centre - beside) - inset * normal;
      const int cell = tracking_.cell_of(tag, at.probe);
      if (cell >= 0) return cell;
    }
  return -1;
}

void DemFluidForce::take_plasma_mass(const Deposition& deposition) {
  take_solid_volume([&](int c) { return deposition.solid_volume(c); });
}

template <class SolidVolume>
void DemFluidForce::take_solid_volume(const SolidVolume& solid_volume) {
  if (form_.drag_over_void_fraction) {
    // The floor only keeps a cell deposited full (a numerical accident, far above any packing
    // of cells) from dividing by zero.
    void_fraction_.resize(locator_.n_cells());
    for (int c = 0; c < locator_.n_cells(); ++c)
      void_fraction_[c] = std::max(1e-3, 1.0 - solid_volume(c) / locator_.volume(c));
  }
  if (!cell_plasma_) return;
  for (int c = 0; c < locator_.n_cells(); ++c)
    cell_plasma_->set_plasma_mass(c, scene_.plasma.density * std::max(0.0, locator_.volume(c) - solid_volume(c)));
}

Vec3 DemFluidForce::stress_force(const FluidSampler::Seen& seen, double volume) const {
  Vec3 f = Vec3::Zero();
  if (form_.pressure_force) f -= volume * seen.pressure_gradient;
  if (form_.viscous_force) f += volume * seen.viscous_force;
  return f;
}

void DemFluidForce::save(EngineState& s) const {
  s.max_reynolds.assign(max_re_.begin(), max_re_.end());
  s.min_relaxation_time = min_relaxation_time_;
  s.outside_total = outside_total_;
}

void DemFluidForce::restore(const EngineState& s) {
  for (int sp = 0; sp < kSpeciesCount; ++sp) max_re_[sp] = s.max_reynolds[sp];
  min_relaxation_time_ = s.min_relaxation_time;
  outside_total_ = static_cast<long>(s.outside_total);
}

}  // namespace hemo::particles
