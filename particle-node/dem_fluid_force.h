// The fluid's force on the particles, evaluated every DEM step in the callback of our fix
// `hemo/fluid_force` (dem_fixes.h) and added to LIGGGHTS's forces, and the impulse it gave them,
// deposited into the fluid's cells after each run.
//
// Every DEM step the callback locates each particle's fluid cell, samples the plasma there,
// evaluates the species' closures (SpeciesForces), applies the drag with the exponential update
// (the contact forces LIGGGHTS computed for the step count as the step's other forces), and
// accumulates each particle's impulse for the feedback. Platelets' orientations take their step
// in the same pass (OrientationTracker). One pass over the atoms, unless the co-relaxed plasma
// answers the step's forces before they are applied (particle-node/README.md, "The force
// callback, one pass").
//
// Each particle's interval impulse (integral of F dt and of beta dt, and its last force for the
// next interval's first half kick) lives in a `fix property/atom`, so that it moves with its atom
// between ranks; its forces are weighted as Velocity Verlet applies them (DemEngine's header).
// After a run every rank deposits its own atoms (deposit()) and the per-cell arrays are summed
// over ranks; in a partitioned exchange each rank's stay its own (the fluid sums them), and only
// the solid volume, when the drag needs the void fraction or the plasma's mass, is summed over
// the ranks sharing each cell (CellHaloSum).
//
// time.closure_every_dem_steps = m > 1: the particle's cell, the plasma velocity there and the
// closures (beta, lift, torque) are evaluated at the first step of every run and every m steps
// after; they are kept per atom (another `fix property/atom`, which moves with its atom between
// ranks), and the steps in between apply the drag with them to the particle's current velocity
// and the step's contacts (the exponential update). They vary with the flow the particle sees,
// on the scale of the coupling interval; the contacts vary on the DEM step's scale. The bench
// suite `closure-interval` measures what m costs in accuracy.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_halo_sum.h"
#include "cell_locator.h"
#include "cell_plasma.h"
#include "dem_orientation.h"
#include "dem_problem.h"
#include "dem_session.h"
#include "dem_species.h"
#include "dem_tracking.h"
#include "deposition.h"
#include "engine_state.h"
#include "fluid_forces.h"
#include "fluid_sampler.h"

#include <mpi.h>
#include <momentum_forms.h>
#include <scene.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

namespace hemo::particles {

class DemFluidForce {
 public:
  // `scene`: the DEM's (dem_scene).
  DemFluidForce(const Scene& scene, const CellLocator& locator, const DemSpecies& species, LiggghtsSession& liggghts,
                ParticleTracking& tracking, OrientationTracker& orientation, FirstProblem& problems, MPI_Comm comm);
  DemFluidForce(const DemFluidForce&) = delete;
  DemFluidForce& operator=(const DemFluidForce&) = delete;

  // What our fluid-force fix calls (dem_fixes.h), with this object as the target: adds the
  // fluid force to `f`, LIGGGHTS's force on each atom.
  static void callback(void* self, std::int64_t ntimestep, int nlocal, int* tag, double** x, double** f);
  // Closure values kept per atom between evaluations (the fix for them is needed).
  bool holds_closures() const { return closure_every_ > 1 || update_ != Update::per_dem_step; }

  // One coupling step's DEM run.
  struct Run {
    long coupling_step = 0;       // labels errors
    std::int64_t first_step = 0;  // LIGGGHTS's step count as the run starts
    int steps = 0;
    double dt = 0;
    const FluidSampler* fluid = nullptr;
  };
  // Before the run. `carry`: the run goes on with the last force of the previous run (`pre no`),
  // whose second half kick belongs to this interval.
  // Throws std::invalid_argument when the fluid state lacks what the momentum form applies.
  void start_run(const Run& run, bool carry);
  // After it: throws std::runtime_error unless LIGGGHTS called the force `evaluations` times;
  // the run's largest Reynolds numbers, shortest relaxation time and particles outside the mesh
  // over all ranks (collective).
  void finish_run(long evaluations);

