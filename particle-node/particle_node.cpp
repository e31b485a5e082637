// SPDX-License-Identifier: GPL-3.0-or-later
#include "particle_node.h"

#include "agree.h"
#include "cell_fields.h"
#include "checkpoint_file.h"
#include "developed_feeder.h"
#include "engine_state.h"
#include "engine_state_merge.h"

#include <checkpoint.h>
#include <clock.h>
#include <feeder_develop.h>
#include <traffic.h>
#include <fmt/format.h>
#include <momentum_forms.h>
#include <placement.h>
#include <spdlog/spdlog.h>
#include <vessel_ends.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <utility>

namespace hemo::particles {

namespace {

void require_same(double scene_value, double mesh_value, const char* what) {
  if (std::abs(scene_value - mesh_value) > 1e-9 * std::abs(scene_value))
    throw std::runtime_error(
        fmt::format("the fluid mesh's {} is {:.6g} m, the scene's {:.6g} m", what, mesh_value, scene_value));
}

constexpr const char* kRole = "particles";     // the checkpoint's folder (common/checkpoint.h)

// A partitioned exchange's rank's own deposition in a checkpoint folder: the cells it takes and
// their accumulators (Deposition::kStride each).
std::string own_deposition_file(const std::string& folder, int rank) {
  return folder + "/deposition-rank" + std::to_string(rank) + ".h5";
}
constexpr std::int64_t kCheckpointFormat = 2;  // 2: the fluid state's pressure gradient

void broadcast(std::string& text, int root, MPI_Comm comm) {
  int len = static_cast<int>(text.size());
  MPI_Bcast(&len, 1, MPI_INT, root, comm);
  text.resize(static_cast<std::size_t>(len));
  MPI_Bcast(text.data(), len, MPI_CHAR, root, comm);
}

}  // namespace

// What node.h5 holds.
struct ParticleNode::NodeCheckpoint {
  std::int64_t ranks = 0, particles = 0, step = 0;
  double time_s = 0, interval_s = 0;
  std::vector<std::int64_t> warned_re;
  std::string mesh_hash;
  std::vector<double> deposition;                      // the interval's per-cell accumulators (Deposition::data)
  std::vector<double> fluid_velocity, fluid_gradient;  // the fluid state of the interval; empty before any
  std::vector<double> fluid_pressure_gradient;         // of that state; empty when it carried none
  std::vector<double> fluid_viscous_force;             // likewise
  std::vector<double> z_cuts;                          // the particle ranks' slabs (DemEngine::z_cuts)
};

ParticleNode::ParticleNode(const Scene& scene, const mesh_t& mesh, const std::string& run_dir, MPI_Comm comm,
                           long resume_step)
    : scene_(scene),
      mesh_hash_(mesh.mesh_hash),
      comm_(comm),
      locator_(mesh, make_vessel_wall(scene.vessel),
               fed_by_feeder(scene.vessel) ? std::optional(feeder_layout(scene)) : std::nullopt),
      fluid_(locator_, scene.fluid_velocity),
      deposition_(locator_, make_solid_fraction_model(scene.solid_fraction, locator_, scene.kernel_width_diameters)),
      run_dir_(run_dir) {
  MPI_Comm_rank(comm_, &rank_);
  fluid_.read_over(&deposition_.model());
  require_same(scene.vessel.diameter, mesh.vessel_diameter_m, "vessel diameter");
  require_same(scene.vessel.length, mesh.vessel_length_m, "vessel length");
  std::filesystem::create_directories(run_dir);
  find_used_species();
  set_interval(scene.time.coupling_interval);
  if (resume_step > 0)
    resume(resume_step);
  else
    start();
  log_particles();
}

double ParticleNode::exchange_margin() const {
  double beyond = 0;
  for (const Species* sp : {&scene_.rbc, &scene_.platelet})
    beyond = std::max(beyond, deposition_.model().reach(0.5 * sp->diameter) - 0.5 * sp->diameter);
  return engine_->exchange_margin() + beyond;
}

void ParticleNode::find_used_species() {
  for (int sp = 0; sp < kSpeciesCount; ++sp) used_[sp] = (sp == kRbc ? rbc_count(scene_) : platelet_count(scene_)) > 0;
  if (!used_[kRbc] && !used_[kPlatelet])
    throw std::runtime_error("the scene has no particles (no hematocrit, no platelets)");
}

void ParticleNode::log_particles() const {
  spdlog::info(
      "particles: {} ({} RBC, {} platelets) in {} fluid cells (wall gap {:.3g} um); solid fraction "
      "'{}'",
      engine_->particle_count(), rbc_count(scene_), platelet_count(scene_), locator_.n_cells(),
      locator_.wall_gap() * 1e6, scene_.solid_fraction);
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (used_[sp])
      spdlog::info(
          "{}: {}{}", sp == kRbc ? "rbc" : "platelet", engine_->forces(sp).describe(),
          engine_->tracks_orientation(sp)
              ? ", orientation tracked (" + name_of((sp == kRbc ? scene_.rbc : scene_.platelet).orientation_integrator) + ")"
              : std::string());
}

void ParticleNode::start() {
  // A developed feeder's cells as its own run left them (model/feeder_develop.h); else placed.
  const auto placed =
      develops_feeder(scene_)
          ? fill_open_vessel(developed_feeder_cells(scene_, run_dir_ + "/" + kFeederDevelopFolder, locator_.z0()),
                             locator_.wall(), feeder_layout(scene_), locator_.z0())
          : place_scene_particles(scene_, locator_.wall(), locator_.z0());
  engine_ = std::make_unique<DemEngine>(scene_, locator_, run_dir_ + "/liggghts.log", comm_);
  engine_->create_particles(placed);
  engine_->deposit(deposition_);
  if (rank_ == 0) output_ = std::make_unique<H5Output>(run_dir_ + "/particles.h5");
  write_output(0, 0.0);
}

void ParticleNode::resume(long step) {
  // Everything is read and checked before anything is changed: a checkpoint that cannot be used
  // stops the node with the run directory as it was.
  NodeCheckpoint saved;
  EngineState engine_state;
  std::string error;
  try {
    saved = read_checkpoint(step);
    engine_state = read_engine_state_for(checkpoint_of(run_dir_, step, kRole), saved.ranks);
    if (rank_ == 0 && std::filesystem::exists(run_dir_ + "/particles.h5")) list_snapshots(run_dir_ + "/particles.h5");
  } catch (const std::exception& e) {
    error = e.what();
  }
  error = agree_on_error(error, comm_);
  if (!error.empty()) throw CheckpointError(fmt::format("cannot resume from step {}: {}", step, error));

  engine_ = std::make_unique<DemEngine>(scene_, locator_, run_dir_ + "/liggghts.log", comm_, /*append_log=*/true);
  try {
    engine_->restore(engine_state, saved.z_cuts);
  } catch (const std::invalid_argument& e) {  // found alike on every rank (DemEngine::restore agrees on it)
    throw CheckpointError(fmt::format("cannot resume from step {}: {}", step, e.what()));
  }
  step_ = saved.step;
  time_ = saved.time_s;
  interval_ = saved.interval_s;
  if (interval_ > 0) set_interval(interval_);
  for (int sp = 0; sp < kSpeciesCount; ++sp) warned_re_[sp] = saved.warned_re[sp] != 0;
  std::copy(saved.deposition.begin(), saved.deposition.end(), deposition_.data());
  engine_->take_plasma_mass(deposition_);
  if (!saved.fluid_velocity.empty())
    fluid_.set_state(saved.fluid_velocity, saved.fluid_gradient, saved.fluid_pressure_gradient,
                     saved.fluid_viscous_force);
  if (rank_ == 0) output_resumes_after_ = step;  // particles.h5 is opened at the first snapshot
  resumed_from_ = {checkpoint_of(run_dir_, step, kRole), saved.ranks};
  spdlog::info("resumed from the checkpoint of step {} (t = {:.6g} s)", step_, time_);
}

EngineState ParticleNode::read_engine_state_for(const std::string& folder, long written_on) const {
  int ranks = 1;
  MPI_Comm_size(comm_, &ranks);
  if (written_on == ranks) return read_engine_state(engine_state_file(folder, rank_));
  // Another rank count: every rank reads them all (DemEngine::restore keeps its own atoms).
  std::vector<EngineState> states;
  for (int r = 0; r < written_on; ++r) states.push_back(read_engine_state(engine_state_file(folder, r)));
  if (rank_ == 0)
    spdlog::info("the checkpoint was written on {} MPI ranks, this node runs on {}: its particles are shared anew",
                 written_on, ranks);
  return merged(std::move(states));
}

ParticleNode::NodeCheckpoint ParticleNode::read_checkpoint(long step) const {
  const CheckpointReader in(checkpoint_of(run_dir_, step, kRole) + "/node.h5");
  if (in.integer("format") != kCheckpointFormat)
    throw std::runtime_error(
        fmt::format("{} is of format {}, this node reads {}", in.path(), in.integer("format"), kCheckpointFormat));
  NodeCheckpoint c;
  c.ranks = in.integer("ranks");
  c.particles = in.integer("particles");
  c.step = in.integer("step");
  c.time_s = in.real("time_s");
  c.interval_s = in.real("interval_s");
  in.get("warned_reynolds", c.warned_re);
  c.mesh_hash = in.bytes("mesh_hash");
  in.get("deposition", c.deposition);
  in.get("fluid_velocity", c.fluid_velocity);
  in.get("fluid_gradient", c.fluid_gradient);
  in.get("fluid_pressure_gradient", c.fluid_pressure_gradient);
  in.get("fluid_viscous_force", c.fluid_viscous_force);
  if (in.has("z_cuts")) in.get("z_cuts", c.z_cuts);
  check_fits(c, step, in.path());
  return c;
}

void ParticleNode::check_fits(const NodeCheckpoint& c, long step, const std::string& path) const {
  if (c.ranks < 1) throw std::runtime_error(fmt::format("{} is damaged (written on {} ranks)", path, c.ranks));
  if (c.mesh_hash != mesh_hash_)
    throw std::runtime_error(fmt::format("it fits the mesh '{}', the fluid's mesh is '{}'", c.mesh_hash, mesh_hash_));
  // An open vessel's count changes as cells come and go (its engine checks its own counts).
  const long particles = rbc_count(scene_) + platelet_count(scene_);
  if (!open_ends(scene_.vessel) && c.particles != particles)
    throw std::runtime_error(fmt::format("it holds {} particles, the scene has {}", c.particles, particles));
  const std::size_t cells = static_cast<std::size_t>(locator_.n_cells());
  const bool fluid_fits = c.fluid_velocity.empty() ||
                          (c.fluid_velocity.size() == 3 * cells && c.fluid_gradient.size() == 9 * cells &&
                           (c.fluid_pressure_gradient.empty() || c.fluid_pressure_gradient.size() == 3 * cells) &&
                           (c.fluid_viscous_force.empty() || c.fluid_viscous_force.size() == 3 * cells));
  if (c.step != step || c.warned_re.size() != kSpeciesCount ||
      c.deposition.size() != static_cast<std::size_t>(deposition_.size()) || !fluid_fits)
    throw std::runtime_error(fmt::format("{} is damaged (step {}, {} deposition and {} fluid values for {} cells)",
                                         path, c.step, c.deposition.size(), c.fluid_velocity.size(), cells));
}

void ParticleNode::set_interval(double interval) {
  if (interval == timing_interval_) return;
  timing_ = derive_dem_timing(scene_, interval, scene_.time.dem_substeps);
  timing_interval_ = interval;
  spdlog::info(
      "DEM step {:.4g} s = coupling interval {:.4g} s / {} substeps; shortest Hertz contact {:.4g} s ({}), "
      "Rayleigh time {:.4g} s, drag relaxation time {:.4g} s ({}; dt / tau = {:.3g})",
      timing_.dt, interval, timing_.substeps, timing_.contact_time, timing_.limiting, timing_.rayleigh_time,
      timing_.relaxation_time, timing_.relaxation_limited ? "limits the step" : "exponential drag: not a limit",
      timing_.dt / timing_.relaxation_time);
  for (const Species* sp : {&scene_.rbc, &scene_.platelet})
    if (sp->present && dem_mass_scaling(scene_, *sp) != 1)
      spdlog::info("mass scaling: the DEM integrates the {} with {:g} x their mass", sp->name,
                   dem_mass_scaling(scene_, *sp));
}

Box ParticleNode::sub_domain() const {
  const auto d = engine_->sub_domain();
  return {Vec3(d[0], d[1], d[2]), Vec3(d[3], d[4], d[5])};
}

void ParticleNode::use_overlap(const OverlapMap& map) {
  hold(map);
  if (!take_own_deposition()) {
    // The deposition so far (placed, or resumed on other rank counts) was summed over the ranks:
    // each cell's sum stays with the one rank that speaks for it, so that the fluid's sum of
    // the partials is it.
    for (std::size_t c = 0; c < designated_.size(); ++c)
      if (!designated_[c]) std::fill_n(deposition_.data() + Deposition::kStride * c, Deposition::kStride, 0.0);
  }
  engine_->use_halo(std::make_unique<CellHaloSum>(map, rank_, comm_));
}

bool ParticleNode::balance() {
  const auto t0 = std::chrono::steady_clock::now();
  const bool moved = engine_->balance(scene_.load_balance_threshold);
  phase_.dem += seconds_since(t0);
  return moved;
}

void ParticleNode::follow_overlap(const OverlapMap& map) {
  const auto t0 = std::chrono::steady_clock::now();
  hold(map);
  engine_->use_halo(std::make_unique<CellHaloSum>(map, rank_, comm_));
  engine_->deposit(deposition_);
  phase_.deposition += seconds_since(t0);
}

void ParticleNode::hold(const OverlapMap& map) {
  const std::size_t n = static_cast<std::size_t>(locator_.n_cells());
  held_.assign(n, 0);
  for (int c : map.needed(rank_)) held_[static_cast<std::size_t>(c)] = 1;
  designated_.assign(n, 0);
  std::vector<char> spoken(n, 0);
  for (int p = 0; p < static_cast<int>(map.from.size()); ++p)
    for (int c : map.needed(p))
      if (!spoken[static_cast<std::size_t>(c)]) {
        spoken[static_cast<std::size_t>(c)] = 1;
        if (p == rank_) designated_[static_cast<std::size_t>(c)] = 1;
      }
  fluid_.set_held(held_);
}

bool ParticleNode::take_own_deposition() {
  // Resumed on the ranks that wrote the checkpoint: each rank's own, so that the fluid sums the
  // same partials as the run that wrote it did (bit for bit). Every rank or none. Collective.
  int ranks = 1;
  MPI_Comm_size(comm_, &ranks);
  std::vector<std::int64_t> cells;
  std::vector<double> values;
  int usable = 0;
  if (resumed_from_.second == ranks && std::filesystem::exists(own_deposition_file(resumed_from_.first, rank_))) {
    try {
      const CheckpointReader in(own_deposition_file(resumed_from_.first, rank_));
      in.get("cells", cells);
      in.get("values", values);
      usable = values.size() == static_cast<std::size_t>(Deposition::kStride) * cells.size() &&
               std::all_of(cells.begin(), cells.end(), [&](std::int64_t c) {
                 return c >= 0 && static_cast<std::size_t>(c) < held_.size() && held_[static_cast<std::size_t>(c)];
               });
    } catch (const std::exception&) {
      usable = 0;
    }
  }
  MPI_Allreduce(MPI_IN_PLACE, &usable, 1, MPI_INT, MPI_MIN, comm_);
  if (!usable) return false;
  std::fill_n(deposition_.data(), deposition_.size(), 0.0);
  for (std::size_t i = 0; i < cells.size(); ++i)
    std::copy_n(values.begin() + static_cast<std::ptrdiff_t>(Deposition::kStride * i), Deposition::kStride,
                deposition_.data() + Deposition::kStride * static_cast<std::size_t>(cells[i]));
  return true;
}

void ParticleNode::write_own_deposition(const std::string& path) const {
  std::vector<std::int64_t> cells;
  std::vector<double> values;
  const double* a = deposition_.data();
  for (std::size_t c = 0; c < held_.size(); ++c) {
    if (!held_[c]) continue;
    cells.push_back(static_cast<std::int64_t>(c));
    values.insert(values.end(), a + Deposition::kStride * c, a + Deposition::kStride * (c + 1));
  }
  CheckpointWriter out(path);
  out.put("cells", cells);
  out.put("values", values);
  out.close();
}

std::string ParticleNode::deposited_outside_held() const {
  const double* a = deposition_.data();
  for (std::size_t c = 0; c < held_.size(); ++c) {
    if (held_[c]) continue;
    for (int k = 0; k < Deposition::kStride; ++k)
      if (a[Deposition::kStride * c + static_cast<std::size_t>(k)] != 0)
        return fmt::format(
            "step {}: particle rank {} deposited into cell {}, which it does not take from the fluid (a particle "
            "reached farther than the exchange's margin of {:.3g} um)",
            step_, rank_, c, engine_->exchange_margin() * 1e6);
  }
  return {};
}

namespace {

// Sums `values` over the ranks into rank 0's; counted as a gather (common/traffic.h). Collective.
void sum_to_root(std::vector<double>& values, int rank, MPI_Comm comm) {
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  long size = static_cast<long>(values.size());
  MPI_Allreduce(MPI_IN_PLACE, &size, 1, MPI_LONG, MPI_MAX, comm);  // an optional field some rank lacks
  values.resize(static_cast<std::size_t>(size), 0.0);
  if (size == 0) return;
  if (rank == 0)
    MPI_Reduce(MPI_IN_PLACE, values.data(), static_cast<int>(size), MPI_DOUBLE, MPI_SUM, 0, comm);
  else
    MPI_Reduce(values.data(), nullptr, static_cast<int>(size), MPI_DOUBLE, MPI_SUM, 0, comm);
  const std::uint64_t bytes = sizeof(double) * static_cast<std::uint64_t>(size);
  if (ranks < 2) return;
  if (rank == 0)
    RankTraffic::received(bytes * static_cast<std::uint64_t>(ranks - 1));
  else
    RankTraffic::sent(bytes);
}

// The same with only the `designated` cells' values kept (per_cell values per cell): a field each
// rank holds for its own cells, whole on rank 0.
void sum_designated_to_root(std::vector<double>& values, int per_cell, const std::vector<char>& designated,
                            int rank, MPI_Comm comm) {
  const std::size_t k = static_cast<std::size_t>(per_cell);
  for (std::size_t c = 0; c < designated.size() && k * c < values.size(); ++c)
    if (!designated[c]) std::fill_n(values.begin() + static_cast<std::ptrdiff_t>(k * c), k, 0.0);
  sum_to_root(values, rank, comm);
}

}  // namespace

std::string ParticleNode::check(const fluid_state_t& fluid) const {
  return FluidSampler::check(fluid, locator_.n_cells(), mesh_hash_);
}

std::string ParticleNode::advance(const step_order_t& order, const fluid_state_t& fluid) {
  if (!(order.dt_s > 0) || !std::isfinite(order.dt_s))
    return fmt::format("step {} orders a coupling interval of {} s", order.envelope.step, order.dt_s);
  fluid_.set_state(fluid);
  if (!designated_.empty()) {
    // Each rank holds its own cells: the closures' u_max is the ranks' largest.
    double speed = fluid_.max_cell_speed();
    MPI_Allreduce(MPI_IN_PLACE, &speed, 1, MPI_DOUBLE, MPI_MAX, comm_);
    fluid_.set_max_cell_speed(speed);
  }
  const MomentumForm& form = momentum_form(scene_.momentum);
  if ((form.needs_pressure_gradient() && !fluid_.has_pressure_gradient()) ||
      (form.needs_viscous_force() && !fluid_.has_viscous_force()))
    return fmt::format(
        "step {}: the fluid state carries no {}, and coupling.momentum = \"{}\" needs it (is the fluid node '{}' "
        "of another build?)",
        order.envelope.step, fluid_.has_pressure_gradient() ? "viscous force" : "pressure gradient", form.name,
        scene_.run.fluid_command.empty() ? "built-in" : scene_.run.fluid_command);
  set_interval(order.dt_s);
  step_ = order.envelope.step;
  time_ = order.time_s;
  interval_ = order.dt_s;
  auto t0 = std::chrono::steady_clock::now();
  std::string error = engine_->run(step_, timing_.substeps, timing_.dt, fluid_);
  const double fluid_forces = engine_->take_fluid_force_seconds();
  phase_.dem += seconds_since(t0) - fluid_forces;
  phase_.fluid_forces += fluid_forces;
  if (!error.empty()) return error;
  t0 = std::chrono::steady_clock::now();
  engine_->deposit(deposition_);
  phase_.deposition += seconds_since(t0);
  if (!held_.empty())
    if (std::string outside = agree_on_error(deposited_outside_held(), comm_); !outside.empty()) return outside;
  warn_reynolds();
  return {};
}

particle_feedback_t ParticleNode::feedback() {
  const auto t0 = std::chrono::steady_clock::now();
  particle_feedback_t fb;
  // Partitioned, this rank's partial sums: its deposition is its own particles', and K u is taken
  // at the velocity of the cells it holds, which are all it deposits into.
  deposition_.finish(interval_, &fluid_, fb);
  phase_.deposition += seconds_since(t0);
  fb.mesh_hash = mesh_hash_;
  return fb;
}

void ParticleNode::write_output(long step, double time_s) {
  const auto t0 = std::chrono::steady_clock::now();
  ParticleSnapshot snap = engine_->snapshot(step, time_s);  // collective
  if (output_resumes_after_ >= 0) {
    std::vector<long> dropped;
    output_ = H5Output::resume(run_dir_ + "/particles.h5", output_resumes_after_, &dropped);
    if (!dropped.empty())
      spdlog::info("particles.h5: dropped the {} snapshot(s) of steps {}..{}, written after step {}", dropped.size(),
                   dropped.front(), dropped.back(), output_resumes_after_);
    output_resumes_after_ = -1;
  }
  if (output_) output_->write(snap);
  phase_.output += seconds_since(t0);
}

void ParticleNode::write_checkpoint() {
  const auto t0 = std::chrono::steady_clock::now();
  EngineState engine_state = engine_->checkpoint_state();  // collective
  std::string folder;
  if (rank_ == 0) folder = begin_checkpoint(run_dir_, step_, kRole);
  broadcast(folder, 0, comm_);  // and it exists before any rank writes into it
  write_engine_state(engine_state, engine_state_file(folder, rank_));
  const auto fluid = whole_fluid_fields();  // collective
  std::vector<double> deposition(deposition_.data(), deposition_.data() + deposition_.size());
  if (!held_.empty()) {
    write_own_deposition(own_deposition_file(folder, rank_));
    sum_to_root(deposition, rank_, comm_);  // each rank's own: the sum is the node's
  }
  if (rank_ == 0) write_node_checkpoint(folder + "/node.h5", fluid, deposition);
  MPI_Barrier(comm_);  // every rank's file is on disk
  if (rank_ == 0) commit_checkpoint(run_dir_, step_, kRole);
  checkpoint_written_ = step_;
  phase_.checkpoint += seconds_since(t0);
}

std::array<std::vector<double>, 4> ParticleNode::whole_fluid_fields() {
  std::array<std::vector<double>, 4> f = {fluid_.cell_velocities(), fluid_.cell_gradients(),
                                          fluid_.cell_pressure_gradients(), fluid_.cell_viscous_forces()};
  if (designated_.empty()) return f;
  const int per_cell[4] = {kVectorValues, kTensorValues, kVectorValues, kVectorValues};
  for (int i = 0; i < 4; ++i) sum_designated_to_root(f[i], per_cell[i], designated_, rank_, comm_);
  return f;
}

void ParticleNode::write_node_checkpoint(const std::string& path, const std::array<std::vector<double>, 4>& fluid,
                                         const std::vector<double>& deposition) {
  int ranks = 1;
  MPI_Comm_size(comm_, &ranks);
  CheckpointWriter out(path);
  out.put("format", kCheckpointFormat);
  out.put("ranks", std::int64_t{ranks});
  out.put("particles", std::int64_t{engine_->particle_count()});
  out.put("step", std::int64_t{step_});
  out.put("time_s", time_);
  out.put("interval_s", interval_);
  out.put("warned_reynolds", std::vector<std::int64_t>{warned_re_[kRbc], warned_re_[kPlatelet]});
  out.put_bytes("mesh_hash", mesh_hash_);
  out.put("deposition", deposition);
  out.put("fluid_velocity", fluid[0]);
  out.put("fluid_gradient", fluid[1]);
  out.put("fluid_pressure_gradient", fluid[2]);
  out.put("fluid_viscous_force", fluid[3]);
  out.put("z_cuts", engine_->z_cuts());
  out.close();
}

void ParticleNode::warn_reynolds() {
  // Once per run and species: the drag law is being used outside its fit.
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    if (!used_[sp] || warned_re_[sp]) continue;
    const double re = engine_->max_reynolds(sp), limit = engine_->forces(sp).drag().max_reynolds();
    if (!(re > limit)) continue;
    warned_re_[sp] = true;
    if (rank_ == 0)
      spdlog::warn(
          "{}: particle Reynolds number {:.3g} at coupling step {} exceeds {:.3g}, the range of the '{}' drag "
          "law (warned once per run)",
          sp == kRbc ? "rbc" : "platelet", re, step_, limit, engine_->forces(sp).drag().name());
  }
}

