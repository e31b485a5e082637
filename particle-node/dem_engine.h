// The DEM engine: LIGGGHTS run in-process for the particles, the fluid acting on them every DEM
// step, the impulse they got handed back to the fluid's cells, checkpoints between coupling
// steps. A façade over its pieces, each with its own header:
//
//   DemSpecies          dem_species.h      each species' closures, orientation integrator, size, mass, weight
//   LiggghtsSession     dem_session.h      the LAMMPS instance: box, contacts, wall, fixes, atoms, runs
//   DemFluidForce       dem_fluid_force.h  the fluid-force fix's callback: closures, drag, impulses; their deposition
//   OrientationTracker  dem_orientation.h  platelet orientations, advanced in that callback
//   ParticleTracking    dem_tracking.h     per tag: z unwrapped over periodic crossings, the locate cache
//   LiggghtsCheckpoint  dem_checkpoint.h   LIGGGHTS's state between runs, saved and recreated
//   DemOutput           dem_output.h       snapshots and diagnostics
//
// A coupling step is one LIGGGHTS `run` (run()). Velocity Verlet applies the force of a callback
// in two half kicks. The first `run N` (and any run after a change of step size) evaluates the
// forces at setup too; later runs use `pre no`, which keeps the last force of the previous run
// for their first half kick. So the impulse a coupling interval delivers is
//   dt (F_0 / 2 + F_1 + ... + F_{N-1} + F_N / 2),
// F_0 the setup force, or the previous interval's F_N (its second half), and the feedback
// weighs the forces the same way: over every interval the fluid receives exactly the impulse
// the particles got.
//
// A checkpoint (engine_state.h) holds what each piece carries from one run to the next; a
// restored engine goes on bit for bit as the checkpointed one would have (dem_checkpoint.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "cell_plasma.h"
#include "dem_checkpoint.h"
#include "dem_fluid_force.h"
#include "dem_orientation.h"
#include "dem_output.h"
#include "dem_problem.h"
#include "dem_session.h"
#include "dem_species.h"
#include "dem_tracking.h"
#include "deposition.h"
#include "engine_state.h"
#include "fluid_forces.h"
#include "fluid_sampler.h"
#include "h5_output.h"
#include "orientation.h"

#include <mpi.h>
#include <placement.h>
#include <scene.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace hemo::particles {

class DemEngine {
 public:
  // Starts LIGGGHTS for the scene (its dem.neighbour_rebuild joins `bookkeeping`); the box, materials, contact model,
  // wall, integrator and fluid callback are set up with the particles (create_particles or restore). The LIGGGHTS log
  // goes to `log_path` ("none": no log; appended to with `append_log`); the screen stays quiet.
  DemEngine(const Scene& scene, const CellLocator& locator, const std::string& log_path, MPI_Comm comm,
            bool append_log = false, const DemBookkeeping& bookkeeping = {});
  DemEngine(const DemEngine&) = delete;
  DemEngine& operator=(const DemEngine&) = delete;

  // Creates the particles (the same list on every rank); tags are 1..N in the spatial order
  // LiggghtsSession::create_particles gives them. A particle with a motion (a developed feeder's,
  // model/feeder_develop.h) starts with it; the others at rest, unturned.
  void create_particles(const std::vector<PlacedParticle>& particles);
  long particle_count() const { return liggghts_.particles(); }
  // An open vessel's counts since the run started, per species: inserted at the inlet, left
  // through the outlets (all, and each), left back through the inlet (all zero for a periodic
  // vessel).
  struct EndCounts {
    std::array<long, kSpeciesCount> inserted{}, left_outlet{}, left_inlet{};
    std::vector<std::array<long, kSpeciesCount>> left_each_outlet;
  };
  EndCounts end_counts() const;
  bool open_ends() const { return liggghts_.open(); }
  long local_particle_count() const { return liggghts_.local_particles(); }  // on this rank
  // This rank's sub-domain (lo x, y, z, then hi x, y, z; m), and how far beyond it a particle of
  // it may reach within a coupling interval: its radius, plus the neighbour skin (LIGGGHTS moves
  // an atom to the rank of its box once it has moved half a skin since the lists were built, and
  // checks that every DEM step). What the partitioned exchange takes cells for (overlap_map.h).
  std::array<double, 6> sub_domain() const;
  double exchange_margin() const;
  // dem.load_balance = "particle_count", between two runs: when the most loaded rank holds more
  // than `threshold` times the mean, moves the slabs' cuts so that each rank holds as many
  // particles (dem_balance.h) and rebuilds as a checkpoint does. Returns whether any rank's
  // sub-domain changed; the same on every rank. Collective.
  bool balance(double threshold);
  // The ranks' particle counts, the largest over the mean (collective).
  double particle_imbalance() const;

  // Checkpoint, between runs (collective): rebuilds the neighbour lists from the atoms (see
  // dem_checkpoint.h) and returns this rank's state.
  EngineState checkpoint_state();
  // Instead of create_particles: the particles and all the engine carries, as a checkpoint holds
  // them (every rank its own part, written on as many ranks). The next run goes on exactly as
  // the checkpointed engine's next run. Throws std::invalid_argument, on every rank alike, when
  // the state does not fit the scene.
  // `z_cuts`: the slabs' cuts of the run that wrote it (dem.load_balance; DemEngine::z_cuts),
  // used when they are as many as this run's slabs need, so that each rank holds the atoms it
  // held then.
  void restore(const EngineState& state, const std::vector<double>& z_cuts = {});
  // The particle ranks' slabs' cuts along z (fractions of the box) once a balance moved them;
  // else none (LIGGGHTS's equal slabs).
  std::vector<double> z_cuts() const;

