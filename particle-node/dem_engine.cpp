// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_engine.h"

#include "agree.h"
#include "dem_balance.h"
#include "dem_timing.h"

#include <atom.h>
#include <comm.h>
#include <domain.h>
#include <fmt/format.h>
#include <lammps.h>
#include <neighbor.h>

#include "dem_fixes.h"
#include "dem_open_ends.h"

#include <solid_fraction_names.h>

#include <stdexcept>

namespace hemo::particles {

namespace {

// The bookkeeping with the scene's neighbour-rebuild policy (dem.neighbour_rebuild).
DemBookkeeping with_neighbour_policy(DemBookkeeping bookkeeping, const Scene& scene) {
  bookkeeping.streaming_neighbours = scene.neighbour_rebuild == NeighbourRebuild::streaming;
  bookkeeping.streaming_wall_shear_rate = wall_shear_rate(scene);
  return bookkeeping;
}

// An open vessel fed by a feeder: the layout its box holds (model/vessel_ends.h).
std::optional<FeederLayout> feeder_of(const Scene& scene) {
  if (!fed_by_feeder(scene.vessel)) return std::nullopt;
  return feeder_layout(scene);
}

}  // namespace

DemEngine::DemEngine(const Scene& scene, const CellLocator& locator, const std::string& log_path, MPI_Comm comm,
                     bool append_log, const DemBookkeeping& bookkeeping)
    : scene_(dem_scene(scene)),
      comm_(comm),
      species_(scene_, scene),
      liggghts_(scene_.contact, locator, species_, log_path, append_log, with_neighbour_policy(bookkeeping, scene_),
                comm, feeder_of(scene_), reach_per_radius(scene_.solid_fraction, scene_.kernel_width_diameters)),
      tracking_(locator),
      orientation_(liggghts_, problems_),
      fluid_force_(scene_, locator, species_, liggghts_, tracking_, orientation_, problems_, comm),
      checkpoint_(liggghts_, comm),
      output_(liggghts_, tracking_, species_, locator, comm) {}

void DemEngine::set_up_box(const std::array<bool, kSpeciesCount>& used) {
  liggghts_.set_up_box(used, species_.any_orientation, fluid_force_.holds_closures(), &DemFluidForce::callback,
                       &fluid_force_);
  dem::attach_tracking(liggghts_.fixes().tracking, &tracking_);
}

void DemEngine::create_particles(const std::vector<PlacedParticle>& particles) {
  if (liggghts_.box_set_up()) throw std::logic_error("particles were already created");
  if (particles.empty()) throw std::invalid_argument("no particles to simulate");
  std::array<bool, kSpeciesCount> used{};
  for (const auto& p : particles) {
    if (p.species < 0 || p.species >= kSpeciesCount || !species_.has(p.species))
      throw std::invalid_argument("a placed particle has a species the scene does not have");
    used[p.species] = true;
  }
  set_up_box(used);
  const auto order = liggghts_.create_particles(particles);
  tracking_.start(order);
  set_motion(order);
  // A periodic vessel's first set-up is its first run's, as it has always been.
  if (liggghts_.open()) liggghts_.first_init(open_ends_listener());
}

void DemEngine::set_motion(const std::vector<const PlacedParticle*>& order) {
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  double** spins = dem::per_atom(liggghts_.fixes().rotation);
  for (int i = 0; i < atom.nlocal; ++i) {
    const PlacedParticle& p = *order[static_cast<std::size_t>(atom.tag[i] - 1)];
    if (!p.motion) continue;
    for (int d = 0; d < 3; ++d) {
      atom.v[i][d] = p.motion->velocity[d];
      atom.omega[i][d] = p.motion->angular_velocity[d];
    }
    if (spins == nullptr) continue;
    for (int k = 0; k < 4; ++k) spins[i][k] = p.motion->orientation[k];
    for (int d = 0; d < 3; ++d) spins[i][4 + d] = p.motion->angular_momentum[d];
  }
}

LiggghtsSession::OpenEndsListener DemEngine::open_ends_listener() {
  return [this](const std::vector<dem::OpenEndsEvent>& events) { follow(events); };
}

void DemEngine::follow(const std::vector<dem::OpenEndsEvent>& events) {
  // Inside LIGGGHTS's pre_exchange, the same events on every rank; a copy is on its source's rank.
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  double** held = dem::per_atom(liggghts_.fixes().closures);
  for (const auto& e : events) {
    if (e.kind != dem::OpenEndsEvent::Kind::inserted) {
      tracking_.leave(e.tag);
      continue;
    }
    tracking_.enter(e.tag, e.z);
    if (held == nullptr) continue;
    // Held closures name the fluid cell they were evaluated in: the copy's is in the vessel (at
    // the inlet while it straddles it).
    for (int i = atom.nlocal - 1; i >= 0; --i)
      if (atom.tag[i] == e.tag) {
        DemFluidForce::AtEnds at;
        held[i][dem::kCell] = fluid_force_.locate(e.tag, Vec3(atom.x[i][0], atom.x[i][1], atom.x[i][2]),
                                                  atom.radius[i], at);
        break;
      }
  }
}

std::string DemEngine::run(long coupling_step, int substeps, double dt, const FluidSampler& fluid) {
  if (particle_count() == 0) return {};
  if (substeps < 1 || !(dt > 0)) throw std::invalid_argument("DEM run needs at least one step of positive length");
  problems_.clear();
  const bool new_dt = dt != dt_;
  dt_ = dt;
  // `pre no` skips re-initialisation between runs and keeps the forces of the last step, whose
  // second half kick comes first in this run. A new step size needs `pre yes` (integrator
  // factors), which recomputes the forces instead.
  const bool pre = first_run_ || new_dt;
  fluid_force_.start_run({coupling_step, liggghts_.dem_step(), substeps, dt, &fluid}, /*carry=*/!pre);
  if (new_dt) liggghts_.set_timestep(dt);
  liggghts_.rotate_log(coupling_step);
  liggghts_.run(substeps, pre);
  first_run_ = false;
  fluid_force_.finish_run(pre ? substeps + 1 : substeps);  // `pre yes` adds the setup evaluation
  std::string problem = problems_.agree(comm_);
  if (problem.empty()) problem = check_lost(coupling_step);
  return problem;
}

std::string DemEngine::check_lost(long coupling_step) {
  const LiggghtsSession::Lost lost = liggghts_.find_lost(tracking_.present());
  lost_ = lost.count;
  if (lost_ == 0) return {};
  return fmt::format(
      "particle {} was lost by LIGGGHTS (it left the DEM box) during coupling step {}; {} particle{} lost in all",
      lost.first, coupling_step, lost_, lost_ == 1 ? "" : "s");
}

DemEngine::EndCounts DemEngine::end_counts() const {
  EndCounts c;
  const auto* open = liggghts_.fixes().open_ends;
  if (open == nullptr) return c;
  const dem::OpenEndsCounts& counts = open->counts();
  c.left_each_outlet.resize(counts.outlets());
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    const int type = liggghts_.type_of(sp);
    if (type == 0) continue;
    const auto t = static_cast<std::size_t>(type);
    c.inserted[sp] = static_cast<long>(counts.inserted[t]);
    c.left_outlet[sp] = static_cast<long>(counts.left_outlets(t));
    c.left_inlet[sp] = static_cast<long>(counts.left_inlet[t]);
    for (std::size_t o = 0; o < counts.outlets(); ++o)
      c.left_each_outlet[o][sp] = static_cast<long>(counts.left_through(o, t));
  }
  return c;
}

