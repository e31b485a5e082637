// The DEM engine: LIGGGHTS 3.8 in-process (Debian's libliggghts), driven by input commands.
//
// Particles are LIGGGHTS granular atoms (type 1 = RBC, 2 = platelet, 3 = the vessel wall's
// material; LIGGGHTS wants types from 1 without holes, so a scene without RBCs has platelets
// as type 1 and the wall as type 2) in SI units, Hertz–Mindlin contacts with tangential history
// between all cells and with the wall (`pair gran` and a `wall/gran` zcylinder primitive), the
// box periodic along z with the mesh's period. The fluid acts through `fix external
// pf/callback`: every DEM step our callback locates each particle's fluid cell, samples the
// plasma there, evaluates the species' closures (SpeciesForces), applies the drag with the
// exponential update (the contact forces LIGGGHTS computed for the step count as the step's
// other forces), and accumulates each particle's impulse for the feedback.
//
// Platelets with an oblate closure carry an orientation: quaternion and angular momentum in a
// LIGGGHTS `fix property/atom` (so they migrate between ranks with their atom), advanced in
// the same callback (orientation.h: kick with the hydrodynamic + contact torque, drift), the
// resulting angular velocity written to LIGGGHTS's omega (contacts see it) and their torque
// zeroed so that nve/sphere leaves it alone. RBCs rotate as LIGGGHTS spheres.
//
// Velocity Verlet applies the force of a callback in two half kicks. The first `run N` (and any
// run after a change of step size) evaluates the forces at setup too; later runs use `pre no`,
// which keeps the last force of the previous run for their first half kick. So the impulse a
// coupling interval delivers is
//   dt (F_0 / 2 + F_1 + ... + F_{N-1} + F_N / 2),
// F_0 the setup force, or the previous interval's F_N (its second half), and the feedback
// weighs the forces the same way: over every interval the fluid receives exactly the impulse
// the particles got.
//
// Each particle's interval impulse (integral of F dt and of beta dt, and its last force for the
// next interval's first half kick) lives in a `fix property/atom` too; after a run every rank
// deposits its own atoms (deposit()) and the per-cell arrays are summed over ranks. The locate
// cache and z-unwrapping data are arrays indexed by the atom tag, synchronised after each run.
//
// time.closure_every_dem_steps = m > 1: the particle's cell, the plasma velocity there and the
// closures (beta, lift, torque) are evaluated at the first step of every run and every m steps
// after; they are kept per atom (another `fix property/atom`, which moves with its atom between
// ranks), and the steps in between apply the drag with
// them to the particle's current velocity and the step's contacts (the exponential update). They
// vary with the flow the particle sees, on the scale of the coupling interval; the contacts vary
// on the DEM step's scale. The bench suite `closure-interval` measures what m costs in accuracy.
//
// Checkpoints (engine_state.h): between two runs LIGGGHTS holds its atoms, their fixes' values,
// the contact histories and its neighbour lists. The lists cannot be saved, so a checkpoint first
// rebuilds them (and the ghost atoms, and the periodic wrap) from the atoms, as any `run` set-up
// does, keeping the forces, torques and fix values as they are; a restored engine recreates the
// same atoms in the same order on the same ranks and rebuilds the same way. Both then go on
// bit for bit alike. (A run that writes a checkpoint differs from one that does not by that
// rebuild: the same contacts summed in another order, round-off.)
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "cell_plasma.h"
#include "dem_timing.h"
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
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace LAMMPS_NS {
class LAMMPS;
class Fix;
class FixContactHistory;
class FixPropertyAtom;
}  // namespace LAMMPS_NS

