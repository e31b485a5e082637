// The observables of docs/model.md §5, defined once, here, as pure functions over plain arrays.
// Nothing in this file reads files or prints: analyze.cpp feeds it snapshots and metrics.
//
// Geometry: the vessel is a straight tube of radius R along z through x = y = 0, periodic
// over the length L; z is unwrapped by the particle node, so it is wrapped here where needed.
// A vessel shape that narrows (model/geometry.h) adds the observables per axial station against
// its local radius (AxialAccumulator); the radial ones stay those of the nominal tube.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <geometry.h>
#include <vessel_wall.h>

#include <cstdint>
#include <string>
#include <vector>

namespace hemo::analysis {

inline constexpr std::int8_t kRbc = 0;  // species code in particles.h5
inline constexpr std::int8_t kPlatelet = 1;

struct Tube {
  double radius = 0;  // m, the nominal radius R0 (the radial profiles' and mu_app's)
  double length = 0;  // m, periodic along z
  // m^2, the vessel's volume over its length where its shape narrows (model/geometry.h); 0: pi R^2.
  double narrowed_section = 0;
  double cross_section() const;  // pi R0^2
  // The mean section: what a periodic vessel's volume flux and tube hematocrit are taken over.
  double mean_section() const { return narrowed_section > 0 ? narrowed_section : cross_section(); }
  double volume() const;  // mean_section() * length
};

// One particle snapshot as written by the particle node (3 doubles per particle).
struct Snapshot {
  long step = 0;
  double time_s = 0;
  std::vector<std::int64_t> id;
  std::vector<std::int8_t> species;
  std::vector<double> position;  // m, z unwrapped
  std::vector<double> velocity;  // m/s
  std::size_t size() const { return id.size(); }
};

// The cells of one species in cylindrical coordinates: what every observable below works on.
struct Cells {
  std::vector<std::int64_t> id;
  std::vector<double> r;      // m, distance of the centre from the axis
  std::vector<double> theta;  // rad, in (-pi, pi]
  std::vector<double> z;      // m, unwrapped
  std::vector<double> vz;     // m/s, axial velocity
  std::size_t size() const { return id.size(); }
};
Cells select_species(const Snapshot& s, std::int8_t species);

// ---- Radial number-density profile ---------------------------------------------------------

// `bins` equal bins in r/R over [0, 1]; edges in metres.
std::vector<double> radial_bin_edges(const Tube& tube, int bins);
// Volume of the annulus of bin b (pi (r_o^2 - r_i^2) L), m^3.
std::vector<double> annulus_volumes(const Tube& tube, int bins);

// Number of centres per annulus volume (1/m^3) of one snapshot. A centre at or beyond R
// (soft wall contact) is counted in the last bin so that the profile integrates to the count.
std::vector<double> radial_number_density(const std::vector<double>& r, const Tube& tube, int bins);

// Element-wise mean of equal-length profiles (the time average over a window). Empty input:
// empty result.
std::vector<double> average_profiles(const std::vector<std::vector<double>>& profiles);

// ---- RBC volume fraction profile (for the profile method of the CFL) -------------------------

// Volume of a sphere (radius a, centre at distance c from the axis) that lies inside the
// coaxial cylinder of radius rho. Integrates the exact area of the circle-circle overlap of
// each z-slice with Gauss-Legendre quadrature in z = a sin(t), split where the slices' overlap
// changes form: error below 1e-7 of the sphere's volume (checked against a 2e6-slice midpoint
// sum over 72 (c, rho) pairs; the unit tests check 1e-6 on the axis and a lattice count off it).
double sphere_volume_inside_cylinder(double a, double c, double rho);

// Volume fraction of cells per annulus, each cell a sphere of `diameter` whose volume is spread
// over the annuli it overlaps and scaled to `cell_volume` (V_RBC need not be the sphere's).
// Counting the cell's extent, not just its centre, is what makes the fraction fall to zero at
// the core's edge rather than half a cell inside it.
std::vector<double> radial_volume_fraction(const std::vector<double>& r, double diameter, double cell_volume,
                                           const Tube& tube, int bins);

// The same for many snapshots at once, at the cost of one: the window-mean fraction is linear in
// the centre distribution, so analyze() accumulates centres in a fine histogram (`fine_bins`
// over [0, R], centres beyond R in the last) and spreads it once, each fine bin's mean count as
// cells at its middle. With fine_bins = 4096 a centre moves by at most R/8192 (6 nm at R = 50 um).
std::vector<double> centre_histogram(const std::vector<double>& r, const Tube& tube, int fine_bins);
std::vector<double> radial_volume_fraction_from_histogram(const std::vector<double>& counts, double diameter,
                                                          double cell_volume, const Tube& tube, int bins);

// ---- Cell-free layer thickness ---------------------------------------------------------------

// Stations: axial slices x angular sectors.
struct Stations {
  int axial = 16;
  int sectors = 24;
  int count() const { return axial * sectors; }
};
// RBCs per CFL station (docs/model.md §5): enough for a station to have an edge in most snapshots,
// few enough that a stray cell moves one station's edge only.
inline constexpr double kRbcsPerStation = 20;
// About `per_station` RBCs per station, with the shape of the calibration case's
// 16 x 24 stations kept for other vessels: sectors / slices = 18 R / L, i.e. a station's arc
// at the wall is about a third of its axial length whatever the vessel.
Stations default_stations(double mean_rbc_count, const Tube& tube, double per_station = kRbcsPerStation);

// Outer edge of the RBC core at every occupied station of one snapshot: max(r_i + d_RBC/2)
// over the station's RBCs. Empty stations give no edge and are counted.
struct StationEdges {
  std::vector<double> edge;  // m, one per occupied station
  int empty = 0;
};
StationEdges rbc_core_edges(const Cells& rbc, double rbc_diameter, const Tube& tube, const Stations& stations);

struct CflThickness {
  std::string method;             // "edge" or "profile"
  double thickness = 0;           // delta, m (NaN when undefined)
  double edge_mean = 0;           // m: <edge> (edge method) or the crossing radius (profile method)
  double edge_std = 0;            // m, spread of the station edges (edge method)
  long samples = 0;               // (station, time) pairs averaged (edge method)
  long empty_samples = 0;         // (station, time) pairs skipped for having no RBC
  double core_mean_fraction = 0;  // profile method: mean RBC volume fraction of the core
};

// Edge method: delta = R - <edge> over all occupied stations and snapshots given.
CflThickness cfl_thickness_edge(const std::vector<StationEdges>& per_snapshot, const Tube& tube);

// Profile method: the core mean is the volume-weighted mean fraction over r < core_radius_fraction R;
// the edge is the outermost radius where the (linearly interpolated between bin centres) fraction
// is still `threshold` x core mean; delta = R - edge.
CflThickness cfl_thickness_profile(const std::vector<double>& volume_fraction, const Tube& tube, double threshold = 0.1,
                                   double core_radius_fraction = 0.5);

// ---- Radial mean squared displacement and diffusivity ----------------------------------------

struct MsdPoint {
  double lag_s = 0;   // t - t_ref
  double msd_m2 = 0;  // <(r_i(t) - r_i(t_ref))^2>
  long matched = 0;   // platelets present in both snapshots (matched by id)
};
// Cells absent from either snapshot are left out; no match gives msd NaN.
MsdPoint radial_msd(const Cells& reference, double t_reference, const Cells& now, double t_now);
// The cells with each radius taken relative to the local wall, in metres of the nominal tube:
// r R0 / R(z). A particle that follows a streamline through a narrowing keeps it, so a radial MSD
// of these counts dispersion, not the streamlines' convergence. Unchanged where R is uniform.
Cells radii_at_nominal_wall(const Cells& cells, const VesselGeometry& vessel);

struct DiffusionFit {
  double diffusivity = 0;  // D, m^2/s (NaN with no point in the window)
  double t_fit = 0;        // s, the window asked for: [0, t_fit]
  double window_end = 0;   // s, the largest lag actually used
  int points = 0;          // MSD points with 0 < lag <= t_fit
};
// MSD = 2 D t by least squares through the origin: 2D = sum(t MSD) / sum(t^2).
DiffusionFit fit_diffusivity(const std::vector<MsdPoint>& msd, double t_fit);

// ---- Apparent viscosity ----------------------------------------------------------------------

struct ApparentViscosity {
  double mean_velocity = 0;             // U = Q / (pi R^2), the blood's mean velocity, m/s
  double wall_shear_rate = 0;           // gamma_w = d dP / (4 mu l), 1/s (imposed)
  double apparent_wall_shear_rate = 0;  // 8 U / d, 1/s
  double relative_viscosity = 0;        // mu_app / mu = gamma_w / (8 U / d)
};
ApparentViscosity apparent_viscosity(double mean_velocity, double diameter, double wall_shear_rate);

// Arithmetic mean of the samples with t_start <= t <= t_end (metrics come at equal steps).
// NaN without samples.
double time_mean(const std::vector<double>& t, const std::vector<double>& value, double t_start, double t_end);

// ---- Momentum balance (docs/model.md §5) -----------------------------------------------------

// The realised wall shear stress against the one the driving imposes (model/momentum_balance.h).
struct WallShearBalance {
  double imposed = 0;                       // τ_w,imposed = d ΔP / (4 l), Pa
  double viscosity = 0;                     // µ, Pa s
  double mesh_ratio = 1;                    // τ_w / τ_w,imposed of an exact balance on the run's mesh
  double window_start = 0, window_end = 0;  // s
  long samples = 0;                         // τ_w samples in the window
  double mean = 0;                          // τ_w, window mean, Pa (NaN without samples)
  double end = 0;                           // τ_w, the window's last sample, Pa (NaN without samples)
  double ratio() const;                     // mean / imposed
  double wall_shear_rate() const;           // realised γ̇ = mean / µ, 1/s
  double imposed_wall_shear_rate() const;   // imposed / µ, 1/s
};
WallShearBalance wall_shear_balance(const std::vector<double>& t, const std::vector<double>& tau, double t_start,
                                    double t_end, double imposed, double viscosity, double mesh_ratio);

// Judged only once the flow has settled: the window starts after the suspension's settling time
// (the red cells' migration forms the cell-free layer in ~0.1 s) and after a viscous time d²/ν
// (8.5 ms in the calibration vessel; it matters for wider vessels only).
inline constexpr double kSuspensionSettling_s = 0.1;
double settling_time(double diameter, double kinematic_viscosity);

// The balance holds when τ_w / τ_w,imposed lies between the exact balance on the mesh and on the
// circle, within a tolerance either side: [mesh_ratio (1 - tol), 1 + tol]. 2 %: a steady
// single-phase run meets its mesh's balance to 1e-11 (docs/fluid-verification.md §2), so what is
// left is the suspension's unsteadiness and the little axial force the cells' wall contacts
// carry; the deficit this is there to catch (the driving on the plasma only) is 12 %.
inline constexpr double kBalanceTolerance = 0.02;
struct BalanceVerdict {
  bool judged = false;  // samples in a settled window
  bool holds = true;
  std::string why_not_judged;  // when not judged
  std::string line;            // "momentum balance: ..." when judged and it does not hold
};
BalanceVerdict judge_balance(const WallShearBalance& b, double settling_time_s, double tolerance = kBalanceTolerance);

// Means of a series over `bins` equal spans of its time range (empty spans left out), each at the
// mean time of its samples: a long series (τ_w every coupling step) thinned for a figure.
struct SeriesPoint {
  double time_s = 0;
  double value = 0;
};
std::vector<SeriesPoint> binned_means(const std::vector<double>& t, const std::vector<double>& value, int bins);

// ---- Platelets on the axis -------------------------------------------------------------------

// The fraction of platelets within `region` R of the axis at the end over that at the start:
// above 1, platelets gather on the axis (where the physics sends them to the wall).
inline constexpr double kAxisRegion = 0.2;
struct AxisEnrichment {
  double start_time = 0, end_time = 0;  // s
  long start_total = 0, end_total = 0;  // platelets
  long start_near = 0, end_near = 0;    // of them within region R
  double start_fraction = 0, end_fraction = 0;
  double enrichment = 0;  // end_fraction / start_fraction; NaN when either is undefined or the start's is 0
};
AxisEnrichment axis_enrichment(const std::vector<double>& start_r, double start_time, const std::vector<double>& end_r,
                               double end_time, double radius, double region = kAxisRegion);

// ---- Hematocrit ------------------------------------------------------------------------------

// Tube hematocrit H_T = N_RBC V_RBC / (pi R^2 L).
double tube_hematocrit(std::size_t rbc_count, double rbc_volume, const Tube& tube);

// Volume flux of cells through a cross-section, m^3/s. In a periodic tube the flux averaged over
// all sections is (1/L) sum_i V_i v_z,i: each cell crosses a section v_z,i / L times per second.
double cell_volume_flux(const std::vector<double>& vz, double cell_volume, const Tube& tube);

// Total (blood) volume flux Q = A <alpha u_z> + Q_cells: the plasma's superficial flux from the
// fluid node (its volume mean times the mean section A = V/L, pi R^2 in a straight tube: in a
// periodic vessel every section passes the same Q) plus the cells' own flux.
double total_volume_flux(double superficial_plasma_velocity, double cells_volume_flux, const Tube& tube);

// Discharge hematocrit H_D = Q_RBC / Q: the RBC share of the volume that flows through a
// section. H_D = H_T in plug flow; H_D > H_T when RBCs ride the fast core (Fahraeus effect).
double discharge_hematocrit(double rbc_volume_flux, double total_volume_flux);

// ---- Through an open vessel's ends (model/vessel_ends.h) ----------------------------------------

// What passes one end of an open vessel over a window: the plasma's volume flux (the fluid node's
// alpha u . n over the patch, its window mean) and the cells counted through it (the particle
// node's cumulative counts, their increase over the window per second).
struct EndFlux {
  std::string end;             // "inlet" (into the vessel) or "outlet" (out of it)
  double plasma_flux = 0;      // m^3/s
  double rbc_rate = 0;         // red cells per second
  double platelet_rate = 0;    // platelets per second
  double rbc_volume_flux = 0;  // m^3/s: rbc_rate x V_RBC
  double platelet_volume_flux = 0;
  double blood_flux() const { return plasma_flux + rbc_volume_flux + platelet_volume_flux; }
  // H_D = Q_RBC / Q through this end.
  double discharge_hematocrit() const;
  // The platelets' count in the blood that passes, 1/m^3: their rate over the blood's flux (the
  // platelets' H_D, as a number density to hold against the scene's).
  double discharge_platelet_density() const;
};

// An outlet's shares of what leaves through all the outlets over the window: of the blood, the
// plasma, the red cells and the platelets. A bifurcation's phase-separation curve plots the red
// cells' share against the blood's (Pries et al. 1989, Am. J. Physiol. 256:H1079): a branch
// that takes a share of the cells below its share of the blood is skimmed (plasma skimming).
struct BranchShare {
  std::string outlet;
  double blood = 0, plasma = 0, rbc = 0, platelet = 0;  // fractions of the outlets' sums
};
std::vector<BranchShare> branch_shares(const std::vector<EndFlux>& outlets);

// The increase of a cumulative count over [t_start, t_end], per second, from its values at the
// last samples at or before each time; NaN when no sample lies at or before t_start or the window
// is empty.
double window_rate(const std::vector<double>& t, const std::vector<double>& count, double t_start, double t_end);

// ---- Blood in glass tubes: the in-vitro references (docs/model.md §7.4) -------------------------

// Relative apparent viscosity of blood in a glass tube of diameter d at discharge hematocrit H_D,
// the in-vitro fit of Pries, Neuhaus & Gaehtgens (1992, Am. J. Physiol. 263:H1770) to the
// published tube-viscosity data (d in µm inside the fit; here in metres). 1 at H_D = 0.
double in_vitro_relative_viscosity(double diameter, double discharge_hematocrit);

// Tube over discharge hematocrit H_T / H_D in a glass tube (the Fåhræus effect), the in-vitro fit
// of Pries, Secomb, Gaehtgens & Gross (1990, Circ. Res. 67:826). 1 in a wide tube.
double in_vitro_fahraeus_ratio(double diameter, double discharge_hematocrit);

// ---- Blood at microvascular bifurcations: the in-vivo reference (docs/model.md §5) ---------------

// A daughter's share of the red cells at a bifurcation against its share of the blood, the in-vivo
// phase-separation fit of Pries et al. (1989, Am. J. Physiol. 256:H1079) with the parameters of
// Pries & Secomb (2005, Am. J. Physiol. 289:H2657): logit F_E = A + B logit((F_B - X0) / (1 - 2 X0)),
// X0 = 0.964 (1 - H_D) / D_F, B = 1 + 6.98 (1 - H_D) / D_F,
// A = -13.29 ((D_a^2 / D_b^2 - 1) / (D_a^2 / D_b^2 + 1)) (1 - H_D) / D_F; diameters in µm inside the
// fit (here in metres), H_D the parent's discharge hematocrit. 0 below X0, 1 above 1 - X0: a branch
// taking less than X0 of the blood takes plasma alone. NaN for inputs outside (0, 1) or diameters
// not positive.
double in_vivo_rbc_share(double blood_share, double parent_diameter, double diameter, double other_diameter,
                         double parent_discharge_hematocrit);

// ---- Along a vessel shape (model/geometry.h) -------------------------------------------------

// Per axial station of a vessel that narrows, each against the local wall r = R(z). A particle's
// gap is the distance from its sphere to the wall, -signed_distance(x) - d/2 (on a straight tube
// R - r - d/2). Stations are equal slices of [0, L) (z wrapped); angular sectors split each for
// the cell-free layer as in the edge method (rbc_core_edges), which this is on a straight tube.
inline constexpr double kNearWallDiameters = 1;        // "near the wall": a gap below one platelet diameter
inline constexpr double kWallContactDiameters = 0.02;  // "touching": a gap below 2 % of it (contacts overlap ~1 %)
struct AxialObservables {
  std::vector<double> z;                   // m, station centres
  std::vector<double> radius;              // m, R at the centre
  std::vector<double> cfl;                 // m, mean over occupied (sector, snapshot) of the smallest RBC gap
                                           // (NaN: no RBC in the station)
  std::vector<double> hematocrit;          // the station's RBC volume over its volume (int pi R^2 dz), mean
  std::vector<double> platelet_near_wall;  // platelets with a gap < kNearWallDiameters d_p, per wall area, 1/m^2
  std::vector<double> wall_contact_rate;   // platelets arriving at the wall (gap < kWallContactDiameters d_p now,
                                           // not at the snapshot before) per wall area and second, 1/(m^2 s):
                                           // contacts shorter than the snapshot interval are missed
  double wall_area_total = 0;              // m^2, the wall's area over the length (the stations' sum)
  int snapshots = 0;
};

class AxialAccumulator {
 public:
  AxialAccumulator(const VesselGeometry& vessel, const Stations& stations, double rbc_diameter, double rbc_volume,
                   double platelet_diameter);
  // One snapshot; snapshots in time order (the contact rate compares each with the one before).
  void add(const Snapshot& s);
  AxialObservables result() const;

