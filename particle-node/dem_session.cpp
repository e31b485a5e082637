// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_session.h"

#include <atom.h>
#include <error.h>
#include <fix.h>
#include <fix_property_atom.h>
#include <fmt/format.h>
#include <input.h>
#include <lammps.h>
#include <modify.h>
#include <neighbor.h>
#include <units.h>
#include <update.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <tuple>
#include <type_traits>

#include "dem_fix_styles.h"
#include "dem_fixes.h"
#include "dem_open_ends.h"
#include "dem_streaming_neighbours.h"
#include "dem_tracking.h"
#include "liggghts_errors.h"

namespace hemo::particles {

static_assert(std::is_same_v<LAMMPS_NS::bigint, std::int64_t>, "LIGGGHTS built with another bigint");

using namespace dem;

namespace {

constexpr long kLogRotateSteps = 1000;  // the LIGGGHTS run log keeps at most this many coupling steps
constexpr double kContactReach = 1.02;  // contact histories are cleared within this x the contact distance

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
      // The box split along the vessel (the streaming lists: across it, which the stream never
      // crosses; dem_streaming_neighbours.h).
      bookkeeping.streaming_neighbours ? "processors * * 1" : "processors 1 1 *",
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

// One file for all ranks: next to the log, or named by the first rank's process id.
std::string wall_file_for(const std::string& log_path, MPI_Comm comm) {
  namespace fs = std::filesystem;
  if (log_path != "none") return (fs::path(log_path).parent_path() / "vessel_wall.stl").string();
  long pid = ::getpid();
  MPI_Bcast(&pid, 1, MPI_LONG, 0, comm);
  return (fs::temp_directory_path() / fmt::format("hemocosim-vessel-wall-{}.stl", pid)).string();
}

// The fluid force while the neighbour lists are rebuilt: none (the forces are thrown away).
void no_force(void*, std::int64_t, int, int*, double**, double**) {}

// fix ID all hemo/fluid_force (dem_fixes.h): no array of its own, nothing to carry between ranks.
class FixFluidForce : public LAMMPS_NS::Fix {
 public:
  FixFluidForce(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) : Fix(lmp, narg, arg) {
    if (narg != 3) error->all(FLERR, "fix hemo/fluid_force takes no arguments");
  }
  int setmask() override { return LAMMPS_NS::FixConst::POST_FORCE; }
  void init() override {
    if (callback_ == nullptr) error->all(FLERR, "fix hemo/fluid_force: no callback set");
  }
  void setup(int vflag) override { post_force(vflag); }
  void post_force(int) override { callback_(target_, update->ntimestep, atom->nlocal, atom->tag, atom->x, atom->f); }