namespace hemo::particles {

// What a coupling step's DEM tells about itself (the node's step diagnostics).
struct EngineDiagnostics {
  long particles = 0;
  long outside_mesh = 0;                    // particles found in no fluid cell during the interval
  long in_wall_gap = 0;                     // particles now between a flat wall face and the round wall
  double core_particle_axial_velocity = 0;  // mean v_z of particles with r < R/2 (m/s)
  double core_fluid_axial_velocity = 0;     // mean fluid u_z sampled at those particles (m/s)
  long core_particles = 0;
  double max_overlap = 0;           // largest overlap / smaller diameter (pairs and wall)
  double max_speed = 0;             // m/s
  double max_reynolds[2] = {0, 0};  // per species, over the last run
  long lost = 0;                    // particles LIGGGHTS no longer has
};

// LIGGGHTS's bookkeeping, which changes the cost of a DEM step and, through the order of the
// force sums, its results at round-off (then chaotically): fixed for runs, varied only by
// hemocosim-dem-bench to measure what the cost responds to (docs/performance.md §6).
struct DemBookkeeping {
  double skin_diameters = 0.25;  // neighbour skin, in largest particle diameters
  long sort_every_steps = 0;     // LIGGGHTS's spatial sort of the atoms (atom_modify sort); 0: never
  bool shuffled_tags = false;    // create the particles in random order (a run long after its start)
};

class DemEngine {
 public:
  // Starts LIGGGHTS for the scene; the box, materials, contact model, wall, integrator and
  // fluid callback are set up with the particles (create_particles or restore). The LIGGGHTS log
  // goes to `log_path` ("none": no log; appended to with `append_log`); the screen stays quiet.
  DemEngine(const Scene& scene, const CellLocator& locator, const std::string& log_path, MPI_Comm comm,
            bool append_log = false, const DemBookkeeping& bookkeeping = {});
  ~DemEngine();
  DemEngine(const DemEngine&) = delete;
  DemEngine& operator=(const DemEngine&) = delete;

  // Creates the particles (the same list on every rank); tags are 1..N in list order.
  void create_particles(const std::vector<PlacedParticle>& particles);
  long particle_count() const { return n_particles_; }
  long local_particle_count() const;  // on this rank

  // Checkpoint, between runs (collective): rebuilds the neighbour lists from the atoms (see the
  // header) and returns this rank's state.
  EngineState checkpoint_state();
  // Instead of create_particles: the particles and all the engine carries, as a checkpoint holds
  // them (every rank its own part, written on as many ranks). The next run goes on exactly as
  // the checkpointed engine's next run. Throws std::invalid_argument, on every rank alike, when
  // the state does not fit the scene.
  void restore(const EngineState& state);

  // Runs `substeps` DEM steps of `dt` in `fluid`, each particle accumulating the impulse the
  // fluid gave it. `coupling_step` only labels errors. Returns an empty string, or a one-line
  // error (particle outside the mesh, non-finite state or force, particle lost) naming the
  // particle and the step; the error is the same on every rank.
  std::string run(long coupling_step, int substeps, double dt, const FluidSampler& fluid);

  // LIGGGHTS's neighbour-list builds since the last run that set up anew (bench diagnostics).
  long neighbour_builds() const;

  // Clears `deposition`, deposits every particle's volume and the impulses of the last run at
  // its current position, and sums the per-cell accumulators over ranks. Collective.
  void deposit(Deposition& deposition);
  // The plasma mass of each cell, rho (V - solid volume), from a deposition (deposit does this;
  // a resumed node from the checkpoint's): what a co-relaxed cell's plasma weighs.
  void take_plasma_mass(const Deposition& deposition);

  // Largest particle Reynolds number per species in the last run, and whether it exceeded the
  // drag law's range for the first time (the node warns once per run).
  double max_reynolds(int species) const { return max_re_[species]; }
  // The shortest drag relaxation time m / beta (DEM mass, beta at the particle's slip and
  // orientation) over the particles and the closures' evaluations of the last run; infinite
  // without drag, NaN before the first run.
  double min_relaxation_time() const { return min_relaxation_time_; }
  bool ran() const { return !std::isnan(min_relaxation_time_); }  // since start-up or restore

