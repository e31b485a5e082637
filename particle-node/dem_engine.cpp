// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_engine.h"

#include "closures/exponential_drag.h"
#include "overlap.h"

#include <atom.h>
#include <fix_external.h>
#include <input.h>
#include <lammps.h>
#include <modify.h>
#include <update.h>

#include <fmt/format.h>
#include <units.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>
#include <type_traits>

namespace hemo::particles {

static_assert(std::is_same_v<LAMMPS_NS::bigint, std::int64_t>, "LIGGGHTS built with another bigint");

namespace {

constexpr const char* kFluidFix = "hemo_fluid";
constexpr long kLogRotateSteps = 1000;  // the LIGGGHTS run log keeps at most this many coupling steps

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

DemEngine::DemEngine(const Scene& scene, const CellLocator& locator, const std::string& log_path, MPI_Comm comm)
    : scene_(scene), locator_(&locator), comm_(comm), log_path_(log_path) {
  double d_max = 0;
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    const Species& s = species_of(scene, sp);
    if (!s.present) continue;
    if (!(s.diameter > 0) || !(s.mass > 0) || !(s.volume > 0))
      throw std::invalid_argument(s.name + ": diameter, mass and volume must be positive");
    drag_[sp] = make_drag_closure(s, scene.plasma);
    if (s.lift != "none")  // lift closures come with issue #4; never ignore one silently
      throw std::invalid_argument(s.name + ": lift closure '" + s.lift + "' is not implemented yet (known: none)");
    volume_[sp] = s.volume;
    diameter_[sp] = s.diameter;
    mass_[sp] = s.mass;
    d_max = std::max(d_max, s.diameter);
  }
  if (d_max == 0) throw std::invalid_argument("the scene has no particle species");

  std::vector<std::string> args = {"hemocosim-particles", "-screen", "none", "-log", log_path};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  lmp_ = new LAMMPS_NS::LAMMPS(static_cast<int>(argv.size()), argv.data(), comm);

  const std::vector<std::string> setup = {
      "units si",
      "atom_style granular",
      "atom_modify map array sort 0 0.0",  // ids keep their spatial order (see create_particles)
      "boundary f f p",
      "newton off",
      "communicate single vel yes",
      // Cells are softer (7.5e5 Pa) than LIGGGHTS's SI floor of 5e6 Pa.
      "soft_particles yes",
      "processors 1 1 *",
      "thermo 0",
  };
  for (const auto& line : setup) command(line);
  d_max_ = d_max;
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
      fmt::format("fix hemo_wall all wall/gran model hertz tangential history primitive type {} zcylinder {:.17g} 0 0",
                  wall_type, R),
      "fix hemo_integrate all nve/sphere",
      fmt::format("fix {} all external pf/callback 1 1", kFluidFix),
  };
  for (const auto& line : setup) command(line);
  const int ifix = lmp_->modify->find_fix(kFluidFix);
  if (ifix < 0) throw std::runtime_error("LIGGGHTS did not create the fluid force fix");
  static_cast<LAMMPS_NS::FixExternal*>(lmp_->modify->fix[ifix])->set_callback(&DemEngine::force_callback, this);
}

void DemEngine::create_particles(const std::vector<PlacedParticle>& particles) {
  if (n_particles_ > 0 || type_of_[kRbc] + type_of_[kPlatelet] > 0)
    throw std::logic_error("particles were already created");
  if (particles.empty()) throw std::invalid_argument("no particles to simulate");
  std::array<bool, kSpeciesCount> used{};
  for (const auto& p : particles) {
    if (p.species < 0 || p.species >= kSpeciesCount || !drag_[p.species])
      throw std::invalid_argument("a placed particle has a species the scene does not have");
    used[p.species] = true;
  }
  setup_box(used);
  // Tags follow a spatial order (axial slabs, then rows): neighbours in space are neighbours in
  // memory, for LIGGGHTS (atom sorting is off) and for our per-tag arrays alike.
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
  static_cast<DemEngine*>(self)->on_force(ntimestep, nlocal, tag, x, f);
}