  FluidForceCallback callback_ = nullptr;
  void* target_ = nullptr;
};

}  // namespace

namespace dem {

LAMMPS_NS::Fix* create_fluid_force_fix(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) {
  return new FixFluidForce(lmp, narg, arg);
}

void set_fluid_force_callback(LAMMPS_NS::Fix* fix, FluidForceCallback callback, void* target) {
  auto* ours = dynamic_cast<FixFluidForce*>(fix);
  if (ours == nullptr) throw std::logic_error("the fluid-force fix is not hemo/fluid_force");
  ours->callback_ = callback;
  ours->target_ = target;
}

}  // namespace dem

LiggghtsSession::LiggghtsSession(const Contact& contact, const CellLocator& locator, const DemSpecies& species,
                                 const std::string& log_path, bool append_log, const DemBookkeeping& bookkeeping,
                                 MPI_Comm comm, std::optional<FeederLayout> feeder, double end_reach)
    : contact_(contact),
      locator_(locator),
      species_(species),
      log_path_(log_path),
      wall_file_(wall_file_for(log_path, comm)),
      bookkeeping_(bookkeeping),
      comm_(comm),
      feeder_(std::move(feeder)),
      end_reach_(end_reach) {
  std::vector<std::string> args = {"hemocosim-particles", "-screen", "none", "-log",
                                   append_log ? std::string("none") : log_path_};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  if (bookkeeping_.streaming_neighbours) {
    // Its frame streams with one vessel's Poiseuille flow, around one axis.
    if (feeder_)
      throw std::invalid_argument(
          "dem.neighbour_rebuild = \"streaming\" follows a periodic vessel's flow, not an "
          "open vessel and its feeder: use \"engine\"");
  }
  lmp_ = new LAMMPS_NS::LAMMPS(static_cast<int>(argv.size()), argv.data(), comm_);
  // Kept in memory, not shown: Error::one's message goes to the screen alone (liggghts_errors.h).
  // LIGGGHTS's mesh input also prints to its screen unchecked (a null screen crashes it).
  lmp_->screen = kept_liggghts_screen();
  atom_ = lmp_->atom;
  register_fix_styles(*lmp_);

  if (append_log && log_path_ != "none") command("log " + log_path_ + " append");  // a resumed run keeps the log
  for (const auto& line : base_settings(bookkeeping_)) command(line);
}

LiggghtsSession::~LiggghtsSession() {
  delete lmp_;
  if (log_path_ == "none") {  // the wall's STL went to the temporary directory: nobody keeps it
    std::error_code ignored;
    std::filesystem::remove(wall_file_, ignored);
  }
}

std::vector<WallTriangle> liggghts_wall_facets(const std::vector<WallTriangle>& facets, double d_min,
                                               double& least_angle_deg) {
  // LIGGGHTS refuses a facet with an angle below acos(0.9999995) = 0.0573 degrees whatever its
  // curvature (its hard limit, surface_mesh_I.h), naming its element_exclusion_list as the
  // remedy. Marching tetrahedra leave such needles where the surface grazes a grid point (one
  // of 0.0223 degrees in a bifurcation with 90- and 64-um daughters): their width, twice their
  // area over their longest edge, is nanometres, and a sphere of diameter d reaches w^2 / (4 d)
  // into the slot of width w a dropped one leaves: 0.0025 % of d at w = 1 % of d.
  const double least_deg = std::acos(0.9999995) * 180 / units::pi;
  const double narrow = 0.01 * d_min;
  std::vector<WallTriangle> kept;
  least_angle_deg = 180;
  for (const WallTriangle& t : facets) {
    double least = 180, longest = 0;
    for (int k = 0; k < 3; ++k) {
      const Vec3 a = t.vertex[(k + 1) % 3] - t.vertex[k], b = t.vertex[(k + 2) % 3] - t.vertex[k];
      least = std::min(least, std::atan2(a.cross(b).norm(), a.dot(b)) * 180 / units::pi);
      longest = std::max(longest, a.norm());
    }
    const double width = (t.vertex[1] - t.vertex[0]).cross(t.vertex[2] - t.vertex[0]).norm() / longest;
    if (!(least > least_deg) && width < narrow) continue;
    if (!(least > least_deg))
      throw std::invalid_argument(fmt::format(
          "the DEM's wall has a facet {:.3g} um wide with an angle of {:.3g} degrees, below the least LIGGGHTS takes "
          "({:.4f})",
          width / units::um, least, least_deg));
    least_angle_deg = std::min(least_angle_deg, least);
    kept.push_back(t);
  }
  return kept;
}

void LiggghtsSession::command(const std::string& line) { lmp_->input->one(line.c_str()); }

void LiggghtsSession::set_up_box(const std::array<bool, kSpeciesCount>& used, bool rotation, bool held_closures,
                                 ForceCallback callback, void* target) {
  callback_ = callback;
  callback_target_ = target;
  if (mesh_wall()) {
    const std::vector<WallTriangle> wall =
        liggghts_wall_facets(locator_.dem_wall(), species_.d_min, wall_min_angle_deg_);
    for (const WallTriangle& t : wall)
      for (const auto& v : t.vertex) {
        wall_lower_ = wall_lower_.cwiseMin(v);
        wall_upper_ = wall_upper_.cwiseMax(v);
      }
    write_wall_surface(wall);
  }
  define_box_and_contacts(assign_atom_types(used));
  // A pair's tangential history is cleared when it separates, not at the next neighbour-list
  // rebuild: LIGGGHTS clears it only for pairs within this factor x the contact distance (and
  // keeps the rest until a rebuild drops it), so with 1 a pair that separates and touches again
  // before the next rebuild would find its old shear spring, and results would depend on when
  // lists are rebuilt (a checkpoint rebuilds them). The band, 2 % of the contact distance
  // (53 nm for two platelets), is wider than a separating pair moves in a DEM step (~1 nm at the
  // impact velocity the step is made for), and adds ~5 % of pairs to the lists.
  lmp_->neighbor->register_contact_dist_factor(kContactReach);
  if (rotation)
    command(fmt::format("fix {} all property/atom hemoRotation vector yes no no 1 0 0 0 0 0 0", kRotationFix));
  if (held_closures)
    command(fmt::format("fix {} all property/atom hemoClosures vector no no no{}", kClosureFix, zeros(kClosureSlots)));
  find_fixes(rotation, held_closures);
}

int LiggghtsSession::assign_atom_types(const std::array<bool, kSpeciesCount>& used) {
  // LIGGGHTS wants granular atom types to start at 1 without holes: the species that have
  // particles take types 1, 2 (RBC before platelet), the wall's material the next one, the last.
  int n_types = 0;
  for (int sp = 0; sp < kSpeciesCount; ++sp) type_of_[sp] = used[sp] ? ++n_types : 0;
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (used[sp]) species_of_type_[type_of_[sp]] = sp;
  return ++n_types;
}

void LiggghtsSession::define_box_and_contacts(int n_types) {
  const double R = locator_.radius();
  const double z0 = locator_.z0();
  const double margin = 2 * species_.d_max;
  const double half_box = R + margin;
  // An open vessel's box holds its feeder beside it and is periodic with the feeder's length; a
  // surface vessel's holds its wall (and the feeder's, which reaches a radius about its axis).
  double x_lo = -half_box, y_lo = -half_box, y_hi = half_box;
  if (!locator_.axisymmetric()) {
    x_lo = wall_lower_.x() - margin;
    const double feeder_y = feeder_ ? feeder_->inlet_y : 0;
    y_lo = std::min(wall_lower_.y(), feeder_y - R) - margin;
    y_hi = std::max(wall_upper_.y(), feeder_y + R) + margin;
  }
  const double x_hi = feeder_ ? feeder_->axis_x + feeder_->radius + margin : half_box;
  const double period = feeder_ ? feeder_->period : locator_.length();
  if (feeder_) check_outlet_gap();
  command(fmt::format("region hemo_box block {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} units box", x_lo, x_hi,
                      y_lo, y_hi, z0, z0 + period));
  command(fmt::format("create_box {} hemo_box", n_types));
  // Thermo output is at each run's start and end, one run per coupling interval: of the step
  // alone, since nothing reads LIGGGHTS's energies, which cost 1 % of a DEM step to compute. The
  // style resets thermo_modify, so that follows it.
  command("thermo_style custom step");
  command("thermo_modify lost ignore");
  for (const auto& line : contact_model(n_types, bookkeeping_.streaming_neighbours)) command(line);
  command(fmt::format("fix {} all property/atom hemoImpulse vector no no no{}", kImpulseFix, zeros(kImpulseValues)));
  command(fmt::format("fix {} all {}", kTrackingFix, kTrackingStyle));
  // Defined after the wall: its post_force sees the contact forces and torques of the step.
  command(fmt::format("fix {} all {}", kFluidFix, kFluidForceStyle));
}

std::vector<std::string> LiggghtsSession::contact_model(int n_types, bool streaming_neighbours) const {
  std::vector<std::string> lines = {
      fmt::format("neighbor {:.17g} bin", bookkeeping_.skin_diameters * species_.d_max),
      "neigh_modify delay 0",
  };
  if (streaming_neighbours)
    for (const auto& line : streaming_neighbour_commands(locator_.radius(), bookkeeping_.streaming_wall_shear_rate))
      lines.push_back(line);
  const auto materials = material_fixes(contact_, n_types);
  lines.insert(lines.end(), materials.begin(), materials.end());
  lines.insert(lines.end(), {"pair_style gran model hertz tangential history", "pair_coeff * *", "timestep 1e-7"});
  const auto wall = wall_commands(n_types);
  lines.insert(lines.end(), wall.begin(), wall.end());
  lines.push_back("fix hemo_integrate all nve/sphere");
  return lines;
}

namespace {
// LIGGGHTS's default mesh curvature, acos(1 - EPSILON_CURVATURE) with EPSILON_CURVATURE = 1e-5.
const double kLiggghtsCurvatureDeg = std::acos(1 - 1e-5) * 180 / units::pi;
}  // namespace

std::vector<std::string> LiggghtsSession::wall_commands(int wall_type) const {
  auto cylinder = [&](const char* id, double radius, double axis_x, double axis_y) {
    return fmt::format(
        "fix {} all wall/gran model hertz tangential history primitive type {} zcylinder {:.17g} {:.17g} {:.17g}", id,
        wall_type, radius, axis_x, axis_y);
  };
  std::vector<std::string> lines;
  if (!mesh_wall()) {
    lines.push_back(cylinder(kWallFix, locator_.radius(), 0, 0));
  } else {
    // The mesh's z origin is the shape's; LIGGGHTS takes the facets as they are in the box.
    // LIGGGHTS refuses a facet with an angle below its `curvature` (acos(1 - 1e-5) = 0.256
    // degrees unless told; doc/fix_mesh_surface, src/surface_mesh_I.h): a surface vessel's
    // marching-tetrahedra wall has such slivers, so its curvature is then half the smallest angle
    // (LIGGGHTS's own error advises lowering it). It is also the angle below which two facets
    // count as one surface, so only nearly coplanar pairs change.
    const std::string curvature = wall_min_angle_deg_ < kLiggghtsCurvatureDeg
                                      ? fmt::format(" curvature {:.6g}", wall_min_angle_deg_ / 2)
                                      : std::string();
    lines.push_back(
        fmt::format("fix {} all mesh/surface file {} type {}{}", kWallMeshFix, wall_file_, wall_type, curvature));
    lines.push_back(fmt::format("fix {} all wall/gran model hertz tangential history mesh n_meshes 1 meshes {}",
                                kWallFix, kWallMeshFix));
  }
  // The feeder is straight: the primitive, whatever the vessel's wall. Each wall reaches the
  // cells of the other tube not at all (they are a radius or more away from it).
  if (feeder_) lines.push_back(cylinder(kFeederWallFix, feeder_->radius, feeder_->axis_x, feeder_->inlet_y));
  return lines;
}

void LiggghtsSession::check_outlet_gap() const {
  // Through the box's periodic z the vessel's top and its inlet are one period minus the vessel's
  // length apart. That gap holds the cells straddling the outlets (centres up to end_reach radii
  // past them) and those straddling the inlet (as far before it), and no pair may reach across
  // between them (dem_open_ends.h).
  const double straddling = end_reach_ * species_.d_max;  // both ends' share of the gap
  const double pair = species_.d_max * kContactReach + bookkeeping_.skin_diameters * species_.d_max;
  const double gap = feeder_->period - feeder_->vessel_length;
  if (!(gap > straddling + pair))
    throw std::invalid_argument(fmt::format(
        "the feeder is {:.4g} um longer than the open vessel: the cells straddling the outlet and the inlet "
        "({:.4g} um past each) and a pair's reach between them ({:.4g} um, with the neighbour skin) need more",
        gap / units::um, 0.5 * straddling / units::um, pair / units::um));
}

void LiggghtsSession::write_wall_surface(const std::vector<WallTriangle>& wall) const {
  // Written by the first rank, read by every rank's LIGGGHTS; the error, if any, agreed on.
  int rank = 0;
  MPI_Comm_rank(comm_, &rank);
  std::string error;
  if (rank == 0) try {
      write_stl(wall_file_, wall);
    } catch (const std::exception& e) {
      error = e.what();
    }
  int failed = error.empty() ? 0 : 1;
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, comm_);
  if (failed) throw std::runtime_error(error.empty() ? "the first rank could not write the vessel wall" : error);
}

