// DemEngine's set-up and stepping: LIGGGHTS started and configured for the scene, the particles
// created, a coupling step's DEM run and its checks, the per-tag tracking. The force callback is
// in dem_fluid_force.cpp, orientations in dem_orientation.cpp, snapshots and diagnostics in
// dem_output.cpp, checkpoints in dem_checkpoint.cpp (see dem_engine.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_engine.h"

#include <atom.h>
#include <fix.h>
#include <fix_external.h>
#include <fix_property_atom.h>
#include <fmt/format.h>
#include <input.h>
#include <lammps.h>
#include <modify.h>
#include <neighbor.h>
#include <units.h>
#include <update.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <tuple>
#include <type_traits>

#include "dem_fixes.h"

namespace hemo::particles {

static_assert(std::is_same_v<LAMMPS_NS::bigint, std::int64_t>, "LIGGGHTS built with another bigint");

using namespace dem;

namespace {

constexpr long kLogRotateSteps = 1000;  // the LIGGGHTS run log keeps at most this many coupling steps
constexpr double kContactReach = 1.02;  // contact histories are cleared within this x the contact distance

const Species& species_of(const Scene& s, int sp) { return sp == kRbc ? s.rbc : s.platelet; }

// The settings that need no particles yet, the node's and a bare LIGGGHTS run's alike.
std::vector<std::string> base_settings(const DemBookkeeping& bookkeeping) {
  return {
      "units si",
      "atom_style granular",
      // No re-sorting by default: tags start in spatial order (create_particles). What sorting
      // would save later in a run is measured in docs/performance.md §6.
      fmt::format("atom_modify map array sort {} 0.0", bookkeeping.sort_every_steps),
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
}

// The materials per atom type and type pair (LIGGGHTS's property/global fixes); the wall's
// material is the last type.
std::vector<std::string> material_fixes(const Contact& c, int n_types) {
  std::string youngs, poisson, restitution, friction;
  for (int i = 1; i <= n_types; ++i) {
    const bool wi = i == n_types;
    youngs += fmt::format(" {:.17g}", wi ? c.wall_youngs_modulus : c.cell_youngs_modulus);
    poisson += fmt::format(" {:.17g}", wi ? c.wall_poisson_ratio : c.cell_poisson_ratio);
    for (int j = 1; j <= n_types; ++j) {
      const bool wall_pair = wi || j == n_types;
      restitution += fmt::format(" {:.17g}", wall_pair ? c.cell_wall_restitution : c.cell_cell_restitution);
      friction += fmt::format(" {:.17g}", c.friction);
    }
  }
  return {
      "fix m1 all property/global youngsModulus peratomtype" + youngs,
      "fix m2 all property/global poissonsRatio peratomtype" + poisson,
      fmt::format("fix m3 all property/global coefficientRestitution peratomtypepair {}{}", n_types, restitution),
      fmt::format("fix m4 all property/global coefficientFriction peratomtypepair {}{}", n_types, friction),
  };
}

// " 0 0 ... 0": the initial values of a per-atom vector fix.
std::string zeros(int n) {
  std::string s;
  for (int k = 0; k < n; ++k) s += " 0";
  return s;
}

}  // namespace

DemEngine::DemEngine(const Scene& scene, const CellLocator& locator, const std::string& log_path, MPI_Comm comm,
                     bool append_log, const DemBookkeeping& bookkeeping)
    : scene_(dem_scene(scene)), locator_(&locator), comm_(comm), log_path_(log_path), bookkeeping_(bookkeeping) {
  set_up_species(scene);
  start_liggghts(append_log);
  if (scene_.implicit_drag == "co_relaxed") {
    cell_plasma_ = std::make_unique<CellPlasmaRelaxation>(locator.n_cells());
    take_plasma_mass(Deposition(locator));  // no particles deposited yet: all plasma
  }
}
DemEngine::~DemEngine() { delete lmp_; }

void DemEngine::set_up_species(const Scene& physical) {
  const Vec3 gravity(physical.gravity.x, physical.gravity.y, physical.gravity.z);
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    const Species& s = species_of(scene_, sp);  // masses x dem_mass_scaling
    if (!s.present) continue;
    if (!(s.diameter > 0) || !(s.mass > 0) || !(s.volume > 0))
      throw std::invalid_argument(s.name + ": diameter, mass and volume must be positive");
    forces_[sp] = std::make_unique<SpeciesForces>(s, scene_);
    if (forces_[sp]->needs_orientation()) {
      if (!(s.semi_axis_a > 0) || !(s.semi_axis_c > 0))
        throw std::invalid_argument(s.name + ": an oblate closure needs the semi-axes a and c");
      rotation_[sp] = make_orientation_integrator(s.orientation_integrator,
                                                  SymmetricTop::oblate_spheroid(s.mass, s.semi_axis_a, s.semi_axis_c));
      any_orientation_ = true;
    }
    volume_[sp] = s.volume;
    diameter_[sp] = s.diameter;
    mass_[sp] = s.mass;
    weight_[sp] = species_of(physical, sp).mass * gravity;  // the physical weight, whatever the DEM mass
    d_max_ = std::max(d_max_, s.diameter);
  }
  if (d_max_ == 0) throw std::invalid_argument("the scene has no particle species");
}

void DemEngine::start_liggghts(bool append_log) {
  std::vector<std::string> args = {"hemocosim-particles", "-screen", "none", "-log",
                                   append_log ? std::string("none") : log_path_};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  lmp_ = new LAMMPS_NS::LAMMPS(static_cast<int>(argv.size()), argv.data(), comm_);

  if (append_log && log_path_ != "none") command("log " + log_path_ + " append");  // a resumed run keeps the log
  for (const auto& line : base_settings(bookkeeping_)) command(line);
}

void DemEngine::command(const std::string& line) { lmp_->input->one(line.c_str()); }

void DemEngine::setup_box(const std::array<bool, kSpeciesCount>& used) {
  define_box_and_contacts(assign_atom_types(used));
  // A pair's tangential history is cleared when it separates, not at the next neighbour-list
  // rebuild: LIGGGHTS clears it only for pairs within this factor x the contact distance (and
  // keeps the rest until a rebuild drops it), so with 1 a pair that separates and touches again
  // before the next rebuild would find its old shear spring, and results would depend on when
  // lists are rebuilt (a checkpoint rebuilds them). The band, 2 % of the contact distance
  // (53 nm for two platelets), is wider than a separating pair moves in a DEM step (~1 nm at the
  // impact velocity the step is made for), and adds ~5 % of pairs to the lists.
  lmp_->neighbor->register_contact_dist_factor(kContactReach);
  if (any_orientation_)
    command(fmt::format("fix {} all property/atom hemoRotation vector yes no no 1 0 0 0 0 0 0", kRotationFix));
  if (holds_closures())
    command(fmt::format("fix {} all property/atom hemoClosures vector no no no{}", kClosureFix, zeros(kClosureSlots)));
  find_fixes();
}

int DemEngine::assign_atom_types(const std::array<bool, kSpeciesCount>& used) {
  // LIGGGHTS wants granular atom types to start at 1 without holes: the species that have
  // particles take types 1, 2 (RBC before platelet), the wall's material the next one, the last.
  int n_types = 0;
  for (int sp = 0; sp < kSpeciesCount; ++sp) type_of_[sp] = used[sp] ? ++n_types : 0;
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (used[sp]) species_of_type_[type_of_[sp]] = sp;
  return ++n_types;
}

void DemEngine::define_box_and_contacts(int n_types) {
  const double R = locator_->radius();
  const double z0 = locator_->z0(), L = locator_->length();
  const double half_box = R + 2 * d_max_;
  command(fmt::format("region hemo_box block {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} units box", -half_box,
                      half_box, -half_box, half_box, z0, z0 + L));
  command(fmt::format("create_box {} hemo_box", n_types));
  for (const auto& line : contact_model(n_types)) command(line);
  command(fmt::format("fix {} all property/atom hemoImpulse vector no no no{}", kImpulseFix, zeros(kImpulseValues)));
  // Defined after the wall: its post_force sees the contact forces and torques of the step.
  command(fmt::format("fix {} all external pf/callback 1 1", kFluidFix));
}

std::vector<std::string> DemEngine::contact_model(int n_types) const {
  std::vector<std::string> lines = {
      fmt::format("neighbor {:.17g} bin", bookkeeping_.skin_diameters * d_max_),
      "neigh_modify delay 0",
  };
  const auto materials = material_fixes(scene_.contact, n_types);
  lines.insert(lines.end(), materials.begin(), materials.end());
  lines.insert(lines.end(), {
                                "pair_style gran model hertz tangential history",
                                "pair_coeff * *",
                                "timestep 1e-7",
                                fmt::format("fix {} all wall/gran model hertz tangential history primitive type {} "
                                            "zcylinder {:.17g} 0 0",
                                            kWallFix, n_types, locator_->radius()),
                                "fix hemo_integrate all nve/sphere",
                            });
  return lines;
}

std::vector<std::string> DemEngine::bare_liggghts_input(const std::string& data_file, double dt, long steps) const {
  std::vector<std::string> lines = base_settings(bookkeeping_);
  lines.push_back("read_data " + data_file);
  for (const auto& line : contact_model(lmp_->atom->ntypes)) lines.push_back(line);
  lines.push_back(fmt::format("timestep {:.17g}", dt));
  lines.push_back(fmt::format("run {}", steps));
  return lines;
}

void DemEngine::find_fixes() {
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
  if (wall_history_fix_ == nullptr)
    throw std::runtime_error("LIGGGHTS's wall contact history is not a fix property/atom");
}

double** DemEngine::per_atom(LAMMPS_NS::Fix* fix) const { return fix != nullptr ? fix->array_atom : nullptr; }

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
    return std::make_tuple(std::floor((p->position.z() - locator_->z0()) / d_max_),
                           std::floor(p->position.y() / d_max_), p->position.x());
  };
  std::stable_sort(order.begin(), order.end(), [&](auto* a, auto* b) { return key(a) < key(b); });
  if (bookkeeping_.shuffled_tags) std::shuffle(order.begin(), order.end(), std::mt19937(1));
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
    throw std::runtime_error(
        fmt::format("LIGGGHTS created {} of {} particles (some outside the box?)", n_particles_, particles.size()));
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
    max_re_[sp] = forces_[sp]
                      ? forces_[sp]->params().reynolds(Vec3(std::sqrt(max_all(max_slip_squared_[sp], comm_)), 0, 0))
                      : 0.0;
  min_relaxation_time_ = std::numeric_limits<double>::infinity();
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (const double beta = max_all(max_beta_[sp], comm_); beta > 0)
      min_relaxation_time_ = std::min(min_relaxation_time_, mass_[sp] / beta);
  std::string problem = agree_on_problem();
  if (problem.empty()) problem = check_lost(coupling_step);
  return problem;
}

long DemEngine::neighbour_builds() const { return static_cast<long>(lmp_->neighbor->ncalls); }

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
  return fmt::format(
      "particle {} was lost by LIGGGHTS (it left the DEM box) during coupling step {}; {} particle{} lost "
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

}  // namespace hemo::particles