  // Diagnostics at the current state in `fluid` (collective).
  EngineDiagnostics diagnostics(const FluidSampler* fluid);
  // Wall seconds spent in the fluid-force callback (location, sampling, closures) since the last call.
  double take_fluid_force_seconds() { return std::exchange(fluid_force_seconds_, 0.0); }

  // Every particle, sorted by id, z unwrapped (collective; complete on every rank).
  ParticleSnapshot snapshot(long step, double time_s);

  // Sets a particle's orientation from the next DEM step on (tests); its angular momentum is kept.
  void set_orientation(long id, const Quat& q);
  bool tracks_orientation(int species) const { return rotation_[species] != nullptr; }
  const SpeciesForces& forces(int species) const { return *forces_[species]; }
  // A species the scene has (absent: no closures, no atom type, nothing per step).
  bool has_species(int species) const { return forces_[species] != nullptr; }

  long dem_timestep() const;
  // Each cell's plasma as it relaxed with its particles in the last run (coupling.implicit_drag
  // = "co_relaxed"; else null).
  const CellPlasmaRelaxation* cell_plasma() const { return cell_plasma_.get(); }

  // The input of a bare LIGGGHTS run of this engine's particles, as `write_data` saved them in
  // `data_file`: the same settings, materials, contact model, wall and integrator, none of our
  // fixes (no fluid force: the particles coast), `steps` DEM steps of `dt`. The floor under the
  // DEM's cost (hemocosim-dem-bench --floor).
  std::vector<std::string> bare_liggghts_input(const std::string& data_file, double dt, long steps) const;

  // One LIGGGHTS input command (tests, diagnostics). A LIGGGHTS error in it ends the process.
  void liggghts(const std::string& line) { command(line); }

 private:
  // ---- set-up and stepping (dem_engine.cpp) ----
  // The species' closures, orientation integrators, sizes and masses; `physical` is the scene
  // before dem_scene scaled the masses (the weight stays physical).
  void set_up_species(const Scene& physical);
  // The LAMMPS instance and the settings that need no particles yet.
  void start_liggghts(bool append_log);
  void command(const std::string& line);
  // The box, materials, contacts, wall, integrator and our fixes, for the species `used`.
  void setup_box(const std::array<bool, kSpeciesCount>& used);
  int assign_atom_types(const std::array<bool, kSpeciesCount>& used);  // returns the number of types
  void define_box_and_contacts(int n_types);
  // The neighbour lists, materials, contact model, wall and integrator for n_types atom types
  // (the wall's material the last).
  std::vector<std::string> contact_model(int n_types) const;
  void find_fixes();
  double** per_atom(LAMMPS_NS::Fix* fix) const;
  void start_accumulators(bool carry);
  // The error of the particle with the smallest id over all ranks, after a run.
  void note_problem(int tag, std::string what);
  std::string agree_on_problem();
  std::string check_lost(long coupling_step);
  // Per-tag tracking: z unwrapped over periodic crossings, the locate cache.
  double unwrap_z(int tag, double z);
  void sync_tracking();
  // The fluid cell of a particle: exact, else the wall cell whose gap it is in, else -1.
  int cell_of(int tag, const Vec3& x, bool* in_wall_gap = nullptr);

  // ---- the fluid-force callback and the deposition (dem_fluid_force.cpp) ----
  static void force_callback(void* self, std::int64_t ntimestep, int nlocal, int* tag, double** x, double** f);
  void on_force(std::int64_t ntimestep, int nlocal, const int* tag, double** x, double** f);
  // One force evaluation of a run, the same for every atom.
  struct ForceStep {
    std::int64_t ntimestep = 0;
    double duration = 0;      // how long its force acts in this run (half a step at the run's ends)
    bool last = false;        // the run's last: its force is kept for the next run's first half kick
    bool evaluate = false;    // the closures are evaluated (else the held ones apply)
    bool advance = false;     // the orientations take this step's kick
    bool drift = false;       // and drift to it first
    double** held = nullptr;  // the closures held per atom (null: none)
  };
  // Atom i's fluid force (into step_forces_, its cell into step_cells_) and its orientation's
  // kick; `f` zeroed for now.
  void step_fluid_force(const ForceStep& step, int i, int tag, const double* x, double* f);
  // The step's fluid forces, after the co-relaxed plasma answered them, onto LIGGGHTS's `f` and
  // into the impulses.
  void apply_fluid_forces(const ForceStep& step, int nlocal, double** f);
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
  // Closure values kept per atom between evaluations.
  bool holds_closures() const { return closure_every_ > 1 || fluid_force_ != FluidForceUpdate::per_dem_step; }
  // The step's impulse (F dt, beta dt), and the last step's force for the next run's first kick.
  static void accumulate_impulse(double* acc, const Vec3& fluid_force, double beta, double duration, bool last);

