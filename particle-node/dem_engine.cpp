// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_engine.h"

#include "closures/exponential_drag.h"

#include <atom.h>
#include <fix.h>
#include <fix_external.h>
#include <fix_property_atom.h>
#include <force.h>
#include <input.h>
#include <lammps.h>
#include <modify.h>
#include <neigh_list.h>
#include <neighbor.h>
#include <pair.h>
#include <update.h>

#include <clock.h>
#include <fmt/format.h>
#include <units.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <tuple>
#include <type_traits>

namespace hemo::particles {

static_assert(std::is_same_v<LAMMPS_NS::bigint, std::int64_t>, "LIGGGHTS built with another bigint");

namespace {

constexpr const char* kFluidFix = "hemo_fluid";
constexpr const char* kImpulseFix = "hemo_impulse";
constexpr const char* kRotationFix = "hemo_rotation";
constexpr const char* kClosureFix = "hemo_closures";
constexpr const char* kWallFix = "hemo_wall";
// LIGGGHTS's name of the fix property/atom where fix wall/gran keeps a primitive wall's contact
// history per atom (checkpoints save it).
constexpr const char* kWallHistoryFix = "history_hemo_wall";
// The per-atom closure values held between evaluations (time.closure_every_dem_steps > 1, or
// a held coupling.fluid_force). kCell: the fluid cell they were evaluated in (where the
// co-relaxed plasma answers), which moves with the atom to another rank as the per-tag locate
// cache does not. kDrag: the drag held as a constant (coupling.fluid_force = "held").
enum ClosureSlot {
  kBeta = 0, kRatio = 1, kVelocity = 2, kLift = 5, kTorque = 8, kCell = 11, kDrag = 12, kPressure = 15,
  kClosureSlots = 18
};
constexpr int kImpulseValues = 8;   // F dt (3), beta dt, last F (3), last beta
constexpr int kRotationValues = 7;  // q (w, x, y, z), L (3)
constexpr long kLogRotateSteps = 1000;  // the LIGGGHTS run log keeps at most this many coupling steps
constexpr double kContactReach = 1.02;  // contact histories are cleared within this x the contact distance
constexpr double kMaxTurnPerStep = 1.0;  // rad: a platelet's spin beyond this per DEM step is an unstable update

const Species& species_of(const Scene& s, int sp) { return sp == kRbc ? s.rbc : s.platelet; }

double sum_all(double v, MPI_Comm comm) {
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_SUM, comm);
  return v;
}
double max_all(double v, MPI_Comm comm) {
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MAX, comm);
  return v;
}

}  // namespace