std::vector<std::string> LiggghtsSession::bare_input(const std::string& data_file, double dt, long steps,
                                                     bool streaming_neighbours) const {
  std::vector<std::string> lines = base_settings(bookkeeping_);
  lines.push_back("read_data " + data_file);
  for (const auto& line : contact_model(atom_->ntypes, streaming_neighbours)) lines.push_back(line);
  lines.push_back(fmt::format("timestep {:.17g}", dt));
  lines.push_back(fmt::format("run {}", steps));
  return lines;
}

void LiggghtsSession::find_fixes(bool rotation, bool held_closures) {
  auto find = [&](const char* id) { return find_fix(id); };
  find_feeder_wall_history();
  fluid_fix_ = find(kFluidFix);
  set_fluid_force_callback(fluid_fix_, callback_, callback_target_);
  fixes_.impulse = find(kImpulseFix);
  fixes_.tracking = find(kTrackingFix);
  if (rotation) fixes_.rotation = find(kRotationFix);
  if (held_closures) fixes_.closures = find(kClosureFix);
  if (mesh_wall()) return;  // its history is the mesh's (dem_fixes.h)
  fixes_.wall_history = dynamic_cast<LAMMPS_NS::FixPropertyAtom*>(find(kWallHistoryFix));
  if (fixes_.wall_history == nullptr)
    throw std::runtime_error("LIGGGHTS's wall contact history is not a fix property/atom");
}