std::array<double, 6> DemEngine::sub_domain() const {
  const LAMMPS_NS::Domain& d = *liggghts_.lammps().domain;
  return {d.sublo[0], d.sublo[1], d.sublo[2], d.subhi[0], d.subhi[1], d.subhi[2]};
}

bool DemEngine::balance(double threshold) {
  LAMMPS_NS::LAMMPS& lmp = liggghts_.lammps();
  if (lmp.comm->procgrid[2] < 2 || !(particle_imbalance() > threshold)) return false;
  // Every slab at least the ghost cut-off thick, as LAMMPS's `balance shift` keeps its cuts a
  // skin apart: no atom then skips a slab in one DEM step's exchange.
  const std::vector<double> cuts = particle_count_cuts(lmp, lmp.neighbor->cutneighmax, comm_);
  bool moved = false;
  for (std::size_t c = 0; c < cuts.size(); ++c) moved = moved || lmp.comm->zsplit[c + 1] != cuts[c];
  if (moved) checkpoint_.rebuild([&] { set_z_cuts(lmp, cuts); });
  return moved;
}

std::vector<double> DemEngine::z_cuts() const { return hemo::particles::z_cuts(liggghts_.lammps()); }

double DemEngine::particle_imbalance() const { return hemo::particles::particle_imbalance(liggghts_.lammps(), comm_); }