  // Runs `substeps` DEM steps of `dt` in `fluid`, each particle accumulating the impulse the
  // fluid gave it. `coupling_step` only labels errors. Returns an empty string, or a one-line
  // error (particle outside the mesh, non-finite state or force, particle lost) naming the
  // particle and the step; the error is the same on every rank.
  std::string run(long coupling_step, int substeps, double dt, const FluidSampler& fluid);

  // LIGGGHTS's neighbour-list builds since the last run that set up anew (bench diagnostics).
  long neighbour_builds() const { return liggghts_.neighbour_builds(); }

  // Clears `deposition`, deposits every particle's volume and the impulses of the last run at
  // its current position, and sums the per-cell accumulators over ranks (after use_halo: this
  // rank's own). Collective.
  void deposit(Deposition& deposition) { fluid_force_.deposit(deposition); }
  // The plasma mass of each cell, rho (V - solid volume), from a deposition (deposit does this;
  // a resumed node from the checkpoint's): what a co-relaxed cell's plasma weighs.
  void take_plasma_mass(const Deposition& deposition) { fluid_force_.take_plasma_mass(deposition); }
  // The partitioned exchange: deposit() leaves each rank's deposition its own (DemFluidForce::use_halo).
  void use_halo(std::unique_ptr<CellHaloSum> halo) { fluid_force_.use_halo(std::move(halo)); }

  // Largest particle Reynolds number per species in the last run, and whether it exceeded the
  // drag law's range for the first time (the node warns once per run).
  double max_reynolds(int species) const { return fluid_force_.max_reynolds(species); }
  // The shortest drag relaxation time m / beta (DEM mass, beta at the particle's slip and
  // orientation) over the particles and the closures' evaluations of the last run; infinite
  // without drag, NaN before the first run.
  double min_relaxation_time() const { return fluid_force_.min_relaxation_time(); }
  bool ran() const { return !std::isnan(min_relaxation_time()); }  // since start-up or restore

  // Diagnostics at the current state in `fluid` (collective).
  EngineDiagnostics diagnostics(const FluidSampler* fluid);
  // Wall seconds spent in the fluid-force callback (location, sampling, closures) since the last call.
  double take_fluid_force_seconds() { return fluid_force_.take_seconds(); }

  // Every particle, sorted by id, z unwrapped (collective; complete on every rank); in an open
  // vessel, those in the vessel (not its feeder).
  ParticleSnapshot snapshot(long step, double time_s) { return output_.snapshot(step, time_s); }

  // Sets a particle's orientation from the next DEM step on (tests); its angular momentum is kept.
  void set_orientation(long id, const Quat& q) { orientation_.set(id, q); }
  bool tracks_orientation(int species) const { return species_.rotation[species] != nullptr; }
  const SpeciesForces& forces(int species) const { return *species_.forces[species]; }
  // A species the scene has (absent: no closures, no atom type, nothing per step).
  bool has_species(int species) const { return species_.has(species); }

  long dem_timestep() const { return static_cast<long>(liggghts_.dem_step()); }
  // Each cell's plasma as it relaxed with its particles in the last run (coupling.implicit_drag
  // = "co_relaxed"; else null).
  const CellPlasmaRelaxation* cell_plasma() const { return fluid_force_.cell_plasma(); }

  // The input of a bare LIGGGHTS run of this engine's particles, as `write_data` saved them in
  // `data_file`: the same settings, materials, contact model, wall and integrator, none of our
  // fixes (no fluid force: the particles coast), `steps` DEM steps of `dt`; with
  // `streaming_neighbours`, our neighbour-rebuild criterion instead of LIGGGHTS's. The floor under
  // the DEM's cost (hemocosim-dem-bench --floor).
  std::vector<std::string> bare_liggghts_input(const std::string& data_file, double dt, long steps,
                                               bool streaming_neighbours = false) const {
    return liggghts_.bare_input(data_file, dt, steps, streaming_neighbours);
  }

  // One LIGGGHTS input command (tests, diagnostics). A LIGGGHTS error in it ends the process.
  void liggghts(const std::string& line) { liggghts_.command(line); }
  // The LIGGGHTS instance itself (tests that read its neighbour lists).
  LAMMPS_NS::LAMMPS& lammps() const { return liggghts_.lammps(); }

 private:
  // The placed particles' motions onto this rank's atoms (tag k: order[k - 1]).
  void set_motion(const std::vector<const PlacedParticle*>& order);
  // The box and our fixes for the species `used`, the fluid force as LIGGGHTS's callback.
  void set_up_box(const std::array<bool, kSpeciesCount>& used);
  // Checks of a state to restore that need no box yet.
  void check_globals(const EngineState& state) const;
  // A particle LIGGGHTS lost: the error, "" when none.
  std::string check_lost(long coupling_step);
  // An open vessel's cells in and out (dem_open_ends.h): the tracking follows the tags.
  LiggghtsSession::OpenEndsListener open_ends_listener();
  void follow(const std::vector<dem::OpenEndsEvent>& events);

  // The pieces hold references to the ones declared before them.
  const Scene scene_;  // the DEM's (dem_scene)
  MPI_Comm comm_;
  const DemSpecies species_;
  LiggghtsSession liggghts_;
  ParticleTracking tracking_;
  FirstProblem problems_;  // of the run in progress
  OrientationTracker orientation_;
  DemFluidForce fluid_force_;
  LiggghtsCheckpoint checkpoint_;
  DemOutput output_;
  double dt_ = 0;          // of the last run
  bool first_run_ = true;  // since start-up (a restored engine goes on with `pre no`)
  long lost_ = 0;          // particles LIGGGHTS lost, as the last run ended
};

}  // namespace hemo::particles
