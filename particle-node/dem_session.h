// LIGGGHTS 3.8 in-process (Debian's libliggghts), driven by input commands: the LAMMPS instance,
// its box, materials, contact model, wall and integrator, the particles as its atoms, the fixes
// the engine keeps its per-atom values in, and its runs.
//
// Particles are LIGGGHTS granular atoms (type 1 = RBC, 2 = platelet, 3 = the vessel wall's
// material; LIGGGHTS wants types from 1 without holes, so a scene without RBCs has platelets
// as type 1 and the wall as type 2) in SI units, Hertz–Mindlin contacts with tangential history
// between all cells and with the wall (`pair gran` and `fix wall/gran`: the zcylinder primitive
// for a straight tube; for any other shape a triangle mesh of the same VesselGeometry as the
// fluid mesh, `fix mesh/surface` from an STL the session writes), the box periodic along z with
// the mesh's period. The fluid acts through our fix `hemo/fluid_force` (dem_fixes.h), defined
// after the wall so that its callback sees each step's contact forces and torques (DemFluidForce). Values that must
// move between ranks with their atom live in `fix property/atom`s (dem_fixes.h). SPDX-License-Identifier:
// GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "dem_species.h"
#include "open_ends_events.h"
#include "placement.h"

#include <mpi.h>
#include <scene.h>
#include <vessel_ends.h>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace LAMMPS_NS {
class LAMMPS;
class Atom;
class Fix;
class FixPropertyAtom;
}  // namespace LAMMPS_NS

namespace hemo::particles::dem {
class FixOpenEnds;
}

namespace hemo::particles {

// The facets of a mesh wall that LIGGGHTS's fix mesh/surface takes: all but needles narrower than
// 1 % of the smallest particle diameter `d_min` with an angle below its hard limit (0.0573
// degrees); `least_angle_deg` gets the smallest angle kept. Throws std::invalid_argument naming a
// wider facet with such an angle.
std::vector<WallTriangle> liggghts_wall_facets(const std::vector<WallTriangle>& facets, double d_min,
                                               double& least_angle_deg);

// LIGGGHTS's bookkeeping, which changes the cost of a DEM step and, through the order of the
// force sums, its results at round-off (then chaotically): fixed for runs, varied only by
// hemocosim-dem-bench to measure what the cost responds to (docs/performance.md §6).
struct DemBookkeeping {
  double skin_diameters = 0.25;  // neighbour skin, in largest particle diameters
  long sort_every_steps = 0;     // LIGGGHTS's spatial sort of the atoms (atom_modify sort); 0: never
  bool shuffled_tags = false;    // create the particles in random order (a run long after its start)
  // When the neighbour lists are rebuilt (scene key dem.neighbour_rebuild): LIGGGHTS's own check,
  // or ours in the frame streaming with the Poiseuille flow of this wall shear rate (1/s) in the
  // vessel (dem_streaming_neighbours.h; one MPI rank).
  bool streaming_neighbours = false;
  double streaming_wall_shear_rate = 0;
  // The vessel's wall as a triangle mesh even where the shape has LIGGGHTS's cylinder primitive
  // (the straight tube): for hemocosim-dem-bench to measure what a mesh wall costs.
  bool mesh_wall = false;
  // The fluid-force callback in its two passes (every particle's force, then all applied) where
  // one pass does (no co-relaxed plasma answers between them): the same arithmetic in the order
  // the co-relaxed plasma needs, the reference the one pass is pinned to bit for bit
  // (DemEngine.OnePassCallbackIsTheTwoPassOneBitForBit) and measured against.
  bool two_pass_fluid_force = false;
};

class LiggghtsSession {
 public:
  // What the fluid-force fix calls every DEM step: (target, DEM step, this rank's atoms, their
  // tags and positions, LIGGGHTS's force on each, the contacts' so far, to add the fluid's to).
  using ForceCallback = void (*)(void* target, std::int64_t ntimestep, int nlocal, int* tag, double** x, double** f);