void DemEngine::on_force(std::int64_t ntimestep, int nlocal, const int* tag, double** x, double** f) {
  ++callbacks_;
  // Verlet: the setup force and the last force of a run act for half a step in this run (see
  // header); the other half of the last one is delivered by the next run and kept for it.
  const bool last = ntimestep == run_start_ + run_steps_;
  const bool half = last || ntimestep == run_start_;
  const double duration = (half ? 0.5 : 1.0) * dt_;
  const int* type = lmp_->atom->type;
  double** v = lmp_->atom->v;
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
    unwrap_z(t, xi.z());
    const int cell = cell_of(t, xi);
    if (cell < 0) {
      ++outside_;
      note_problem(t, fmt::format("particle {} is outside the fluid mesh at coupling step {} (DEM step {}), "
                                  "x = ({:.6g}, {:.6g}, {:.6g}) m, r = {:.6g} m",
                                  t, coupling_step_, ntimestep, xi.x(), xi.y(), xi.z(), std::hypot(xi.x(), xi.y())));
      continue;
    }
    const Vec3 slip = fluid_->velocity(cell, locator_->wrap(xi)) - vi;
    double beta, beta_eff;
    if (beta_eff_[sp] >= 0) {
      beta = beta_[sp];
      beta_eff = beta_eff_[sp];
    } else {
      beta = drag_[sp]->coefficient(slip);
      beta_eff = exponential_drag_coefficient(mass_[sp], beta, dt_);
    }
    const Vec3 force = beta_eff * slip;
    f[i][0] = force.x();
    f[i][1] = force.y();
    f[i][2] = force.z();
    deposition_->add_drag(cell, force, beta, duration);
    if (last) carry_.push_back({cell, beta, force});
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

std::string DemEngine::run(long coupling_step, int substeps, double dt, const FluidSampler& fluid,
                           Deposition& deposition) {
  if (n_particles_ == 0) return {};
  if (substeps < 1 || !(dt > 0)) throw std::invalid_argument("DEM run needs at least one step of positive length");
  fluid_ = &fluid;
  deposition_ = &deposition;
  coupling_step_ = coupling_step;
  run_steps_ = substeps;
  callbacks_ = 0;
  outside_ = 0;
  first_problem_.clear();
  const bool new_dt = dt != dt_;
  dt_ = dt;
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    beta_eff_[sp] = -1;
    if (drag_[sp] && drag_[sp]->slip_independent()) {
      beta_[sp] = drag_[sp]->coefficient(Vec3::Zero());
      beta_eff_[sp] = exponential_drag_coefficient(mass_[sp], beta_[sp], dt);
    }
  }
  // `pre no` skips re-initialisation between runs and keeps the forces of the last step, whose
  // second half kick comes first in this run: its impulse belongs to this interval. A new step
  // size needs `pre yes` (integrator factors), which recomputes the forces instead.
  const bool pre = first_run_ || new_dt;
  if (!pre)
    for (const auto& c : carry_) deposition.add_drag(c.cell, c.force, c.beta, 0.5 * dt);
  carry_.clear();
  if (new_dt) command(fmt::format("timestep {:.17g}", dt));
  if (log_path_ != "none" && coupling_step % kLogRotateSteps == 1)
    command("log " + log_path_ + ".steps");  // restarts the run log: bounded size, recent errors kept
  run_start_ = lmp_->update->ntimestep;
  command(fmt::format("run {} pre {} post no", substeps, pre ? "yes" : "no"));
  first_run_ = false;
  fluid_ = nullptr;
  deposition_ = nullptr;
  const long expected = pre ? substeps + 1 : substeps;  // `pre yes` adds the setup evaluation
  if (callbacks_ != expected)
    throw std::runtime_error(fmt::format("LIGGGHTS evaluated the fluid forces {} times in a run of {} steps, not {}",
                                         callbacks_, substeps, expected));
  sync_tracking();
  outside_total_ = static_cast<long>(sum_all(static_cast<double>(outside_), comm_));
  return agree_on_problem();
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

void DemEngine::finish_deposition(Deposition& deposition) {
  deposition.clear_volume();
  const int nlocal = lmp_->atom->nlocal;
  const int* tag = lmp_->atom->tag;
  const int* type = lmp_->atom->type;
  double** x = lmp_->atom->x;
  for (int i = 0; i < nlocal; ++i) {
    const Vec3 xi(x[i][0], x[i][1], x[i][2]);
    const int cell = cell_of(tag[i], xi);
    if (cell >= 0) deposition.add_volume(cell, locator_->wrap(xi), volume_[species_of_type_[type[i]]]);
  }
  int size = 1;
  MPI_Comm_size(comm_, &size);
  if (size > 1) MPI_Allreduce(MPI_IN_PLACE, deposition.data(), deposition.size(), MPI_DOUBLE, MPI_SUM, comm_);
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

  const ParticleSnapshot all = snapshot(0, 0.0);
  std::vector<Vec3> pos(all.size());
  std::vector<double> dia(all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    pos[i] = Vec3(all.position[3 * i], all.position[3 * i + 1], all.position[3 * i + 2]);
    dia[i] = diameter_[all.species[i]];
  }
  d.max_overlap = measure_overlaps(pos, dia, locator_->radius(), locator_->length(), locator_->z0()).max_relative;
  return d;
}

ParticleSnapshot DemEngine::snapshot(long step, double time_s) {
  const std::size_t n = static_cast<std::size_t>(n_particles_);
  // Per tag: species, position (3), velocity (3); summed over ranks (each atom on one rank).
  std::vector<double> buf(7 * n, 0.0);
  const int nlocal = lmp_->atom->nlocal;
  const int* tag = lmp_->atom->tag;
  const int* type = lmp_->atom->type;
  double** x = lmp_->atom->x;
  double** v = lmp_->atom->v;
  for (int i = 0; i < nlocal; ++i) {
    const std::size_t k = 7 * static_cast<std::size_t>(tag[i] - 1);
    buf[k] = species_of_type_[type[i]];
    buf[k + 1] = x[i][0];
    buf[k + 2] = x[i][1];
    buf[k + 3] = unwrap_z(tag[i], x[i][2]);
    buf[k + 4] = v[i][0];
    buf[k + 5] = v[i][1];
    buf[k + 6] = v[i][2];
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
  for (std::size_t t = 0; t < n; ++t) {
    s.id[t] = static_cast<std::int64_t>(t + 1);
    s.species[t] = static_cast<std::int8_t>(buf[7 * t]);
    for (int d = 0; d < 3; ++d) {
      s.position[3 * t + d] = buf[7 * t + 1 + d];
      s.velocity[3 * t + d] = buf[7 * t + 4 + d];
    }
  }
  return s;
}

}  // namespace hemo::particles