void LiggghtsSession::find_feeder_wall_history() {
  if (!feeder_) return;
  fixes_.feeder_wall_history = dynamic_cast<LAMMPS_NS::FixPropertyAtom*>(find_fix(kFeederWallHistoryFix));
  if (fixes_.feeder_wall_history == nullptr)
    throw std::runtime_error("LIGGGHTS's feeder wall contact history is not a fix property/atom");
}

LAMMPS_NS::Fix* LiggghtsSession::find_fix(const char* id) const {
  const int ifix = lmp_->modify->find_fix(id);
  if (ifix < 0) throw std::runtime_error(std::string("LIGGGHTS did not create the fix ") + id);
  return lmp_->modify->fix[ifix];
}

void LiggghtsSession::first_init(OpenEndsListener listener, const OpenEndsState* restored) {
  lmp_->init();
  if (!feeder_) return;
  // The inlet buffer: one largest cell diameter, so that a copy is wholly inside the vessel when
  // it is let go (dem_open_ends.h).
  dem::OpenEndsLayout layout{{},
                             feeder_->split_x,
                             feeder_->axis_x - feeder_->inlet_x,
                             species_.d_max,
                             end_reach_,
                             locator_.z0() + feeder_->vessel_length};
  for (const VesselWall::Opening& end : locator_.wall().outlets())
    layout.outlets.push_back({{end.centre.x(), end.centre.y(), locator_.z0() + end.centre.z()},
                              {end.normal.x(), end.normal.y(), end.normal.z()},
                              end.radius});
  command(open_ends_command(layout));
  fixes_.open_ends = static_cast<FixOpenEnds*>(find_fix(kOpenEndsFix));
  // A copy takes the source's orientation and held closures; its impulse starts at zero (the
  // source's interval impulse stays with the source, which goes on in the feeder). In the buffer
  // it replays the source's orientation and spin as it does its position and velocity: a platelet
  // copy held there against the vessel's wall by its replayed position spun up under the contact's
  // torque alone (1.3e5 rad/s at step 692 of scenes/bifurcation.toml) and stopped the run.
  std::vector<LAMMPS_NS::Fix*> copied, replayed;
  for (LAMMPS_NS::Fix* fix : {fixes_.rotation, fixes_.closures})
    if (fix != nullptr) copied.push_back(fix);
  if (fixes_.rotation != nullptr) replayed.push_back(fixes_.rotation);
  fixes_.open_ends->copy_values_of(copied, replayed);
  fixes_.open_ends->on_events(std::move(listener));
  if (restored)
    fixes_.open_ends->restore(*restored);
  else
    fixes_.open_ends->start();
}