  // Our per-atom fixes (values in dem_fixes.h); null when the scene needs none.
  struct Fixes {
    LAMMPS_NS::Fix* impulse = nullptr;
    LAMMPS_NS::Fix* rotation = nullptr;                         // orientations tracked
    LAMMPS_NS::Fix* closures = nullptr;                         // closures held between evaluations
    LAMMPS_NS::FixPropertyAtom* wall_history = nullptr;         // LIGGGHTS's own: the wall contacts' history
                                                                // (a primitive wall's; null for a mesh wall)
    LAMMPS_NS::FixPropertyAtom* feeder_wall_history = nullptr;  // the feeder's primitive wall's (open ends)
    dem::FixOpenEnds* open_ends = nullptr;                      // open ends, after the first init
    LAMMPS_NS::Fix* tracking = nullptr;                         // carries crossing records (dem_tracking.h)
  };
  using OpenEndsListener = std::function<void(const std::vector<dem::OpenEndsEvent>&)>;

  // Starts LIGGGHTS with the settings that need no particles yet. Its log goes to `log_path`
  // ("none": no log; appended to with `append_log`); the screen stays quiet.
  // `feeder`: an open vessel's layout (model/vessel_ends.h): the box holds the vessel and its
  // feeder, each with its wall, and the ends are open (dem_open_ends.h); `end_reach`: how far
  // past an end, per radius, a cell's solid fraction still reaches the vessel's cells
  // (reach_per_radius, model/solid_fraction_names.h), so how long it straddles it.
  LiggghtsSession(const Contact& contact, const CellLocator& locator, const DemSpecies& species,
                  const std::string& log_path, bool append_log, const DemBookkeeping& bookkeeping, MPI_Comm comm,
                  std::optional<FeederLayout> feeder = std::nullopt, double end_reach = 1.0);
  ~LiggghtsSession();
  LiggghtsSession(const LiggghtsSession&) = delete;
  LiggghtsSession& operator=(const LiggghtsSession&) = delete;

  // The box, materials, contacts, wall, integrator and our fixes, for the species `used`, with
  // a rotation fix and a held-closure fix as asked; `callback(target, ...)` is the fluid force.
  void set_up_box(const std::array<bool, kSpeciesCount>& used, bool rotation, bool held_closures,
                  ForceCallback callback, void* target);
  // LIGGGHTS's first set-up of the atoms created (or recreated from a checkpoint), where pair gran
  // makes its contact history store; then, in an open vessel, the open ends, after that store
  // (dem_open_ends.h), with the counts and tag capacity of `restored` (none: a new run) and
  // `listener` told of every build's events.
  void first_init(OpenEndsListener listener, const dem::OpenEndsState* restored = nullptr);
  bool open() const { return feeder_.has_value(); }
  const std::optional<FeederLayout>& feeder() const { return feeder_; }
  bool box_set_up() const { return fluid_fix_ != nullptr; }
  // The particles as atoms (the same list on every rank); returns them in the order of their
  // tags, 1..N.
  std::vector<const PlacedParticle*> create_particles(const std::vector<PlacedParticle>& particles);
  // The atoms LIGGGHTS holds now, over all ranks.
  long count_atoms() const;
  // The particles created at the run's start (a restored run: as its checkpoint says).
  long created() const { return particles_; }
  void set_created(long created) { particles_ = created; }
  // Tags in use lie in 1..tag_capacity(): the particles created, or, with open ends, the largest
  // tag ever given (a tag freed by a cell that left is given again).
  long tag_capacity() const;

  void command(const std::string& line);
  void set_timestep(double dt);
  // `steps` DEM steps; `pre`: set up anew (and evaluate the forces at the set-up), else go on with
  // the last step's forces.
  void run(int steps, bool pre);
  // Restarts the run log every so many coupling steps: bounded size, recent errors kept.
  void rotate_log(long coupling_step);
  // A set-up without dynamics (`run 0`): periodic wrap, atoms to their ranks, ghosts, pair and
  // wall neighbour lists, contact histories onto the new lists. The fluid force is not called and
  // the forces computed are thrown away: the caller puts back what the next run's first half kick
  // needs. LIGGGHTS's list-build count is kept.
  void rebuild_neighbours();

