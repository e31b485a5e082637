// The DEM engine: LIGGGHTS 3.8 in-process (Debian's libliggghts), driven by input commands.
//
// Particles are LIGGGHTS granular atoms (type 1 = RBC, 2 = platelet, 3 = the vessel wall's
// material; LIGGGHTS wants types from 1 without holes, so a scene without RBCs has platelets
// as type 1 and the wall as type 2) in SI units, Hertz contacts with tangential history, the vessel wall a
// `wall/gran` zcylinder primitive, the box periodic along z with the mesh's period. The fluid
// acts through `fix external pf/callback`: every DEM step our callback locates each particle's
// fluid cell, samples the plasma velocity there, applies the drag with the exponential
// integrator, and accumulates the force for the interval-mean feedback.
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
// Per-particle data lives in arrays indexed by the LIGGGHTS atom tag (atoms are reordered and
// migrate between ranks). Per-cell and per-particle arrays are summed over MPI ranks where a
// global view is needed; one rank is what runs today.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "closures/drag_closure.h"
#include "deposition.h"
#include "fluid_sampler.h"
#include "h5_output.h"
#include "placement.h"

#include <mpi.h>
#include <scene.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace LAMMPS_NS {
class LAMMPS;
}

namespace hemo::particles {

// What a coupling step's DEM tells about itself (the node's step diagnostics).
struct EngineDiagnostics {
  long particles = 0;
  long outside_mesh = 0;            // particles found in no fluid cell during the interval
  long in_wall_gap = 0;             // particles now between a flat wall face and the round wall
  double core_particle_axial_velocity = 0;  // mean v_z of particles with r < R/2 (m/s)
  double core_fluid_axial_velocity = 0;     // mean fluid u_z sampled at those particles (m/s)
  long core_particles = 0;
  double max_overlap = 0;           // largest overlap / smaller diameter (pairs and wall)
  double max_speed = 0;             // m/s
};

class DemEngine {
 public:
  // Starts LIGGGHTS for the scene; the box, materials, contact model, wall, integrator and
  // fluid callback are set up with the particles (create_particles). The LIGGGHTS log goes to `log_path` ("none": no log); the screen stays quiet.
  DemEngine(const Scene& scene, const CellLocator& locator, const std::string& log_path, MPI_Comm comm);
  ~DemEngine();
  DemEngine(const DemEngine&) = delete;
  DemEngine& operator=(const DemEngine&) = delete;

  // Creates the particles (the same list on every rank); tags are 1..N in list order.
  void create_particles(const std::vector<PlacedParticle>& particles);
  long particle_count() const { return n_particles_; }

  // Runs `substeps` DEM steps of `dt` in `fluid`, accumulating the drag applied into
  // `deposition` (not cleared here). `coupling_step` only labels errors. Returns an empty
  // string, or a one-line error (particle outside the mesh, non-finite state) naming the
  // particle and the step; the error is the same on every rank.
  std::string run(long coupling_step, int substeps, double dt, const FluidSampler& fluid, Deposition& deposition);

  // Deposits every particle's volume at its current position (clears volumes first) and sums
  // the per-cell accumulators over ranks. Collective.
  void finish_deposition(Deposition& deposition);

  // Diagnostics at the current state in `fluid` (collective).
  EngineDiagnostics diagnostics(const FluidSampler* fluid);

  // Every particle, sorted by id, z unwrapped (collective; complete on every rank).
  ParticleSnapshot snapshot(long step, double time_s);

  long dem_timestep() const;

 private:
  static void force_callback(void* self, std::int64_t ntimestep, int nlocal, int* tag, double** x, double** f);
  void on_force(std::int64_t ntimestep, int nlocal, const int* tag, double** x, double** f);
  void command(const std::string& line);
  void setup_box(const std::array<bool, kSpeciesCount>& used);
  double unwrap_z(int tag, double z);
  void sync_tracking();
  void note_problem(int tag, std::string what);
  // The fluid cell of a particle: exact, else the wall cell whose gap it is in, else -1.
  int cell_of(int tag, const Vec3& x, bool* in_wall_gap = nullptr);
  std::string agree_on_problem();

  const Scene scene_;
  const CellLocator* locator_;
  MPI_Comm comm_;
  std::string log_path_;
  LAMMPS_NS::LAMMPS* lmp_ = nullptr;
  std::array<std::unique_ptr<DragClosure>, kSpeciesCount> drag_;
  std::array<double, kSpeciesCount> volume_{};    // m^3, deposited as solid
  std::array<double, kSpeciesCount> diameter_{};  // m
  std::array<double, kSpeciesCount> mass_{};      // kg
  std::array<double, kSpeciesCount> beta_{};      // N s/m, for slip-independent closures
  std::array<double, kSpeciesCount> beta_eff_{};  // exponential-integrator coefficient; < 0: per particle
  long n_particles_ = 0;
  double d_max_ = 0;
  std::array<int, kSpeciesCount> type_of_{};      // LIGGGHTS atom type of a species (0: none)
  std::array<int, kSpeciesCount + 2> species_of_type_{};

  // Per tag (index = LIGGGHTS atom tag, 0 unused), packed for one cache line per particle.
  struct Tracked {
    LocateCache where;      // fluid cell
    double last_z = 0;      // z when last seen (as LIGGGHTS had it)
    double crossings = 0;   // periodic crossings along +z (integer valued)
  };
  std::vector<Tracked> tracked_;

  // State of the run in progress (read by the callback).
  const FluidSampler* fluid_ = nullptr;
  Deposition* deposition_ = nullptr;
  double dt_ = 0;
  std::int64_t run_start_ = 0;
  int run_steps_ = 0;
  long callbacks_ = 0;
  long outside_ = 0;
  long outside_total_ = 0;          // over all ranks, last run
  long coupling_step_ = 0;
  std::string first_problem_;      // on this rank
  int first_problem_tag_ = 0;
  bool first_run_ = true;
  struct Carry {
    int cell;
    double beta;
    Vec3 force;
  };
  std::vector<Carry> carry_;        // last forces of the previous run: their second half is still due
};

}  // namespace hemo::particles