DemEngine::DemEngine(const Scene& scene, const CellLocator& locator, const std::string& log_path, MPI_Comm comm,
                     bool append_log)
    : scene_(dem_scene(scene)), locator_(&locator), comm_(comm), log_path_(log_path) {
  double d_max = 0;
  const Vec3 gravity(scene.gravity.x, scene.gravity.y, scene.gravity.z);
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    const Species& s = species_of(scene_, sp);  // masses x dem_mass_scaling
    if (!s.present) continue;
    if (!(s.diameter > 0) || !(s.mass > 0) || !(s.volume > 0))
      throw std::invalid_argument(s.name + ": diameter, mass and volume must be positive");
    forces_[sp] = std::make_unique<SpeciesForces>(s, scene_);
    if (forces_[sp]->needs_orientation()) {
      if (!(s.semi_axis_a > 0) || !(s.semi_axis_c > 0))
        throw std::invalid_argument(s.name + ": an oblate closure needs the semi-axes a and c");
      rotation_[sp] = make_orientation_integrator(
          s.orientation_integrator, SymmetricTop::oblate_spheroid(s.mass, s.semi_axis_a, s.semi_axis_c));
      any_orientation_ = true;
    }
    volume_[sp] = s.volume;
    diameter_[sp] = s.diameter;
    mass_[sp] = s.mass;
    weight_[sp] = species_of(scene, sp).mass * gravity;  // the physical weight, whatever the DEM mass
    d_max = std::max(d_max, s.diameter);
  }
  if (d_max == 0) throw std::invalid_argument("the scene has no particle species");

  std::vector<std::string> args = {"hemocosim-particles", "-screen", "none", "-log",
                                   append_log ? std::string("none") : log_path};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  lmp_ = new LAMMPS_NS::LAMMPS(static_cast<int>(argv.size()), argv.data(), comm);

  const std::vector<std::string> setup = {
      "units si",
      "atom_style granular",
      // No re-sorting: on the calibration scene, sorting every 1,000 steps did not make the DEM
      // faster over its first 75 coupling steps (0.60-0.71 s per step against 0.47-0.54 s without,
      // one run each on a noisy machine). Tags start in spatial order (create_particles).
      "atom_modify map array sort 0 0.0",
      "boundary f f p",
      "newton off",
      "communicate single vel yes",
      // Cells are softer (7.5e5 Pa) than LIGGGHTS's SI floor of 5e6 Pa.
      "soft_particles yes",
      "processors 1 1 *",
      "thermo 0",
      // A lost atom is our error (named, one line), not LIGGGHTS's exit.
      "thermo_modify lost ignore",
  };
  if (append_log && log_path != "none") command("log " + log_path + " append");  // a resumed run keeps the log
  for (const auto& line : setup) command(line);
  d_max_ = d_max;
  if (scene_.implicit_drag == "co_relaxed") {
    cell_plasma_ = std::make_unique<CellPlasmaRelaxation>(locator.n_cells());
    take_plasma_mass(Deposition(locator));  // no particles deposited yet: all plasma
  }
}
DemEngine::~DemEngine() { delete lmp_; }

void DemEngine::command(const std::string& line) { lmp_->input->one(line.c_str()); }

void DemEngine::setup_box(const std::array<bool, kSpeciesCount>& used) {
  // LIGGGHTS wants granular atom types to start at 1 without holes: the species that have
  // particles take types 1, 2 (RBC before platelet), the wall's material the next one.
  int n_types = 0;
  for (int sp = 0; sp < kSpeciesCount; ++sp) type_of_[sp] = used[sp] ? ++n_types : 0;
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (used[sp]) species_of_type_[type_of_[sp]] = sp;
  const int wall_type = ++n_types;

  const double R = locator_->radius();
  const double z0 = locator_->z0(), L = locator_->length();
  const double half_box = R + 2 * d_max_;
  const auto& c = scene_.contact;
  // Per type and type pair, the wall type last.
  std::string youngs, poisson, restitution, friction;
  for (int i = 1; i <= n_types; ++i) {
    const bool wi = i == wall_type;
    youngs += fmt::format(" {:.17g}", wi ? c.wall_youngs_modulus : c.cell_youngs_modulus);
    poisson += fmt::format(" {:.17g}", wi ? c.wall_poisson_ratio : c.cell_poisson_ratio);
    for (int j = 1; j <= n_types; ++j) {
      const bool wall_pair = wi || j == wall_type;
      restitution += fmt::format(" {:.17g}", wall_pair ? c.cell_wall_restitution : c.cell_cell_restitution);
      friction += fmt::format(" {:.17g}", c.friction);
    }
  }
  const std::vector<std::string> setup = {
      fmt::format("region hemo_box block {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} units box", -half_box,
                  half_box, -half_box, half_box, z0, z0 + L),
      fmt::format("create_box {} hemo_box", n_types),
      fmt::format("neighbor {:.17g} bin", 0.25 * d_max_),
      "neigh_modify delay 0",
      "fix m1 all property/global youngsModulus peratomtype" + youngs,
      "fix m2 all property/global poissonsRatio peratomtype" + poisson,
      fmt::format("fix m3 all property/global coefficientRestitution peratomtypepair {}{}", n_types, restitution),
      fmt::format("fix m4 all property/global coefficientFriction peratomtypepair {}{}", n_types, friction),
      "pair_style gran model hertz tangential history",
      "pair_coeff * *",
      "timestep 1e-7",
      fmt::format("fix {} all wall/gran model hertz tangential history primitive type {} zcylinder {:.17g} 0 0",
                  kWallFix, wall_type, R),
      "fix hemo_integrate all nve/sphere",
      fmt::format("fix {} all property/atom hemoImpulse vector no no no{}", kImpulseFix,
                  " 0 0 0 0 0 0 0 0"),
      // Defined after the wall: its post_force sees the contact forces and torques of the step.
      fmt::format("fix {} all external pf/callback 1 1", kFluidFix),
  };
  for (const auto& line : setup) command(line);
  // A pair's tangential history is cleared when it separates, not at the next neighbour-list
  // rebuild: LIGGGHTS clears it only for pairs within this factor x the contact distance (and
  // keeps the rest until a rebuild drops it), so with 1 a pair that separates and touches again
  // before the next rebuild would find its old shear spring, and results would depend on when
  // lists are rebuilt (a checkpoint rebuilds them). The band, 2 % of the contact distance
  // (53 nm for two platelets), is wider than a separating pair moves in a DEM step (~1 nm at the
  // impact velocity the step is made for), and adds ~5 % of pairs to the lists.
  lmp_->neighbor->register_contact_dist_factor(kContactReach);
  if (any_orientation_) command(fmt::format("fix {} all property/atom hemoRotation vector yes no no 1 0 0 0 0 0 0", kRotationFix));
  if (holds_closures()) {
    std::string zeros;
    for (int k = 0; k < kClosureSlots; ++k) zeros += " 0";
    command(fmt::format("fix {} all property/atom hemoClosures vector no no no{}", kClosureFix, zeros));
  }
  auto find = [&](const char* id) {
    const int ifix = lmp_->modify->find_fix(id);
    if (ifix < 0) throw std::runtime_error(std::string("LIGGGHTS did not create the fix ") + id);
    return lmp_->modify->fix[ifix];
  };
  static_cast<LAMMPS_NS::FixExternal*>(find(kFluidFix))->set_callback(&DemEngine::force_callback, this);
  impulse_fix_ = find(kImpulseFix);
  if (any_orientation_) rotation_fix_ = find(kRotationFix);
  if (holds_closures()) closure_fix_ = find(kClosureFix);
  wall_history_fix_ = dynamic_cast<LAMMPS_NS::FixPropertyAtom*>(find(kWallHistoryFix));
  if (wall_history_fix_ == nullptr) throw std::runtime_error("LIGGGHTS's wall contact history is not a fix property/atom");
}