  // ---- orientation (dem_orientation.cpp) ----
  struct Spin {
    Quat q = Quat::Identity();
    Vec3 l = Vec3::Zero();  // angular momentum, world frame
  };
  // Atom i's orientation at this step: as stored (or as set_orientation asked), drifted from the
  // step whose kick it took last.
  Spin spin_at_step(int i, int tag, const OrientationIntegrator& rotation, bool drift) const;
  // Kicked by the fluid and contact torques (once per step), checked, stored, and its angular
  // velocity handed to LIGGGHTS.
  void kick_and_store_spin(const ForceStep& step, int i, int tag, const OrientationIntegrator& rotation, Spin& spin,
                           const Vec3& fluid_torque);
  void finish_rotation_step(const ForceStep& step);

  // ---- output (dem_output.cpp) ----
  // The largest overlap of this rank's particles (pairs and wall), relative to the smaller diameter.
  double local_max_overlap() const;

  // ---- checkpoints (dem_checkpoint.cpp) ----
  // A LIGGGHTS set-up without dynamics (`run 0`): periodic wrap, atoms to their
  // ranks, ghosts, pair and wall neighbour lists, contact histories onto the new lists. Its
  // forces are thrown away (the callback does nothing meanwhile): the caller puts back what the
  // next run's first half kick needs.
  void rebuild_neighbours();
  // The per-atom values a rebuild must leave as they were: force, torque, impulse, rotation,
  // held closures, wall history (the fixes present), and the state's vectors in the same order.
  struct Column {
    double** values;
    int width;
  };
  std::vector<Column> carried_columns();
  int carried_width();
  template <class State>
  auto carried_fields(State& state) const;
  // Every particle's carried values by tag: gathered over the ranks, or from a checkpoint; and
  // back onto this rank's atoms.
  std::vector<double> gather_carried();
  std::vector<double> carried_by_tag(const EngineState& state);
  void scatter_carried(const std::vector<double>& by_tag);
  void save_globals(EngineState& state) const;
  void save_atoms(EngineState& state);
  void save_contact_history(EngineState& state) const;
  void save_tracking(EngineState& state) const;
  // Checks of a state to restore, agreed on by every rank (invalid_argument on all or none).
  void agreed(const std::function<void()>& check) const;
  void check_globals(const EngineState& state) const;
  void check_atoms(const EngineState& state);
  void create_atoms_as(const EngineState& state);
  void restore_contact_history(const EngineState& state);
  void restore_globals(const EngineState& state);
  LAMMPS_NS::FixContactHistory* contact_history() const;