  // Clears `deposition`, deposits every particle's volume and the impulses of the last run at
  // its current position, and sums the per-cell accumulators over ranks (with a halo: leaves
  // them this rank's own). Collective.
  void deposit(Deposition& deposition);
  // The plasma mass of each cell, rho (V - solid volume), and its void fraction, from a
  // deposition summed over ranks.
  void take_plasma_mass(const Deposition& deposition);
  // The partitioned exchange: from now on deposit() keeps each rank's deposition its own and
  // sums the solid volume, where it is used, over `halo` only.
  void use_halo(std::unique_ptr<CellHaloSum> halo) { halo_ = std::move(halo); }
  const CellPlasmaRelaxation* cell_plasma() const { return cell_plasma_.get(); }

  // Of the last run, over all ranks.
  double max_reynolds(int species) const { return max_re_[species]; }
  double min_relaxation_time() const { return min_relaxation_time_; }  // NaN before the first run
  long outside_mesh() const { return outside_total_; }
  // Wall seconds spent in the callback since the last call.
  double take_seconds() { return std::exchange(seconds_, 0.0); }

  void save(EngineState& state) const;
  void restore(const EngineState& state);

  // Where a particle stands against an open vessel's ends (dem_open_ends.h): its centre in the
  // vessel's frame (wrapped; before the inlet, below it), how far it is past the end whose plane
  // it is furthest past or nearest to (m; < 0 inside; -inf in a periodic vessel and the feeder),
  // and where it is located and reads the plasma: its centre (as given), or, with the centre past an end,
  // the point of that end's plane just inside, beside it (the plasma past an end taken as the
  // end's own, as the outlet's zero gradient takes it).
  struct AtEnds {
    Vec3 centre = Vec3::Zero(), probe = Vec3::Zero();
    double beyond = -std::numeric_limits<double>::infinity();
  };
  // Its fluid cell there (or -1), with the locate cache of `tag`.
  int locate(int tag, const Vec3& x, double radius, AtEnds& at);
  // The share of a particle of `species` at x (unwrapped) inside the vessel's ends: 1 unless it
  // straddles one (SolidFractionModel::inside_share, the deposition's).
  double inside_share(const double* x, int species) const;
  // The particles' volume on the inside of the vessel's ends at the last deposit, this rank's
  // (what the deposited solid volume sums to).
  double inside_volume() const { return inside_volume_; }

 private:
  void on_force(std::int64_t ntimestep, int nlocal, const int* tag, double** x, double** f);
  // One force evaluation of a run, the same for every atom.
  struct ForceStep {
    std::int64_t ntimestep = 0;
    double duration = 0;            // how long its force acts in this run (half a step at the run's ends)
    bool last = false;              // the run's last: its force is kept for the next run's first half kick
    bool evaluate = false;          // the closures are evaluated (else the held ones apply)
    double** held = nullptr;        // the closures held per atom (null: none)
    OrientationTracker::Step spin;  // what the orientations take from it
  };
  // Every atom's fluid force and orientation kick, added to LIGGGHTS's force `f` and into the
  // impulses as it is found: what a step does unless a co-relaxed plasma answers in between.
  void one_pass(const ForceStep& step, int nlocal, const int* tag, double** x, double** f);
  // The two passes of a step with the co-relaxed plasma (or DemBookkeeping::two_pass_fluid_force):
  // atom i's fluid force (into step_forces_, its cell into step_cells_) and its orientation's
  // kick;
  void step_fluid_force(const ForceStep& step, int i, int tag, const double* x);
  // then the step's fluid forces, after the co-relaxed plasma answered them, added to LIGGGHTS's
  // force `f` and into the impulses.
  void apply_fluid_forces(const ForceStep& step, int nlocal, double** f);
  void note_not_finite(int tag, std::int64_t ntimestep);
  // One particle as the force callback sees it.
  struct Particle {
    int tag, species;
    Vec3 x, v;
    Vec3 axis;  // symmetry axis (platelets with orientation; +z otherwise)
  };
  // Locates the particle, samples the plasma there and evaluates its species' closures; returns
  // its cell, or -1 (problem noted) when it is outside the mesh or the force is not finite.
  int evaluate_fluid_force(const Particle& p, const Vec3& other, std::int64_t ntimestep, FluidForce& ff,
                           Vec3& plasma_velocity);
  // Keeps the closures per atom for the steps until the next evaluation (closure_every_ > 1),
  static void hold(const FluidForce& ff, const Vec3& plasma_velocity, int cell, double* held);
  // and applies them there: the drag on the current velocity, with this step's other forces.
  // (constant_drag: the drag held too, coupling.fluid_force = "held").
  static FluidForce held_fluid_force(const double* held, const Vec3& v, const Vec3& other, bool constant_drag);
  // The step's impulse (F dt, beta dt), and the last step's force for the next run's first kick.
  static void accumulate_impulse(double* acc, const Vec3& fluid_force, double beta, double duration, bool last);

