// A scene: one TOML file that says everything about a run (docs/model.md, docs/design.md "Scenes, outputs, analysis").
// Parsed once, into SI units, with every unknown key and impossible value refused.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "closure_names.h"  // the names a scene accepts per closure slot
#include "hosts.h"
#include "scene_choices.h"  // the options that pick one named behaviour

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hemo {

// The vessel: along z over [0, length), axisymmetric, its wall r = R(z) given by the shape
// (model/geometry.h, where each shape and its parameters are registered and described); periodic
// or open at its ends (model/vessel_ends.h).
struct Vessel {
  double diameter = 0;  // m, the nominal diameter 2 R0 (the whole length of a straight tube)
  double length = 0;    // m, along z (the period of a periodic vessel)
  std::string shape = "straight";
  std::string ends = "periodic";         // vessel_ends.h
  std::string inlet = "feeder";          // vessel_ends.h: what an open vessel's inlet takes in
  // s: a feeder developed before the run, as a periodic tube of its own for this long
  // (model/feeder_develop.h); 0: its cells start from the random placement.
  double feeder_develop = 0;
  double stenosis_area_reduction = 0.5;  // "stenosis": 1 - (R_throat / R0)^2
  double stenosis_length = 0;            // m, "stenosis": the constriction's axial length
  // "bifurcation" (bifurcation.h): the parent is the vessel (diameter, length); its daughters'
  // diameters (0: Murray's law), their length (0: the parent's) and the angle between them.
  double daughter_diameter[2] = {0, 0};                              // m
  double daughter_length = 0;                                        // m
  double bifurcation_angle = 60 * 3.14159265358979323846 / 180;      // rad
  // "imported": an ASCII STL as the scene gives it (relative: to the scene file's folder), that
  // path resolved, and which of its solids are the inlet and the outlets (names separated by
  // spaces; every other solid is wall).
  std::string surface_file = "";
  std::string surface_path = "";
  std::string surface_inlet = "inlet";
  std::string surface_outlets = "outlet_1 outlet_2";
  double radius() const { return diameter / 2; }
};

// O-grid of a disk extruded along z: a core_cells x core_cells square core and four blocks of
// core_cells x ring_cells around it; cross-section has core_cells^2 + 4 core_cells ring_cells cells.
// The paper's 1,536 cells: core 4, ring 3 (64 per section), axial 24.
// The wall is a polygon of n = 4 core_cells flat sides (docs/model.md §5 "Momentum balance"):
//   "circumscribed" (default)  sides tangent to the vessel circle: the cross-section's hydraulic
//                              diameter 4A/P is the vessel's d, so the streamwise balance
//                              τ_w = d ΔP / (4 l) holds on the mesh exactly;
//   "inscribed"                corners on the circle (as blockMesh's arcs put them): hydraulic
//                              diameter d cos(π/n), the wall carries cos(π/n) of d ΔP / (4 l).
struct MeshSpec {
  int core_cells = 4;
  int ring_cells = 3;
  int axial_cells = 24;
  WallPolygon wall_polygon = WallPolygon::circumscribed;
  // A surface vessel's mesh (snappyHexMesh, fluid-node/surface_mesh.h): the edge of its cubes, m
  // (0: the vessel's diameter / 12).
  double surface_cell_size = 0;
  int cells() const { return (core_cells * core_cells + 4 * core_cells * ring_cells) * axial_cells; }
  int wall_sides() const { return 4 * core_cells; }
  double wall_corner_radius() const;        // the wall polygon's corners, in vessel radii
  double hydraulic_diameter_ratio() const;  // 4A/P of the cross-section, in vessel diameters
};

// Why the fluid node cannot run on `ranks` MPI ranks: it splits whole cross-sections along the
// vessel axis (fluid-node/fluid_case.h, write_decomposition), so it needs as many axial cells at
// least. Nothing when it can.
std::optional<std::string> fluid_ranks_problem(const MeshSpec& mesh, int ranks);

struct Plasma {
  double density = 1025;      // kg/m^3
  double viscosity = 1.2e-3;  // Pa s (dynamic)
  // The suspension's own stress beyond the paper, suspension_viscosity.h ("none": the paper's).
  std::string suspension_viscosity = "none";
  double kinematic_viscosity() const { return viscosity / density; }
};

// The flow is driven by the mean pressure drop over the vessel length; a scene gives either it
// or the wall shear rate it produces, gamma_w = d dP / (4 mu l).
struct Driving {
  double pressure_drop = 0;    // Pa over the vessel length
  double wall_shear_rate = 0;  // 1/s
};

struct Species {
  std::string name;  // "rbc" or "platelet"
  bool present = false;
  double diameter = 0;        // m, placeholder sphere (contacts, Re, reference areas)
  double mass = 0;            // kg
  double volume = 0;          // m^3, the cell's own volume (deposited as solid fraction)
  double hematocrit = 0;      // rbc: volume fraction of the vessel
  double number_density = 0;  // platelet: per m^3 of blood
  // The DEM integrates this species with mass_scaling x its mass (0: time.mass_scaling's).
  // Platelets' contacts are the shortest (they set the DEM step): scaling them more than the red
  // cells lengthens the step without making the red cells heavier.
  double mass_scaling = 0;
  // Closures chosen by name (closure_names.h; particle-node/closures/; docs/model.md §2, §3). A scene file's defaults
  // are the paper's models: RBC "rbc_fit" + "rbc_lift", platelet "oblate" for all three
  // (spherical surrogate: drag "schiller_naumann", lift "shear_lift", torque "none"). A Species
  // built in code starts from plain Stokes drag without lift or torque.
  std::string drag = "stokes";
  std::string lift = "none";
  std::string torque = "none";
  // Platelet shape: the oblate spheroid's semi-axes (two equal a, c along the symmetry axis) and
  // how its orientation is integrated: "splitting" (second order, exact torque-free rotation)
  // or "euler" (docs/model.md §3.3 as printed, first order). Orientation is tracked only when a
  // closure needs it.
  double semi_axis_a = 0;  // m
  double semi_axis_c = 0;  // m
  OrientationMethod orientation_integrator = OrientationMethod::splitting;
};

struct Contact {
  double cell_youngs_modulus = 7.5e5;  // Pa
  double wall_youngs_modulus = 7.5e7;  // Pa
  double cell_poisson_ratio = 0.45;
  double wall_poisson_ratio = 0.18;
  double cell_cell_restitution = 0.9;
  double cell_wall_restitution = 0.85;
  double friction = 0.3;
};

struct Timing {
  double coupling_interval = 1e-5;  // s, one fluid step and N DEM substeps
  long coupling_steps = 10;
  int dem_substeps = 0;  // 0: derived from contact time and drag relaxation
  // The DEM step is at most contact_time / steps_per_contact and at most
  // relaxation_factor x the shortest drag relaxation time m / beta(0) (0: drag does not limit
  // it; the exponential drag update is stable at any step, particle-node/README.md measures
  // what a step above the relaxation time costs).
  double steps_per_contact = 10;
  double relaxation_factor = 0;
  // The plasma velocity at each particle and its closures (drag coefficient, lift, torque) are
  // evaluated every this many DEM steps; in between the drag acts with them on the particle's
  // current velocity (exponential update) every step. 1: every step.
  int closure_every_dem_steps = 1;
  // Mass scaling: the DEM integrates every particle with this many times its mass (the forces
  // stay the physical ones; the weight too). The Hertz contact time grows like s^(2/5), so the
  // DEM step does; what it costs is the particles' inertia: their drag relaxation time grows
  // like s and must stay far below the flow's time scale 1 / shear rate (docs/performance.md,
  // bench mass-scaling). 1: the physical masses.
  double mass_scaling = 1;  // every species' DEM mass factor unless the species sets its own
  // Adaptive coupling intervals (coordinator/coupling_clock.h): each interval the longest of
  // coupling_interval / 2^j that is at most this many times the shortest drag relaxation time
  // m / beta the particle node reports for its particles (at their DEM masses, current slip and
  // orientation). coupling_interval is then the longest interval, and coupling_steps x
  // coupling_interval the physical time. 0: fixed intervals.
  double coupling_relaxation_times = 0;
  bool adaptive_interval() const { return coupling_relaxation_times > 0; }
  double end_time() const { return static_cast<double>(coupling_steps) * coupling_interval; }  // s
};

// Body force on the particles (m g); docs/model.md §1: off by default.
struct Gravity {
  double x = 0, y = 0, z = 0;  // m/s^2
};

// The fluid node's linear solvers, PISO loop and steady-state skip (fluid-node/README.md;
// docs/fluid-verification.md measures the cost and the error of each setting).
struct FluidSolver {
  double pressure_tolerance = 1e-10;          // p: OpenFOAM's normalised residual, final corrector
  double pressure_relative_tolerance = 0.01;  // p: non-final correctors, fraction of the initial residual
  double velocity_tolerance = 1e-12;          // U predictor: normalised residual
  double velocity_relative_tolerance = 0;     // U predictor: fraction of its initial residual (0: none)
  // Whether PISO solves the momentum predictor before the correctors (OpenFOAM's
  // momentumPredictor); without it the first corrector starts from the old U.
  bool momentum_predictor = true;
  int min_correctors = 2;                     // PISO pressure correctors at least ...
  int max_correctors = 20;                    // ... and at most,
  double corrector_tolerance = 1e-3;          // more while a corrector's initial p residual is above
  // Extra solves of each corrector's pressure equation with its explicit non-orthogonal
  // correction updated (OpenFOAM's nNonOrthogonalCorrectors); 0: one solve, the correction
  // taken from the p before it.
  int non_orthogonal_correctors = 1;
  // p's linear solver: "GAMG" (algebraic multigrid, Gauss-Seidel smoother) or "PCG" (conjugate
  // gradients with DIC: more iterations, each far cheaper on small meshes).
  std::string pressure_solver = "GAMG";
  // One-way scenes (coupling.two_way = false): stop solving once max|U - U_old| / max|U| over a
  // step is below steady_tolerance, and publish the same state every later step.
  bool skip_when_steady = true;
  double steady_tolerance = 1e-8;
  // The fluid solved every this many coupling steps: one fluid step of solve_every intervals at
  // the end of each block of them, on the particles' momentum feedback (S, K) averaged over the
  // block's intervals and their latest solid fraction; the steps in between publish the last
  // solved state again (fluid-node/README.md, docs/performance.md measures the error). 1: every
  // step. Serial coupling scheme and fixed intervals only.
  int solve_every = 1;
};

struct Output {
  long every_steps = 10;               // particle snapshot every this many coupling steps (and last)
  long checkpoint_every_steps = 1000;  // both nodes' whole state every this many steps (0: never)
};

struct RunSettings {
  std::string name = "run";
  unsigned seed = 1;
  double node_timeout = 30;      // s without a heartbeat before a node is declared dead
  double startup_timeout = 120;  // s for both nodes to finish step 0
  double step_timeout = 3600;    // s for both nodes to finish any later step
  int max_restarts = 3;          // times a dead or silent node is restarted from the last checkpoint
  int fluid_ranks = 1;           // MPI ranks of the fluid node
  int particle_ranks = 1;        // MPI ranks of the particle node
  int drop_every = 0;            // fault injection: every process drops every n-th message it receives
  // Stability guards: the coordinator stops a run whose step exceeds them, naming the cause.
  double max_courant = 1.0;      // fluid Courant number
  double max_overlap = 0.25;     // deepest contact overlap / the smaller diameter (wall: the cell's)
  std::string fluid_command;     // empty: the built-in fluid node
  std::string particle_command;  // empty: the built-in particle node
  // The bus across hosts (docs/hosts.md): the multicast TTL (-1: 0 on one host, 1 with
  // [hosts]) and the seconds after every process joined the bus within which each must have
  // heard every other, or the run stops naming the pair that does not hear each other.
  int bus_ttl = -1;
  double bus_check_s = 10;
};

// Where the nodes run (docs/hosts.md): host lists as "a" or "b:2,c:2" (model/hosts.h); a node
// without hosts runs on the coordinator's host. A node with hosts runs on their ranks' sum.
struct HostPlacement {
  std::string fluid;
  std::string particles;
  // "ssh": started on its first host by launch_command; "local": here; "slurm": a job step of
  // the Slurm allocation the coordinator runs in (docs/slurm.md)
  Launcher launcher = Launcher::ssh;
  std::string launch_command = kDefaultLaunchCommand;
  // The bus: "multicast" (LCM UDP multicast) or "tcp" (LCM's tcpq provider through a relay the
  // coordinator runs for the run, where multicast is blocked; docs/hosts.md). The relay listens on
  // relay_address ("auto": the address of this host that the nodes' hosts are routed to, or
  // 127.0.0.1 without hosts) and relay_port (0: any free port).
  Transport transport = Transport::multicast;
  std::string relay_address = "auto";
  int relay_port = 0;
  bool any() const { return !fluid.empty() || !particles.empty(); }
  bool tcp() const { return transport == Transport::tcp; }
  // Whether the nodes may run on other hosts than the coordinator's (the bus must reach them).
  bool across_hosts() const { return any() || launcher == Launcher::slurm; }
};

// The bus beyond its transport (docs/hosts.md, "What an observer of the network learns"):
// messages are always signed with the run's secret; with `encrypt`, their payloads are also
// encrypted (AES-256-GCM with a key derived from the secret), for networks one does not trust.
struct BusSettings {
  bool encrypt = false;
};

struct Scene {
  std::string source_path;
  RunSettings run;
  HostPlacement hosts;
  BusSettings bus;
  Vessel vessel;
  MeshSpec mesh;
  Plasma plasma;
  Driving driving;
  Species rbc{"rbc"};
  Species platelet{"platelet"};
  Contact contact;
  Gravity gravity;
  Timing time;
  Output output;
  FluidSolver fluid;
  bool two_way = true;  // particles push back on the fluid
  // How a particle's volume, drag and coefficient are shared among fluid cells:
  // "sphere_overlap" (the cells its sphere overlaps, by the volume of the sphere beyond each
  // face of its cell), "centre_cell" (all to the cell holding its centre) or
  // "gaussian_kernel" (a Gaussian of full width at half maximum kernel_width_diameters particle
  // diameters, cut at three sigma, over the cells it reaches: particle-node/gaussian_kernel.h) for
  // fluid cells narrower than the particles.
  std::string solid_fraction = "sphere_overlap";
  double kernel_width_diameters = 1.0;
  // How a coupling step is shared between the nodes (docs/design.md "Lockstep coupling"): "serial"
  // (Gauss-Seidel: the fluid solves step k, then the particles move in it) or "parallel"
  // (Jacobi: both compute step k at once, the particles in the fluid of step k - 1).
  CouplingScheme coupling_scheme = CouplingScheme::serial;
  // The coefficient K with which the fluid treats the particles' drag implicitly (-K U, its
  // explicit part adjusted so that at the velocity the particles saw the fluid gets back exactly
  // their forces): "interval_response" (the derivative of the interval's drag on the cell's
  // particles with respect to that velocity, sum m (1 - exp(-B/m)) / (V dt), B the interval's
  // integral of beta dt: particles that follow the flow resist its change with their mass, not
  // with beta dt) or "instantaneous" (sum of beta / V: the particles' velocities held; for a
  // coupling interval much longer than their relaxation time it adds beta dt / V of inertia to
  // the fluid, ~27 times the plasma's in the calibration case), or "co_relaxed" (K = 0: the
  // particle node lets each cell's plasma answer its particles' drag at every DEM step,
  // particle-node/cell_plasma.h, and the fluid takes the interval's impulse explicitly).
  ImplicitDrag implicit_drag = ImplicitDrag::interval_response;
  // The implicit drag keeps back from the plasma K (U - U_seen) V of what the particles
  // exchanged in a step (U_seen the velocity their feedback was computed in); the particles only
  // take it up as they follow the flow in the next interval. true: the fluid hands it back in
  // its next step, so momentum is conserved over two steps and the particles resist the flow's
  // changes with their own mass, once; false: it is never handed back, and acts as inertia the
  // coupling adds to the plasma (the particles' mass again with "interval_response").
  bool return_held_back_momentum = true;

  // Numerical readings where the paper is silent (docs/validation.md measures what each moves).
  // Ours are the defaults; the others are CFDEMcoupling's documented behaviour, the machinery
  // the paper's authors used (scenes/calibration-cfdem.toml sets them all).
  // The plasma velocity a particle sees: "reconstructed" (u_c + G^T (x - x_c), exact for a
  // linear field) or "cell" (the value of the cell holding its centre: CFDEM's default, no
  // interpolation).
  FluidVelocity fluid_velocity = FluidVelocity::reconstructed;
  // When the fluid force and torque on a particle are evaluated:
  //   "per_dem_step"        the closures every time.closure_every_dem_steps DEM steps, the drag
  //                         on the particle's current velocity every step (exponential update);
  //   "held_implicit_drag"  CFDEM's couple/cfd/force/implicit with nve/cfd_cn: the closures once
  //                         per coupling interval, at its first DEM step; the drag coefficient
  //                         and plasma velocity held, the drag on the current velocity every
  //                         step; lift and torque held constant until the next exchange;
  //   "held"                CFDEM's explicit couple/cfd/force: drag, lift and torque evaluated
  //                         at the interval's first DEM step and applied as constants until the
  //                         next exchange (stable only while the interval is below twice the
  //                         particles' drag relaxation time at their DEM mass).
  FluidForceUpdate fluid_force = FluidForceUpdate::per_dem_step;
  // How the pressure (with the imposed mean drop) and the plasma's viscous stress are shared
  // between the plasma and the particles, and what the particles hand back: one of the forms in
  // momentum_forms.h ("paper": the paper's eq:momentum with F_p and F_v on the particles, not
  // exchanged; "cfdem_A", "cfdem_B", "cfdem_Bfull": CFDEMcoupling's model types;
  // "plasma_driven": the drop on the plasma's share only, for comparison). docs/model.md, section 1.
  std::string momentum = "paper";
  // The plasma velocity field the fluid node publishes: "cell_centre" (OpenFOAM's U after the
  // pressure correction, as CFDEM's solvers hand it over) or "face_flux" (U rebuilt from the
  // conservative face fluxes, fvc::reconstruct(phi), and its gradient: the velocity that carries
  // the plasma's volume; OpenFOAM's DPMFoam rebuilds its U from face quantities to the same end).
  // Where the particles' momentum sources vary from cell to cell the two differ: in the
  // calibration scene the cell-centre U converges on the axis while the fluxes diverge
  // (docs/validation.md, "what carries platelets to the axis").
  PlasmaVelocity plasma_velocity = PlasmaVelocity::face_flux;
  // When LIGGGHTS rebuilds the DEM's neighbour lists: "engine" (its own check: a particle moved
  // half the skin) or "streaming" (ours: the particles' motion relative to the Poiseuille flow of
  // the scene's driving, particle-node/dem_streaming_neighbours.h; one particle rank). The lists
  // are complete either way; docs/performance.md §1 measures the builds and the cost.
  NeighbourRebuild neighbour_rebuild = NeighbourRebuild::engine;
  // Whether the particle ranks' slabs follow their particles (dem.load_balance: "none", or
  // "particle_count": every `load_balance_every_steps` coupling steps, when the most loaded rank
  // holds more than `load_balance_threshold` times the mean, the cuts move so that each rank
  // holds as many; LAMMPS's `fix balance` Nfreq and thresh). The overlap map follows at that
  // step on both nodes (docs/notes/partitioned-exchange.md). Serial scheme only.
  LoadBalance load_balance = LoadBalance::none;
  long load_balance_every_steps = 10;
  double load_balance_threshold = 1.1;
};

// Whether the particle node moves its ranks' slabs at the end of coupling step `step`, the new
// slabs (and the overlap map of both nodes) holding from step + 1 on. The same on both nodes.
bool load_balance_after(const Scene& scene, long step);

// A numerical choice the paper leaves open, as a scene makes it, and whose reading it is
// ("ours", CFDEMcoupling's documented behaviour, the paper's Algorithm 1): `hemocosim check`
// lists them; docs/validation.md measures what each one moves.
struct NumericalReading {
  std::string key;      // e.g. "coupling.fluid_velocity"
  std::string value;    // as in the scene file
  std::string reading;  // whose, and what it means, in a few words
};
std::vector<NumericalReading> numerical_readings(const Scene& scene);

// One problem found in a scene, with where it is: one line "file:line: key = value: rule".
struct SceneProblem {
  std::string key;  // dotted key, e.g. "vessel.diameter_um"
  int line = 0;     // 0 when the key is missing
  std::string message;
  std::string value = {};  // the value as in the file (or the default it took), when there is one
  std::string str(const std::string& file) const;
};

// What a scene file may be before it is parsed (load_scene refuses anything else, naming why).
inline constexpr long kMaxSceneBytes = 1L << 20;  // a scene is a few kB
inline constexpr int kMaxSceneNesting = 64;       // tables, arrays and dotted-key levels
// Work a scene may plan (hemocosim check names the figure when it is more): DEM substeps per
// coupling interval, from the shortest Hertz contact time (a lower bound: the drag relaxation
// limit can only add), and particle-steps over the whole run.
inline constexpr double kMaxDemSubsteps = 1e5;
inline constexpr double kMaxParticleSteps = 1e14;

class SceneError : public std::runtime_error {
 public:
  SceneError(std::string file, std::vector<SceneProblem> problems);
  const std::vector<SceneProblem>& problems() const { return problems_; }

 private:
  std::vector<SceneProblem> problems_;
};

// How far load_scene goes.
enum class SceneCheck {
  // Types, ranges, geometry (the particles fit the vessel and are smaller than its cells) and
  // work: what every process that reads a scene needs.
  values,
  // Those, and the particles' initial placement (model/placement.h), run as the particle node
  // runs it at step 0: a scene whose particles cannot be placed is refused, naming the species'
  // key (rbc.hematocrit or platelet.number_density_per_ul). For `hemocosim check` and `run`,
  // before any node starts; the nodes themselves load with `values` (the particle node places
  // its particles itself, once).
  placement,
};

// Reads and validates a scene file; throws SceneError listing every problem found.
Scene load_scene(const std::string& path, SceneCheck check = SceneCheck::values);

// SceneCheck::placement places at most this many particles, five times the largest committed
// scene's (d = 200 um at Ht 15 %: 37,071 particles, 0.05 s). Placing costs what it costs the
// particle node at step 0: seconds where random addition nears its jamming (d = 200 um at
// Ht 30 %: 4 s; 186,000 particles at Ht 59 %: 7 s). A scene with more is left to the particle
// node, and `hemocosim check` says so.
inline constexpr long kMaxCheckedPlacement = 200'000;
bool placement_checked(const Scene& scene);  // whether SceneCheck::placement places its particles

// What a scene asks of the DEM, estimated as `hemocosim check` does (particle-node/dem_timing.h
// derives the actual step; this uses only the shortest Hertz contact time, so its substeps are
// a lower bound of the particle node's).
struct WorkEstimate {
  double particles = 0;       // expected number of particles in the vessel (and an open one's feeder)
  double contact_time = 0;    // s, shortest Hertz contact time at the DEM masses (inf: none)
  double substeps = 0;        // DEM steps per coupling interval
  double particle_steps = 0;  // particles x substeps x coupling steps
};
WorkEstimate estimate_work(const Scene& scene);

// The edge of a surface vessel's cubes (fluid-node/surface_mesh.h), m: mesh.surface_cell_size_um,
// or, when it is 0, the vessel's diameter / 12.
double surface_cell_size(const Scene& scene);

// Every key a scene may hold, with its default in the file's units, in reading order
// (`hemocosim check --keys`; docs/scenes.md is made from it). What a key accepts is recorded by
// the checks that validate it, as they run, so the listing cannot drift from the validation.
struct SceneKey {
  std::string key;
  std::string default_value;
  std::vector<std::string> names;  // an enumeration's names, as the validation offers them
  std::vector<std::string> rules;  // its range and checks, worded as their refusals
  // One line: one of "a", "b"; must be ...; must be ... ("" when anything of the type goes).
  std::string allowed() const;
  // Its row of the table `hemocosim check --keys` prints and docs/scenes.md holds:
  // | `key` | default | allowed |
  std::string table_row() const;
};
std::vector<SceneKey> scene_keys();

}  // namespace hemo