double** DemEngine::per_atom(LAMMPS_NS::Fix* fix) { return fix != nullptr ? fix->array_atom : nullptr; }

void DemEngine::create_particles(const std::vector<PlacedParticle>& particles) {
  if (n_particles_ > 0 || type_of_[kRbc] + type_of_[kPlatelet] > 0)
    throw std::logic_error("particles were already created");
  if (particles.empty()) throw std::invalid_argument("no particles to simulate");
  std::array<bool, kSpeciesCount> used{};
  for (const auto& p : particles) {
    if (p.species < 0 || p.species >= kSpeciesCount || !forces_[p.species])
      throw std::invalid_argument("a placed particle has a species the scene does not have");
    used[p.species] = true;
  }
  setup_box(used);
  // Tags follow a spatial order (axial slabs, then rows): neighbours in space are neighbours in
  // memory at the start, for LIGGGHTS and for our per-tag arrays alike.
  std::vector<const PlacedParticle*> order;
  for (const auto& p : particles) order.push_back(&p);
  auto key = [&](const PlacedParticle* p) {
    return std::make_tuple(std::floor((p->position.z() - locator_->z0()) / d_max_), std::floor(p->position.y() / d_max_),
                           p->position.x());
  };
  std::stable_sort(order.begin(), order.end(), [&](auto* a, auto* b) { return key(a) < key(b); });
  for (const PlacedParticle* p : order)
    command(fmt::format("create_atoms {} single {:.17g} {:.17g} {:.17g} units box", type_of_[p->species],
                        p->position.x(), p->position.y(), p->position.z()));
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    if (!used[sp]) continue;
    // LIGGGHTS sets the mass from diameter and density: density = m / (pi d^3 / 6).
    const double density = mass_[sp] / (units::pi / 6 * std::pow(diameter_[sp], 3));
    command(fmt::format("set type {} diameter {:.17g} density {:.17g}", type_of_[sp], diameter_[sp], density));
  }
  n_particles_ = static_cast<long>(lmp_->atom->natoms);
  if (n_particles_ != static_cast<long>(particles.size()))
    throw std::runtime_error(fmt::format("LIGGGHTS created {} of {} particles (some outside the box?)", n_particles_,
                                         particles.size()));
  tracked_.assign(n_particles_ + 1, Tracked{});
  for (std::size_t i = 0; i < order.size(); ++i) tracked_[i + 1].last_z = order[i]->position.z();
}