  struct Lost {
    long count = 0;
    long first = 0;  // the smallest tag lost
  };
  // The particles LIGGGHTS dropped because they left the box: of the tags `expected` says are
  // present (index = tag), those no rank has (collective).
  Lost find_lost(const std::vector<char>& expected) const;

  LAMMPS_NS::LAMMPS& lammps() const { return *lmp_; }
  LAMMPS_NS::Atom& atom() const { return *atom_; }
  const Fixes& fixes() const { return fixes_; }
  const DemBookkeeping& bookkeeping() const { return bookkeeping_; }
  int type_of(int species) const { return type_of_[species]; }  // 0: none
  int species_of_type(int type) const { return species_of_type_[type]; }
  // The particles present: created, and with open ends inserted - left (the open ends' counts of
  // centres crossing them).
  long particles() const;
  // With open ends, the atoms whose centres are past an end, still in the DEM while they straddle
  // it (dem_open_ends.h); else 0.
  long straddling() const;
  long local_particles() const;
  std::int64_t dem_step() const;
  // Neighbour-list builds since the last run that set up anew.
  long neighbour_builds() const;

  // The input of a bare LIGGGHTS run of these particles, as `write_data` saved them in
  // `data_file`: the same settings, materials, contact model, wall and integrator, none of our
  // fixes but, with `streaming_neighbours`, the neighbour-rebuild one (its style registered with
  // dem::register_fix_styles), `steps` DEM steps of `dt`.
  std::vector<std::string> bare_input(const std::string& data_file, double dt, long steps,
                                      bool streaming_neighbours) const;

 private:
  int assign_atom_types(const std::array<bool, kSpeciesCount>& used);  // returns the number of types
  void define_box_and_contacts(int n_types);
  // The neighbour lists, materials, contact model, wall and integrator for n_types atom types
  // (the wall's material the last).
  std::vector<std::string> contact_model(int n_types, bool streaming_neighbours) const;
  // Whether the wall is a triangle mesh (fix mesh/surface), and the commands that define it.
  bool mesh_wall() const {
    return bookkeeping_.mesh_wall || !(locator_.axisymmetric() && locator_.axisymmetric()->uniform());
  }
  std::vector<std::string> wall_commands(int wall_type) const;
  void write_wall_surface(const std::vector<WallTriangle>& wall) const;
  void find_fixes(bool rotation, bool held_closures);
  void find_feeder_wall_history();
  LAMMPS_NS::Fix* find_fix(const char* id) const;
  // Refuses a feeder too short for the gap beyond the outlet.
  void check_outlet_gap() const;

  const Contact contact_;
  const CellLocator& locator_;
  // The box the DEM's mesh wall lies in (set_up_box), which a surface vessel's box holds.
  Vec3 wall_lower_ = Vec3::Constant(std::numeric_limits<double>::infinity()), wall_upper_ = -wall_lower_;
  double wall_min_angle_deg_ = 180;  // its facets' smallest angle
  const DemSpecies& species_;
  const std::string log_path_;
  const std::string wall_file_;  // the mesh wall's STL: next to the log (or in the temporary directory)
  const DemBookkeeping bookkeeping_;
  MPI_Comm comm_;
  const std::optional<FeederLayout> feeder_;
  const double end_reach_;
  LAMMPS_NS::LAMMPS* lmp_ = nullptr;
  LAMMPS_NS::Atom* atom_ = nullptr;  // LAMMPS keeps one for its lifetime
  LAMMPS_NS::Fix* fluid_fix_ = nullptr;
  ForceCallback callback_ = nullptr;
  void* callback_target_ = nullptr;
  Fixes fixes_;
  std::array<int, kSpeciesCount> type_of_{};
  std::array<int, kSpeciesCount + 2> species_of_type_{};
  long particles_ = 0;  // created at the run's start
};

}  // namespace hemo::particles