long LiggghtsSession::particles() const {
  return particles_ + (fixes_.open_ends ? static_cast<long>(fixes_.open_ends->counts().net()) : 0);
}

long LiggghtsSession::straddling() const { return fixes_.open_ends ? fixes_.open_ends->straddling() : 0; }

long LiggghtsSession::tag_capacity() const {
  return fixes_.open_ends ? std::max<long>(particles_, fixes_.open_ends->tag_capacity()) : particles_;
}

std::vector<const PlacedParticle*> LiggghtsSession::create_particles(const std::vector<PlacedParticle>& particles) {
  // Tags follow a spatial order (axial slabs, then rows): neighbours in space are neighbours in
  // memory at the start, for LIGGGHTS and for our per-tag arrays alike.
  const double d_max = species_.d_max;
  std::vector<const PlacedParticle*> order;
  for (const auto& p : particles) order.push_back(&p);
  auto key = [&](const PlacedParticle* p) {
    return std::make_tuple(std::floor((p->position.z() - locator_.z0()) / d_max), std::floor(p->position.y() / d_max),
                           p->position.x());
  };
  std::stable_sort(order.begin(), order.end(), [&](auto* a, auto* b) { return key(a) < key(b); });
  if (bookkeeping_.shuffled_tags) std::shuffle(order.begin(), order.end(), std::mt19937(1));
  for (const PlacedParticle* p : order)
    command(fmt::format("create_atoms {} single {:.17g} {:.17g} {:.17g} units box", type_of_[p->species],
                        p->position.x(), p->position.y(), p->position.z()));
  for (int sp = 0; sp < kSpeciesCount; ++sp) {
    if (type_of_[sp] == 0) continue;
    // LIGGGHTS sets the mass from diameter and density: density = m / (pi d^3 / 6).
    const double diameter = species_.diameter[sp];
    const double density = species_.mass[sp] / (units::pi / 6 * std::pow(diameter, 3));
    command(fmt::format("set type {} diameter {:.17g} density {:.17g}", type_of_[sp], diameter, density));
  }
  particles_ = count_atoms();
  if (particles_ != static_cast<long>(particles.size()))
    throw std::runtime_error(
        fmt::format("LIGGGHTS created {} of {} particles (some outside the box?)", particles_, particles.size()));
  return order;
}