Diagnostics ParticleNode::diagnostics() {
  const auto t0 = std::chrono::steady_clock::now();
  const EngineDiagnostics d = engine_->diagnostics(fluid_.has_state() ? &fluid_ : nullptr);
  Vec3 f = deposition_.total_force(interval_);
  double solid_volume = deposition_.total_volume();
  if (!held_.empty()) {  // each rank's deposition is its own
    double sums[4] = {f.x(), f.y(), f.z(), solid_volume};
    MPI_Allreduce(MPI_IN_PLACE, sums, 4, MPI_DOUBLE, MPI_SUM, comm_);
    f = Vec3(sums[0], sums[1], sums[2]);
    solid_volume = sums[3];
  }
  const PhaseSeconds phase = std::exchange(phase_, PhaseSeconds{});
  Diagnostics out = {
      {"phase_particles_dem_s", phase.dem},
      {"phase_particles_fluid_forces_s", phase.fluid_forces},
      {"phase_particles_deposition_s", phase.deposition},
      {"phase_particles_output_s", phase.output},
      {"phase_particles_checkpoint_s", phase.checkpoint},
      {"phase_particles_diagnostics_s", seconds_since(t0)},
      {"particles", static_cast<double>(d.particles)},
      {"dem_substeps", static_cast<double>(timing_.substeps)},
      {"dem_dt_s", timing_.dt},
      {"total_force_x_N", f.x()},
      {"total_force_y_N", f.y()},
      {"total_force_z_N", f.z()},
      {"core_particle_axial_velocity_m_s", d.core_particle_axial_velocity},
      {"core_fluid_axial_velocity_m_s", d.core_fluid_axial_velocity},
      {"core_particles", static_cast<double>(d.core_particles)},
      {"max_overlap", d.max_overlap},
      {"max_particle_speed_m_s", d.max_speed},
      {"particles_outside_mesh", static_cast<double>(d.outside_mesh)},
      {"particles_in_wall_gap", static_cast<double>(d.in_wall_gap)},
      {"particles_lost", static_cast<double>(d.lost)},
      {"particles_in_vessel", static_cast<double>(d.in_vessel)},
      {"max_reynolds_rbc", d.max_reynolds[kRbc]},
      {"max_reynolds_platelet", d.max_reynolds[kPlatelet]},
      {"solid_volume_m3", solid_volume},
      {kTimeDiagnostic, time_},
  };
  if (engine_->open_ends()) {  // counts since the run started, per species and end
    // The cells whose centres are past an end, still in the DEM while they straddle it, and the
    // particles' volume inside the ends, which the deposited solid volume sums to.
    out.emplace_back("particles_straddling", static_cast<double>(d.straddling));
    out.emplace_back("particles_volume_inside_m3", d.volume_inside);
    const DemEngine::EndCounts c = engine_->end_counts();
    for (int sp = 0; sp < kSpeciesCount; ++sp) {
      if (!used_[sp]) continue;
      const std::string name = sp == kRbc ? "rbc" : "platelet";
      out.emplace_back(name + "_inserted", static_cast<double>(c.inserted[sp]));
      out.emplace_back(name + "_left_outlet", static_cast<double>(c.left_outlet[sp]));
      out.emplace_back(name + "_left_inlet", static_cast<double>(c.left_inlet[sp]));
      // Several outlets: each one's too, named as the fluid's outlet patches (outlet_1, ...).
      if (c.left_each_outlet.size() > 1)
        for (std::size_t o = 0; o < c.left_each_outlet.size(); ++o)
          out.emplace_back(fmt::format("{}_left_outlet_{}", name, o + 1),
                           static_cast<double>(c.left_each_outlet[o][sp]));
    }
  }
  // Before the first run: the particles at rest. None without drag (nothing bounds an interval).
  const double tau = engine_->ran() ? engine_->min_relaxation_time() : timing_.relaxation_time;
  if (std::isfinite(tau)) out.emplace_back(kRelaxationDiagnostic, tau);
  // The coordinator keeps a checkpoint only once both nodes have acknowledged it.
  if (const long k = std::exchange(checkpoint_written_, -1); k >= 0) out.emplace_back(kCheckpointDiagnostic, double(k));
  return out;
}

}  // namespace hemo::particles