long DemEngine::local_particle_count() const { return lmp_->atom->nlocal; }

long DemEngine::dem_timestep() const { return static_cast<long>(lmp_->update->ntimestep); }

double DemEngine::unwrap_z(int tag, double z) {
  const double half = 0.5 * locator_->length();
  Tracked& t = tracked_[tag];
  const double dz = z - t.last_z;
  if (dz < -half)
    t.crossings += 1;
  else if (dz > half)
    t.crossings -= 1;
  t.last_z = z;
  return z + t.crossings * locator_->length();
}

void DemEngine::force_callback(void* self, std::int64_t ntimestep, int nlocal, int* tag, double** x, double** f) {
  auto* engine = static_cast<DemEngine*>(self);
  if (engine->rebuilding_) return;
  const auto t0 = std::chrono::steady_clock::now();
  engine->on_force(ntimestep, nlocal, tag, x, f);
  engine->fluid_force_seconds_ += seconds_since(t0);
}

void DemEngine::on_force(std::int64_t ntimestep, int nlocal, const int* tag, double** x, double** f) {
  ++callbacks_;
  // Verlet: the setup force and the last force of a run act for half a step in this run (see
  // header); the other half of the last one is delivered by the next run and kept for it.
  const bool last = ntimestep == run_start_ + run_steps_;
  const bool half = last || ntimestep == run_start_;
  const double duration = (half ? 0.5 : 1.0) * dt_;
  // Orientation: a step's kick is applied once, at its first evaluation (a `pre yes` setup
  // re-evaluates the step the previous run ended on); the drift to this step comes first.
  const bool advance = ntimestep > last_rotation_step_;
  const bool drift = advance && last_rotation_step_ >= 0;
  const int* type = lmp_->atom->type;
  double** v = lmp_->atom->v;
  double** contact = lmp_->atom->f;        // pair and wall forces of this step so far
  double** contact_torque = lmp_->atom->torque;
  double** omega = lmp_->atom->omega;
  double** impulse = per_atom(impulse_fix_);
  double** rot = per_atom(rotation_fix_);
  double** held = per_atom(closure_fix_);
  // The closures at the run's first evaluation (a new flow) and every closure_every_ after;
  // a held fluid force only at the first (CFDEM: once per exchange).
  const bool evaluate =
      held == nullptr || (fluid_force_ == FluidForceUpdate::per_dem_step ? (callbacks_ - 1) % closure_every_ == 0
                                                                          : callbacks_ == 1);
  step_forces_.resize(nlocal);
  step_cells_.assign(nlocal, -1);  // -1: no fluid force this step (problem noted)
  for (int i = 0; i < nlocal; ++i) {
    const int t = tag[i];
    const int sp = species_of_type_[type[i]];
    const Vec3 xi(x[i][0], x[i][1], x[i][2]);
    const Vec3 vi(v[i][0], v[i][1], v[i][2]);
    f[i][0] = f[i][1] = f[i][2] = 0.0;
    if (!xi.allFinite() || !vi.allFinite()) {
      note_problem(t, fmt::format("particle {} has a non-finite position or velocity at coupling step {} (DEM step {})",
                                  t, coupling_step_, ntimestep));
      continue;
    }
    const OrientationIntegrator* rotation = rotation_[sp].get();
    Quat q = Quat::Identity();
    Vec3 l = Vec3::Zero();
    if (rotation) {
      q = Quat(rot[i][0], rot[i][1], rot[i][2], rot[i][3]);
      l = Vec3(rot[i][4], rot[i][5], rot[i][6]);
      if (!pending_orientation_.empty()) {
        const auto it = pending_orientation_.find(t);
        if (it != pending_orientation_.end()) q = it->second;
      }
      if (drift) rotation->drift(q, l, rotation_dt_);
    }
    const Vec3& weight = weight_[sp];
    const Vec3 other = Vec3(contact[i][0], contact[i][1], contact[i][2]) + weight;
    FluidForce& ff = step_forces_[i];
    if (evaluate) {
      const Particle particle{t, sp, xi, vi, rotation ? symmetry_axis(q) : Vec3::UnitZ()};
      Vec3 plasma_velocity;
      const int cell = evaluate_fluid_force(particle, other, ntimestep, ff, plasma_velocity);
      if (cell < 0) continue;
      if (held) hold(ff, plasma_velocity, cell, held[i]);
      step_cells_[i] = cell;
    } else {
      ff = held_fluid_force(held[i], vi, other, fluid_force_ == FluidForceUpdate::held);
      step_cells_[i] = static_cast<int>(held[i][kCell]);
    }
    if (cell_plasma_) cell_plasma_->add(step_cells_[i], duration * ff.total(), duration * ff.ratio * ff.beta);
    if (rotation) {
      const Vec3 torque = ff.torque + Vec3(contact_torque[i][0], contact_torque[i][1], contact_torque[i][2]);
      if (advance) rotation->kick(q, l, torque, dt_);
      Vec3 w = rotation->top().angular_velocity(q, l);
      // A platelet turning by a radian in one DEM step (the flow turns it by ~gamma dt / 2,
      // 3e-3 rad at the calibration point) has an unstable orientation update (the explicit
      // "euler" one pumps energy into the spin): stop the run naming it, with its spin taken
      // away meanwhile so that LIGGGHTS's contacts stay finite until the run's end.
      if (!(w.norm() * dt_ < kMaxTurnPerStep) || !q.coeffs().allFinite()) {
        note_problem(t, fmt::format("platelet {} spins at {:.3g} rad/s ({:.2g} rad per DEM step of {:.3g} s) at coupling "
                                    "step {} (DEM step {}): the orientation update '{}' is unstable here (try \"splitting\")",
                                    t, w.norm(), w.norm() * dt_, dt_, coupling_step_, ntimestep, rotation->name()));
        if (!q.coeffs().allFinite()) q = Quat::Identity();
        l = Vec3::Zero();
        w = Vec3::Zero();
      }
      rot[i][0] = q.w();
      rot[i][1] = q.x();
      rot[i][2] = q.y();
      rot[i][3] = q.z();
      for (int d = 0; d < 3; ++d) {
        rot[i][4 + d] = l[d];
        omega[i][d] = w[d];       // the contacts of the next step see the platelet's own rotation
        contact_torque[i][d] = 0;  // and nve/sphere leaves omega alone
      }
    }
  }
  if (advance) {
    last_rotation_step_ = ntimestep;
    rotation_dt_ = dt_;
  }
  pending_orientation_.clear();

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
    accumulate_impulse(impulse[i], fluid_force, ff.beta, duration, last);
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

int DemEngine::cell_of(int tag, const Vec3& x, bool* in_wall_gap) {
  LocateCache& where = tracked_[tag].where;
  int cell = locator_->locate(x, where);
  const bool gap = cell < 0 && (cell = locator_->locate_in_wall_gap(x)) >= 0;
  if (gap) where.cell = cell;  // a good first guess next time; the cache stays invalid
  if (in_wall_gap) *in_wall_gap = gap;
  return cell;
}

void DemEngine::note_problem(int tag, std::string what) {
  if (first_problem_.empty() || tag < first_problem_tag_) {
    first_problem_tag_ = tag;
    first_problem_ = std::move(what);
  }
}

std::string DemEngine::agree_on_problem() {
  // The problem of the smallest particle id over all ranks, known to every rank.
  struct {
    int tag;
    int rank;
  } mine{first_problem_.empty() ? INT32_MAX : first_problem_tag_, 0}, best;
  MPI_Comm_rank(comm_, &mine.rank);
  MPI_Allreduce(&mine, &best, 1, MPI_2INT, MPI_MINLOC, comm_);
  if (best.tag == INT32_MAX) return {};
  int len = static_cast<int>(first_problem_.size());
  MPI_Bcast(&len, 1, MPI_INT, best.rank, comm_);
  std::string msg = first_problem_;
  msg.resize(static_cast<std::size_t>(len));
  MPI_Bcast(msg.data(), len, MPI_CHAR, best.rank, comm_);
  return msg;
}

void DemEngine::start_accumulators(bool carry) {
  // With `pre no` the last force of the previous run acts for the first half step of this one:
  // its impulse belongs to this interval.
  double** acc = per_atom(impulse_fix_);
  const int nlocal = lmp_->atom->nlocal;
  for (int i = 0; i < nlocal; ++i)
    for (int d = 0; d < 4; ++d) acc[i][d] = carry ? 0.5 * dt_ * acc[i][4 + d] : 0.0;
}

std::string DemEngine::run(long coupling_step, int substeps, double dt, const FluidSampler& fluid) {
  if (n_particles_ == 0) return {};
  if (substeps < 1 || !(dt > 0)) throw std::invalid_argument("DEM run needs at least one step of positive length");
  fluid_ = &fluid;
  centreline_speed_ = fluid.max_cell_speed();
  coupling_step_ = coupling_step;
  run_steps_ = substeps;
  callbacks_ = 0;
  outside_ = 0;
  max_slip_squared_.fill(0.0);
  max_beta_.fill(0.0);
  first_problem_.clear();
  const bool new_dt = dt != dt_;
  dt_ = dt;
  // `pre no` skips re-initialisation between runs and keeps the forces of the last step, whose
  // second half kick comes first in this run. A new step size needs `pre yes` (integrator
  // factors), which recomputes the forces instead.
  const bool pre = first_run_ || new_dt;
  start_accumulators(!pre);
  if (cell_plasma_) cell_plasma_->start_interval();
  if (new_dt) command(fmt::format("timestep {:.17g}", dt));
  if (log_path_ != "none" && coupling_step % kLogRotateSteps == 1)
    command("log " + log_path_ + ".steps");  // restarts the run log: bounded size, recent errors kept
  run_start_ = lmp_->update->ntimestep;
  command(fmt::format("run {} pre {} post no", substeps, pre ? "yes" : "no"));
  first_run_ = false;
  fluid_ = nullptr;
  const long expected = pre ? substeps + 1 : substeps;  // `pre yes` adds the setup evaluation
  if (callbacks_ != expected)
    throw std::runtime_error(fmt::format("LIGGGHTS evaluated the fluid forces {} times in a run of {} steps, not {}",
                                         callbacks_, substeps, expected));
  sync_tracking();
  outside_total_ = static_cast<long>(sum_all(static_cast<double>(outside_), comm_));
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    max_re_[sp] = forces_[sp] ? forces_[sp]->params().reynolds(Vec3(std::sqrt(max_all(max_slip_squared_[sp], comm_)), 0, 0))
                              : 0.0;
  min_relaxation_time_ = std::numeric_limits<double>::infinity();
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (const double beta = max_all(max_beta_[sp], comm_); beta > 0)
      min_relaxation_time_ = std::min(min_relaxation_time_, mass_[sp] / beta);
  std::string problem = agree_on_problem();
  if (problem.empty()) problem = check_lost(coupling_step);
  return problem;
}

std::string DemEngine::check_lost(long coupling_step) {
  // LIGGGHTS drops an atom that leaves the box (thermo_modify lost ignore): name the first.
  const long have = static_cast<long>(sum_all(static_cast<double>(lmp_->atom->nlocal), comm_));
  lost_ = n_particles_ - have;
  if (lost_ == 0) return {};
  std::vector<double> present(n_particles_ + 1, 0.0);
  for (int i = 0; i < lmp_->atom->nlocal; ++i) present[lmp_->atom->tag[i]] = 1;
  MPI_Allreduce(MPI_IN_PLACE, present.data(), static_cast<int>(present.size()), MPI_DOUBLE, MPI_SUM, comm_);
  long first = 0;
  for (long t = 1; t <= n_particles_ && first == 0; ++t)
    if (present[t] == 0) first = t;
  return fmt::format("particle {} was lost by LIGGGHTS (it left the DEM box) during coupling step {}; {} particle{} lost "
                     "in all",
                     first, coupling_step, lost_, lost_ == 1 ? "" : "s");
}

void DemEngine::sync_tracking() {
  int size = 1;
  MPI_Comm_size(comm_, &size);
  if (size == 1) return;
  // Each rank contributes its own atoms; the sum is everyone's current view.
  const int nlocal = lmp_->atom->nlocal;
  const int* tag = lmp_->atom->tag;
  std::vector<double> buf(2 * tracked_.size(), 0.0);
  for (int i = 0; i < nlocal; ++i) {
    buf[2 * tag[i]] = tracked_[tag[i]].last_z;
    buf[2 * tag[i] + 1] = tracked_[tag[i]].crossings;
  }
  MPI_Allreduce(MPI_IN_PLACE, buf.data(), static_cast<int>(buf.size()), MPI_DOUBLE, MPI_SUM, comm_);
  for (std::size_t t = 0; t < tracked_.size(); ++t) {
    tracked_[t].last_z = buf[2 * t];
    tracked_[t].crossings = buf[2 * t + 1];
  }
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
    const double drag_response = cell_plasma_        ? 0.0
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
    cell_plasma_->set_plasma_mass(c, scene_.plasma.density * std::max(0.0, locator_->volume(c) - deposition.solid_volume(c)));
}

EngineDiagnostics DemEngine::diagnostics(const FluidSampler* fluid) {
  EngineDiagnostics d;
  d.particles = n_particles_;
  d.outside_mesh = outside_total_;
  const double core_r = 0.5 * locator_->radius();
  const int nlocal = lmp_->atom->nlocal;
  const int* tag = lmp_->atom->tag;
  double** x = lmp_->atom->x;
  double** v = lmp_->atom->v;
  double sums[4] = {0, 0, 0, 0};  // count, particle v_z, fluid u_z, particles in the wall gap
  double max_speed = 0;
  for (int i = 0; i < nlocal; ++i) {
    const Vec3 xi(x[i][0], x[i][1], x[i][2]);
    max_speed = std::max(max_speed, Vec3(v[i][0], v[i][1], v[i][2]).norm());
    bool in_gap = false;
    const int cell = cell_of(tag[i], xi, &in_gap);
    sums[3] += in_gap;
    if (cell < 0 || std::hypot(xi.x(), xi.y()) >= core_r) continue;
    sums[0] += 1;
    sums[1] += v[i][2];
    if (fluid != nullptr && fluid->has_state()) sums[2] += fluid->velocity(cell, locator_->wrap(xi)).z();
  }
  MPI_Allreduce(MPI_IN_PLACE, sums, 4, MPI_DOUBLE, MPI_SUM, comm_);
  d.core_particles = static_cast<long>(sums[0]);
  d.in_wall_gap = static_cast<long>(sums[3]);
  if (sums[0] > 0) {
    d.core_particle_axial_velocity = sums[1] / sums[0];
    d.core_fluid_axial_velocity = sums[2] / sums[0];
  }
  d.max_speed = max_all(max_speed, comm_);
  d.max_reynolds[0] = max_re_[0];
  d.max_reynolds[1] = max_re_[1];
  d.lost = lost_;

  d.max_overlap = max_all(local_max_overlap(), comm_);
  return d;
}

double DemEngine::local_max_overlap() const {
  // The pairs LIGGGHTS keeps for its contacts: every pair that touches is in the neighbour list
  // (atoms move less than half the skin between builds) and ghosts carry this step's positions,
  // so one pass over the list finds what measure_overlaps finds with a grid of all particles.
  // Before the first run there is no list; placement leaves no overlaps (test_placement).
  const double* r = lmp_->atom->radius;
  double** x = lmp_->atom->x;
  const int nlocal = lmp_->atom->nlocal;
  double worst = 0;
  for (int i = 0; i < nlocal; ++i)
    worst = std::max(worst, (std::hypot(x[i][0], x[i][1]) + r[i] - locator_->radius()) / (2 * r[i]));
  const LAMMPS_NS::NeighList* list = lmp_->force->pair != nullptr ? lmp_->force->pair->list : nullptr;
  if (list == nullptr || lmp_->neighbor->ncalls == 0) return worst;
  for (int k = 0; k < list->inum; ++k) {
    const int i = list->ilist[k];
    const int* neighbours = list->firstneigh[i];
    for (int n = 0; n < list->numneigh[i]; ++n) {
      const int j = neighbours[n] & NEIGHMASK;
      const double gap = std::sqrt((x[i][0] - x[j][0]) * (x[i][0] - x[j][0]) + (x[i][1] - x[j][1]) * (x[i][1] - x[j][1]) +
                                   (x[i][2] - x[j][2]) * (x[i][2] - x[j][2]));
      worst = std::max(worst, (r[i] + r[j] - gap) / (2 * std::min(r[i], r[j])));
    }
  }
  return worst;
}

ParticleSnapshot DemEngine::snapshot(long step, double time_s) {
  const std::size_t n = static_cast<std::size_t>(n_particles_);
  // Per tag: species, position (3), velocity (3), orientation (4); summed over ranks (each atom
  // on one rank). A tag no rank has (lost) keeps zeros.
  constexpr int kPer = 11;
  std::vector<double> buf(kPer * n, 0.0);
  const int nlocal = lmp_->atom->nlocal;
  const int* tag = lmp_->atom->tag;
  const int* type = lmp_->atom->type;
  double** x = lmp_->atom->x;
  double** v = lmp_->atom->v;
  double** rot = per_atom(rotation_fix_);
  for (int i = 0; i < nlocal; ++i) {
    const std::size_t k = kPer * static_cast<std::size_t>(tag[i] - 1);
    const int sp = species_of_type_[type[i]];
    buf[k] = sp;
    buf[k + 1] = x[i][0];
    buf[k + 2] = x[i][1];
    buf[k + 3] = unwrap_z(tag[i], x[i][2]);
    buf[k + 4] = v[i][0];
    buf[k + 5] = v[i][1];
    buf[k + 6] = v[i][2];
    if (rotation_[sp])
      for (int d = 0; d < 4; ++d) buf[k + 7 + d] = rot[i][d];
    else
      buf[k + 7] = 1;
  }
  int size = 1;
  MPI_Comm_size(comm_, &size);
  if (size > 1) MPI_Allreduce(MPI_IN_PLACE, buf.data(), static_cast<int>(buf.size()), MPI_DOUBLE, MPI_SUM, comm_);
  ParticleSnapshot s;
  s.step = step;
  s.time_s = time_s;
  s.id.resize(n);
  s.species.resize(n);
  s.position.resize(3 * n);
  s.velocity.resize(3 * n);
  s.orientation.resize(4 * n);
  for (std::size_t t = 0; t < n; ++t) {
    s.id[t] = static_cast<std::int64_t>(t + 1);
    s.species[t] = static_cast<std::int8_t>(buf[kPer * t]);
    for (int d = 0; d < 3; ++d) {
      s.position[3 * t + d] = buf[kPer * t + 1 + d];
      s.velocity[3 * t + d] = buf[kPer * t + 4 + d];
    }
    for (int d = 0; d < 4; ++d) s.orientation[4 * t + d] = buf[kPer * t + 7 + d];
  }
  return s;
}

void DemEngine::set_orientation(long id, const Quat& q) {
  if (rotation_fix_ == nullptr) throw std::logic_error("no particle of this scene tracks an orientation");
  // Taken at the next force evaluation: LIGGGHTS re-initialises property/atom values of
  // existing atoms when it sets up a run, so a value written between runs may not survive.
  pending_orientation_[static_cast<int>(id)] = q.normalized();
}

}  // namespace hemo::particles