long LiggghtsSession::count_atoms() const { return static_cast<long>(atom_->natoms); }

long LiggghtsSession::local_particles() const { return atom_->nlocal; }

std::int64_t LiggghtsSession::dem_step() const { return lmp_->update->ntimestep; }

long LiggghtsSession::neighbour_builds() const { return static_cast<long>(lmp_->neighbor->ncalls); }

void LiggghtsSession::set_timestep(double dt) { command(fmt::format("timestep {:.17g}", dt)); }

void LiggghtsSession::run(int steps, bool pre) {
  command(fmt::format("run {} pre {} post no", steps, pre ? "yes" : "no"));
}

void LiggghtsSession::rotate_log(long coupling_step) {
  if (log_path_ != "none" && coupling_step % kLogRotateSteps == 1) command("log " + log_path_ + ".steps");
}

void LiggghtsSession::rebuild_neighbours() {
  if (!box_set_up()) throw std::logic_error("no particles to rebuild the neighbour lists of");
  const auto builds = lmp_->neighbor->ncalls;  // a set-up zeroes it; the overlap diagnostic reads it
  set_fluid_force_callback(fluid_fix_, &no_force, nullptr);
  command("run 0 pre yes post no");
  set_fluid_force_callback(fluid_fix_, callback_, callback_target_);
  lmp_->neighbor->ncalls = builds;
}

LiggghtsSession::Lost LiggghtsSession::find_lost(const std::vector<char>& expected) const {
  // LIGGGHTS drops an atom that leaves the box (thermo_modify lost ignore).
  Lost lost;
  const long have = static_cast<long>(sum_all(static_cast<double>(atom_->nlocal), comm_));
  lost.count = particles() + straddling() - have;
  if (lost.count == 0) return lost;
  std::vector<double> present(expected.size(), 0.0);
  for (int i = 0; i < atom_->nlocal; ++i)
    if (atom_->tag[i] < static_cast<long>(present.size())) present[atom_->tag[i]] = 1;
  MPI_Allreduce(MPI_IN_PLACE, present.data(), static_cast<int>(present.size()), MPI_DOUBLE, MPI_SUM, comm_);
  for (std::size_t t = 1; t < expected.size() && lost.first == 0; ++t)
    if (expected[t] && present[t] == 0) lost.first = static_cast<long>(t);
  return lost;
}

}  // namespace hemo::particles