 private:
  int station_of(double z) const;
  double gap(const double* x, double diameter) const;
  const VesselGeometry& vessel_;
  Stations stations_;
  double rbc_diameter_, rbc_volume_, platelet_diameter_;
  std::vector<double> volume_, area_;  // per station, m^3 and m^2
  std::vector<double> edge_sum_, rbc_volume_sum_, near_wall_sum_, arrivals_;
  std::vector<long> edge_samples_;
  std::vector<std::int64_t> touching_;  // platelet ids touching the wall at the last snapshot, sorted
  double first_time_ = 0, last_time_ = 0;
  int snapshots_ = 0;
};

// ---- Along a branching vessel's branches (model/vessel_wall.h) ---------------------------------

// Branch 0 is "parent", branch i "daughter_<i>": the one that leaves through outlet_<i>.
std::string branch_name(int branch);

// Where a branch's sections are its own tube's: the span along its axis, in m from the axis's
// start, over which the wall runs round the whole circle of the branch's radius about it (the
// wall's signed distance at 64 points of the circle: none inside the vessel by more than the
// branch's tolerance). Near the junction a
// section meets another branch's tube: two daughters of radius r at an angle theta share their
// sections up to r cot(theta/2) from the junction, and a gap R - r there would be to no wall. Each
// end of the span is bisected to 1e-4 R between the last section found shared and the first found
// clear, stepping in from the axis's ends by R / 10. Empty (start = end = 0) when no section is clear.
struct BranchSpan {
  double start = 0, end = 0;  // m
  double length() const { return end - start; }
};
BranchSpan own_section_span(const VesselWall& wall, int branch);

// The stations along a branch when none are asked for: a few, so that a change along it shows.
inline constexpr int kBranchSlices = 4;

// The cell-free layer along each branch of a branching vessel, by the straight tube's edge method
// (rbc_core_edges, cfl_thickness_edge) in the branch's own cylindrical coordinates: r the
// distance from its axis, theta about it, z along it from its span's start (own_section_span).
// The span is cut into equal slices, each into sectors; a slice's δ is R_b - <max(r + d/2)> over
// its occupied sectors and the snapshots, the branch's the same over all its slices. A red cell
// counts in the branch it is in (VesselWall::branch_at), and only within that branch's span.
struct BranchLayer {
  std::string name;
  double radius = 0;                  // m, R_b
  double length = 0;                  // m, the axis segment's
  BranchSpan span;                    // m along the axis
  Stations stations;                  // axial: slices of the span; sectors: of each slice
  std::vector<double> s;              // m along the axis from its start, the slices' centres
  std::vector<CflThickness> station;  // per slice
  CflThickness whole;                 // over the span
  double mean_rbc_count = 0;          // red cells in the span, mean per snapshot
};

class BranchAccumulator {
 public:
  // `slices` along each branch; `sectors` 0: about kRbcsPerStation red cells per station, sized
  // per branch from the first snapshot's count in its span (so a branch with few cells keeps whole
  // slices).
  BranchAccumulator(const VesselWall& wall, int slices, int sectors, double rbc_diameter);
  void add(const Snapshot& s);
  std::vector<BranchLayer> result() const;

 private:
  struct Frame {
    VesselWall::Point start, axis, u, v;  // the axis's start, its unit direction and two normals
    double radius = 0, length = 0;
    BranchSpan span;
    int sectors = 0;
    std::vector<std::vector<StationEdges>> edges;  // per slice, per snapshot
    long rbc_sum = 0;
  };
  const VesselWall& wall_;
  int slices_, sectors_;
  double rbc_diameter_;
  std::vector<Frame> branches_;
  int snapshots_ = 0;
};

// ---- Margination -----------------------------------------------------------------------------

// Fraction of platelets whose centre lies in the cell-free layer, r > R - delta. NaN without
// platelets or without a finite delta.
double margination_index(const std::vector<double>& platelet_r, double radius, double cfl_thickness);

}  // namespace hemo::analysis