double DemEngine::exchange_margin() const { return 0.5 * species_.d_max + liggghts_.lammps().neighbor->skin; }

EngineDiagnostics DemEngine::diagnostics(const FluidSampler* fluid) {
  EngineDiagnostics d = output_.diagnostics(fluid);
  d.outside_mesh = fluid_force_.outside_mesh();
  for (int sp = 0; sp < kSpeciesCount; ++sp) d.max_reynolds[sp] = fluid_force_.max_reynolds(sp);
  d.lost = lost_;
  d.straddling = liggghts_.straddling();
  d.volume_inside = dem::sum_all(fluid_force_.inside_volume(), comm_);
  return d;
}

// ---- checkpoints ---------------------------------------------------------------------------

EngineState DemEngine::checkpoint_state() {
  EngineState state;
  checkpoint_.save(state);
  int ranks = 1;
  MPI_Comm_size(comm_, &ranks);
  state.ranks = ranks;
  state.dt = dt_;
  state.lost = lost_;
  fluid_force_.save(state);
  orientation_.save(state);
  tracking_.share_all(liggghts_.atom().nlocal, liggghts_.atom().tag, comm_);
  tracking_.save(state);
  return state;
}

void DemEngine::restore(const EngineState& s, const std::vector<double>& cuts) {
  if (liggghts_.box_set_up()) throw std::logic_error("particles were already created");
  agreed([&] { check_globals(s); }, comm_);
  set_up_box({s.type_of[kRbc] > 0, s.type_of[kPlatelet] > 0});
  if (!cuts.empty() && static_cast<int>(cuts.size()) == liggghts_.lammps().comm->procgrid[2] - 1)
    set_z_cuts(liggghts_.lammps(), cuts);
  checkpoint_.restore(s, open_ends_listener());
  dt_ = s.dt;
  first_run_ = false;  // the next run carries the last force over (`pre no`), as it would have
  lost_ = static_cast<long>(s.lost);
  fluid_force_.restore(s);
  orientation_.restore(s);
  tracking_.restore(s, liggghts_.tag_capacity());
}

void DemEngine::check_globals(const EngineState& s) const {
  if (s.ranks < 1) throw std::invalid_argument(fmt::format("the checkpoint was written on {} MPI ranks", s.ranks));
  expect_size(s.type_of, kSpeciesCount, "type_of");
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (s.type_of[sp] > 0 && !species_.has(sp))
      throw std::invalid_argument(
          fmt::format("the checkpoint has {} particles, the scene has none", sp == kRbc ? "red cell" : "platelet"));
  if (s.particles < 0 || s.created < 1 || s.tag_capacity < s.created || s.tag_capacity < s.particles)
    throw std::invalid_argument(fmt::format("the checkpoint has {} particles created, {} present on {} tags", s.created,
                                            s.particles, s.tag_capacity));
  expect_size(s.tracked, EngineState::kTrackedValues * static_cast<std::size_t>(s.tag_capacity + 1), "tracked");
  const bool open = liggghts_.open();
  for (const auto* counts : {&s.inserted, &s.left_outlet, &s.left_inlet})
    if (counts->empty() == open)
      throw std::invalid_argument(open ? "the checkpoint is of a periodic vessel, the scene's is open"
                                       : "the checkpoint is of an open vessel, the scene's is periodic");
  expect_size(s.max_reynolds, kSpeciesCount, "max_reynolds");
  expect_size(s.pending_orientations, 4 * s.pending_tags.size(), "pending_orientations");
}

}  // namespace hemo::particles
