// SPDX-License-Identifier: GPL-3.0-or-later
#include "particle_node.h"

#include "placement.h"

#include <clock.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <utility>

namespace hemo::particles {

namespace {

void require_same(double scene_value, double mesh_value, const char* what) {
  if (std::abs(scene_value - mesh_value) > 1e-9 * std::abs(scene_value))
    throw std::runtime_error(fmt::format("the fluid mesh's {} is {:.6g} m, the scene's {:.6g} m", what, mesh_value,
                                         scene_value));
}

}  // namespace

ParticleNode::ParticleNode(const Scene& scene, const mesh_t& mesh, const std::string& run_dir, MPI_Comm comm)
    : scene_(scene),
      mesh_hash_(mesh.mesh_hash),
      comm_(comm),
      locator_(mesh),
      fluid_(locator_),
      deposition_(locator_, make_solid_fraction_model(scene.solid_fraction, locator_)),
      run_dir_(run_dir) {
  MPI_Comm_rank(comm_, &rank_);
  require_same(scene.vessel.diameter, mesh.vessel_diameter_m, "vessel diameter");
  require_same(scene.vessel.length, mesh.vessel_length_m, "vessel length");
  std::filesystem::create_directories(run_dir);

  const auto requests = placement_requests(scene);
  if (requests.empty()) throw std::runtime_error("the scene has no particles (no hematocrit, no platelets)");
  const auto placed = place_particles(locator_.radius(), locator_.length(), locator_.z0(), requests, scene.run.seed);
  engine_ = std::make_unique<DemEngine>(scene, locator_, run_dir + "/liggghts.log", comm_);
  engine_->create_particles(placed);
  set_interval(scene.time.coupling_interval);
  spdlog::info("particles: {} ({} RBC, {} platelets) in {} fluid cells (wall gap {:.3g} um); solid fraction "
               "'{}'",
               placed.size(), rbc_count(scene), platelet_count(scene), locator_.n_cells(), locator_.wall_gap() * 1e6,
               scene.solid_fraction);
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    used_[sp] = (sp == kRbc ? rbc_count(scene) : platelet_count(scene)) > 0;
    if (used_[sp])
      spdlog::info("{}: {}{}", sp == kRbc ? "rbc" : "platelet", engine_->forces(sp).describe(),
                   engine_->tracks_orientation(sp) ? ", orientation tracked (" +
                                                         (sp == kRbc ? scene.rbc : scene.platelet).orientation_integrator + ")"
                                                   : std::string());
  }

  engine_->deposit(deposition_);
  if (rank_ == 0) output_ = std::make_unique<H5Output>(run_dir + "/particles.h5");
  write_output(0, 0.0);
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

std::string ParticleNode::check(const fluid_state_t& fluid) const {
  return FluidSampler::check(fluid, locator_.n_cells(), mesh_hash_);
}

std::string ParticleNode::advance(const step_order_t& order, const fluid_state_t& fluid) {
  if (!(order.dt_s > 0) || !std::isfinite(order.dt_s))
    return fmt::format("step {} orders a coupling interval of {} s", order.envelope.step, order.dt_s);
  fluid_.set_state(fluid);
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
  warn_reynolds();
  return {};
}

particle_feedback_t ParticleNode::feedback() {
  const auto t0 = std::chrono::steady_clock::now();
  particle_feedback_t fb;
  deposition_.finish(interval_, &fluid_, fb);
  phase_.deposition += seconds_since(t0);
  fb.mesh_hash = mesh_hash_;
  return fb;
}

void ParticleNode::write_output(long step, double time_s) {
  const auto t0 = std::chrono::steady_clock::now();
  ParticleSnapshot snap = engine_->snapshot(step, time_s);  // collective
  if (output_) output_->write(snap);
  phase_.output += seconds_since(t0);
}

void ParticleNode::warn_reynolds() {
  // Once per run and species: the drag law is being used outside its fit.
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    if (!used_[sp] || warned_re_[sp]) continue;
    const double re = engine_->max_reynolds(sp), limit = engine_->forces(sp).drag().max_reynolds();
    if (!(re > limit)) continue;
    warned_re_[sp] = true;
    if (rank_ == 0)
      spdlog::warn("{}: particle Reynolds number {:.3g} at coupling step {} exceeds {:.3g}, the range of the '{}' drag "
                   "law (warned once per run)",
                   sp == kRbc ? "rbc" : "platelet", re, step_, limit, engine_->forces(sp).drag().name());
  }
}

Diagnostics ParticleNode::diagnostics() {
  const auto t0 = std::chrono::steady_clock::now();
  const EngineDiagnostics d = engine_->diagnostics(fluid_.has_state() ? &fluid_ : nullptr);
  const Vec3 f = deposition_.total_force(interval_);
  const PhaseSeconds phase = std::exchange(phase_, PhaseSeconds{});
  return {
      {"phase_particles_dem_s", phase.dem},
      {"phase_particles_fluid_forces_s", phase.fluid_forces},
      {"phase_particles_deposition_s", phase.deposition},
      {"phase_particles_output_s", phase.output},
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
      {"max_reynolds_rbc", d.max_reynolds[kRbc]},
      {"max_reynolds_platelet", d.max_reynolds[kPlatelet]},
      {"solid_volume_m3", deposition_.total_volume()},
  };
}

}  // namespace hemo::particles
