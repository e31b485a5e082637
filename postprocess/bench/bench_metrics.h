// The error metrics of `hemocosim bench`, defined once, here (docs/performance.md states them).
//
// Every run of a bench suite is measured (RunMeasures) and compared with the suite's reference
// run, the converged setting (BenchErrors):
//
//   e_U    = |U - U_ref| / |U_ref|        U: the fluid's mean axial velocity, mean over the second
//                                         half of the run (analysis: rheology.mean_velocity)
//   e_rPLT = |rP - rP_ref| / rP_ref       rP: mean radial position of the platelets' centres in the
//                                         last snapshot
//   e_rRBC = |rR - rR_ref| / rR_ref       the same for the RBCs
//   e_D    = |D - D_ref| / |D_ref|        D: platelet radial diffusivity (MSD = 2 D t through the
//                                         origin, analysis defaults). Noisy: its relative standard
//                                         error is about sqrt(2 / N_PLT) (the spread of a mean of
//                                         N squared Gaussian displacements), reported as d_noise.
//   L1_RBC = sum_b |p_b - p_ref,b|        p_b: fraction of the RBC centres of the last snapshot in
//   L1_PLT                                radial bin b of kProfileBins equal bins of r / R over
//                                         [0, 1] (a centre at r >= R counts in the last bin);
//                                         0 for equal profiles, 2 for disjoint ones.
//
// The reference run's own errors are 0 by construction. Runs start from the same placement
// (same seed), so the errors include the knob's effect and the divergence of the cells'
// chaotic trajectories, not the spread between placements.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <vector>

namespace hemo::bench {

inline constexpr int kProfileBins = 10;

// Cost of a run, from its profile.csv (NaN where missing).
struct RunCost {
  double fluid_compute_s = 0, particle_compute_s = 0, coupling_overhead_s = 0;
  double fluid_peak_mib = 0, particle_peak_mib = 0;
};
// Reads RUN_DIR/profile.csv; all NaN when it is missing (a failed run).
RunCost read_profile(const std::string& run_dir);

struct RunMeasures {
  double mean_velocity = 0;                           // U, m/s
  double mean_r_platelet = 0;                         // m, last snapshot
  double mean_r_rbc = 0;                              // m, last snapshot
  double diffusivity = 0;                             // D, m^2/s
  long platelets = 0, rbcs = 0;                       // in the last snapshot
  std::vector<double> profile_platelet, profile_rbc;  // fractions per bin, sum 1 (empty without cells)
};

// Fractions of the radii r (m) in kProfileBins equal bins of r / radius over [0, 1].
std::vector<double> radial_fractions(const std::vector<double>& r, double radius);
// Mean of r; NaN when empty.
double mean_of(const std::vector<double>& r);
// Sum of |a_b - b_b|; NaN when either is empty or they differ in size.
double l1_distance(const std::vector<double>& a, const std::vector<double>& b);
// |x - ref| / |ref|; NaN when either is not finite or ref is 0.
double relative_error(double x, double ref);

// Analyses RUN_DIR (analysis defaults) and reads its last snapshot; throws on a bad run directory.
RunMeasures measure_run(const std::string& run_dir);

struct BenchErrors {
  double u = 0, r_platelet = 0, r_rbc = 0, d = 0, l1_platelet = 0, l1_rbc = 0;
  double d_noise = 0;  // sqrt(2 / N_PLT) of the run
};
BenchErrors errors_against(const RunMeasures& run, const RunMeasures& reference);

// A floor suite's run: hemocosim-dem-bench's figures (its --json file), wall time per
// particle-step in ns.
struct DemFloor {
  long particles = 0;
  int ranks = 0;
  double dem_ns = 0;       // our DEM as the node runs it, one LIGGGHTS run per coupling interval
  double callback_ns = 0;  // of which our fluid-force callback
  double one_run_ns = 0;   // the same steps in one continuous run
  double bare_ns = 0;      // bare LIGGGHTS on the same particles (the floor)
  long bare_particles = 0;  // the particles the bare run read
  double peak_mib = 0;      // per rank
  // Neighbour-list builds per 1000 DEM steps: ours (its dem.neighbour_rebuild), bare LIGGGHTS's
  // own policy, and bare LIGGGHTS with our streaming criterion (when ours used it).
  std::string neighbour_rebuild = "engine";
  double builds_per_1000 = 0, bare_builds_per_1000 = 0;
  bool has_bare_streaming = false;
  double bare_streaming_ns = 0, bare_streaming_builds_per_1000 = 0;
  double over_bare() const { return dem_ns / bare_ns; }
};
// Reads RUN_DIR/dem-bench.json; throws naming the file when it is missing or incomplete.
DemFloor read_dem_floor(const std::string& run_dir);

}  // namespace hemo::bench