  const Scene& scene_;
  const CellLocator& locator_;
  const DemSpecies& species_;
  LiggghtsSession& liggghts_;
  ParticleTracking& tracking_;
  OrientationTracker& orientation_;
  FirstProblem& problems_;
  MPI_Comm comm_;

  const int closure_every_ = scene_.time.closure_every_dem_steps;
  const bool two_pass_ = liggghts_.bookkeeping().two_pass_fluid_force;
  // Each species' orientation integrator where it is the splitting one (else null), for one
  // pass's orientation step with its drift and kick inlined.
  std::array<const SplittingIntegrator*, kSpeciesCount> splitting_{};
  // coupling.fluid_force: when the closures are evaluated and what is held until the next.
  using Update = FluidForceUpdate;
  const Update update_ = scene_.fluid_force;
  // coupling.momentum: F_p = -V_p grad P and F_v = V_p div tau on the particles (the fluid
  // states carry both per cell), whether they go to the plasma with the drag and lift, and the
  // drag over the void fraction (CFDEM's model B).
  const MomentumForm& form_ = momentum_form(scene_.momentum);
  // The plasma's stress on a particle of volume `volume` that sees `seen`, F_p + F_v (N).
  Vec3 stress_force(const FluidSampler::Seen& seen, double volume) const;
  // What the particle hands the plasma: drag and lift, with F_p + F_v where the form exchanges them.
  Vec3 exchanged(const FluidForce& ff) const { return form_.stress_exchanged ? Vec3(ff.total() + ff.stress) : ff.total(); }
  // Each cell's void fraction alpha at the last deposition (for beta / alpha; else empty).
  std::vector<double> void_fraction_;
  // The void fraction and the co-relaxed plasma's mass from each cell's solid volume (m^3).
  template <class SolidVolume>
  void take_solid_volume(const SolidVolume& solid_volume);
  std::unique_ptr<CellHaloSum> halo_;  // the partitioned exchange's (null: deposition summed over all ranks)
  // Each cell's plasma relaxing with its particles (coupling.implicit_drag = "co_relaxed"; else null).
  std::unique_ptr<CellPlasmaRelaxation> cell_plasma_;
  // co_relaxed: the scene's solid fraction model, for the share of a cell straddling an open end
  // inside it (the plasma the fluid's cells hold answers that share of its drag).
  std::unique_ptr<SolidFractionModel> end_shares_;

  // The run in progress.
  Run run_;
  double centreline_speed_ = 0;
  long evaluations_ = 0;
  long outside_ = 0;                                      // on this rank
  std::array<double, kSpeciesCount> max_slip_squared_{};  // (m/s)^2, on this rank
  std::array<double, kSpeciesCount> max_beta_{};          // N s/m, on this rank
  // This step's fluid force per local atom, and the cell it acts in (-1: none), between the
  // callback's evaluation and its application (the co-relaxation comes in between).
  std::vector<FluidForce> step_forces_;
  std::vector<int> step_cells_;
  double seconds_ = 0;  // wall seconds in the callback since take_seconds
  double inside_volume_ = 0;

  // The last run's, over all ranks.
  std::array<double, kSpeciesCount> max_re_{};
  double min_relaxation_time_ = std::numeric_limits<double>::quiet_NaN();
  long outside_total_ = 0;
};

}  // namespace hemo::particles