  const Scene scene_;
  const CellLocator* locator_;
  MPI_Comm comm_;
  std::string log_path_;
  LAMMPS_NS::LAMMPS* lmp_ = nullptr;
  std::array<std::unique_ptr<SpeciesForces>, kSpeciesCount> forces_;
  std::array<std::unique_ptr<OrientationIntegrator>, kSpeciesCount> rotation_;  // null: a sphere
  std::array<double, kSpeciesCount> volume_{};                                  // m^3, deposited as solid
  std::array<double, kSpeciesCount> diameter_{};                                // m
  std::array<double, kSpeciesCount> mass_{};                            // kg, the DEM's (dem_mass_scaling x physical)
  std::array<Vec3, kSpeciesCount> weight_{Vec3::Zero(), Vec3::Zero()};  // N, physical mass x gravity
  std::array<double, kSpeciesCount> max_re_{};                          // largest particle Re of the last run
  std::array<double, kSpeciesCount> max_slip_squared_{};                // (m/s)^2, during the run (Re after it)
  std::array<double, kSpeciesCount> max_beta_{};                        // N s/m, during the run
  double min_relaxation_time_ = std::numeric_limits<double>::quiet_NaN();  // s, of the last run
  bool any_orientation_ = false;
  LAMMPS_NS::Fix* impulse_fix_ = nullptr;                   // per atom: F dt (3), beta dt, last F (3), last beta
  LAMMPS_NS::Fix* rotation_fix_ = nullptr;                  // per atom: q (w, x, y, z), L (3)
  LAMMPS_NS::Fix* closure_fix_ = nullptr;                   // per atom: beta, r, u (3), lift (3), torque (3)
  LAMMPS_NS::FixPropertyAtom* wall_history_fix_ = nullptr;  // LIGGGHTS's: the wall contacts' history
  bool rebuilding_ = false;                                 // rebuild_neighbours in progress: the callback does nothing
  const int closure_every_ = scene_.time.closure_every_dem_steps;
  // coupling.fluid_force: when the closures are evaluated and what is held until the next.
  enum class FluidForceUpdate { per_dem_step, held_implicit_drag, held };
  const FluidForceUpdate fluid_force_ = scene_.fluid_force == "held" ? FluidForceUpdate::held
                                        : scene_.fluid_force == "held_implicit_drag"
                                            ? FluidForceUpdate::held_implicit_drag
                                            : FluidForceUpdate::per_dem_step;
  // coupling.pressure_gradient_force: -V_p grad P on every particle (fluid states carry grad P).
  const bool pressure_force_ = scene_.pressure_gradient_force;
  // coupling.implicit_drag = "instantaneous": the deposited drag response is beta dt.
  const bool held_velocity_drag_ = scene_.implicit_drag == "instantaneous";
  // coupling.implicit_drag = "co_relaxed": each cell's plasma relaxing with its particles (else null).
  std::unique_ptr<CellPlasmaRelaxation> cell_plasma_;
  // This step's fluid force per local atom, and the cell it acts in (-1: none), between the
  // callback's evaluation and its application (the co-relaxation comes in between).
  std::vector<FluidForce> step_forces_;
  std::vector<int> step_cells_;
  std::int64_t last_rotation_step_ = -1;  // the DEM step whose kick was applied last
  double rotation_dt_ = 0;                // the step length of that kick
  long n_particles_ = 0;
  double d_max_ = 0;
  std::array<int, kSpeciesCount> type_of_{};  // LIGGGHTS atom type of a species (0: none)
  std::array<int, kSpeciesCount + 2> species_of_type_{};
  DemBookkeeping bookkeeping_;

  // Per tag (index = LIGGGHTS atom tag, 0 unused), packed for one cache line per particle.
  struct Tracked {
    LocateCache where;     // fluid cell
    double last_z = 0;     // z when last seen (as LIGGGHTS had it)
    double crossings = 0;  // periodic crossings along +z (integer valued)
  };
  std::vector<Tracked> tracked_;

  // State of the run in progress (read by the callback).
  const FluidSampler* fluid_ = nullptr;
  double centreline_speed_ = 0;
  double dt_ = 0;
  std::int64_t run_start_ = 0;
  int run_steps_ = 0;
  long callbacks_ = 0;
  double fluid_force_seconds_ = 0;
  long outside_ = 0;
  long outside_total_ = 0;  // over all ranks, last run
  long coupling_step_ = 0;
  std::string first_problem_;  // on this rank
  int first_problem_tag_ = 0;
  bool first_run_ = true;
  long lost_ = 0;
  std::map<int, Quat> pending_orientation_;  // set_orientation, applied at the next callback
};

}  // namespace hemo::particles
