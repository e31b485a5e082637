// hemocosim analyze RUN_DIR: the observables of docs/model.md §5 for one run, as a table or JSON,
// and RUN_DIR/analysis.json + RUN_DIR/profiles.csv for plotting.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "observables.h"
#include "run_data.h"

#include <string>
#include <vector>

namespace hemo {

struct AnalyzeOptions {
  std::string run_dir;
  bool json = false;         // print JSON instead of the table
  int bins = 50;             // radial bins over [0, R]
  double t_fit = 0.1;        // s: D from the MSD over [0, t_fit]
  double window_start = -1;  // s: start of the averaging window; < 0: the second half of [first, end]
  double window_end = -1;    // s: its end; < 0: the last snapshot
  int slices = 0;            // CFL stations: axial slices (a bifurcation's: per branch); 0: about 20 RBCs
                             // per station (a bifurcation's: kBranchSlices per branch)
  int sectors = 0;           // CFL stations: angular sectors; 0: about 20 RBCs per station
};

// Prints the table (or JSON) and writes the two files; throws analysis::RunDataError (one line,
// naming the file) on a missing or corrupt input.
int analyze_command(const AnalyzeOptions& opt);

namespace analysis {

// Per-snapshot number-density profiles (for the paper's profiles at t = 0, 0.5, 1, 2 s).
struct ProfileFrame {
  double time_s = 0;
  std::vector<double> rbc;       // 1/m^3
  std::vector<double> platelet;  // 1/m^3
};

// Everything `analyze` reports; SI units.
struct Analysis {
  std::string run_dir;
  Tube tube;
  double rbc_diameter = 0, rbc_volume = 0, platelet_volume = 0;
  int bins = 0;

  double window_start = 0, window_end = 0;  // s
  bool window_is_default = false;           // second half of the run
  int window_snapshots = 0;
  double mean_rbc_count = 0, mean_platelet_count = 0;  // over the window

  Stations stations;
  CflThickness cfl_edge, cfl_profile;

  double msd_reference_time = 0;  // s, the first snapshot
  std::vector<MsdPoint> msd;
  DiffusionFit diffusion;

  ApparentViscosity rheology;       // from the blood's mean velocity Q / (pi R^2)
  double plasma_mean_velocity = 0;  // m/s, the fluid node's interstitial mean, window mean
  long velocity_samples = 0;
  double wall_shear_stress = 0;  // Pa, window mean from the fluid node
  WallShearBalance balance;      // τ_w against τ_w,imposed over the window
  // What τ_w is held against: the imposed drop's d ΔP / (4 l), or in an open vessel the realised
  // one's, d p_inlet / (4 l) (the outlet holds p = 0).
  std::string balance_against = "imposed d ΔP / (4 l)";
  BalanceVerdict balance_verdict;
  double settling_time = 0;                    // s, before which the balance is not judged
  std::vector<SeriesPoint> balance_over_time;  // τ_w / τ_w,imposed over the whole run, thinned

  AxisEnrichment platelet_axis;  // first snapshot to the last one in the window

  double tube_hematocrit = 0, discharge_hematocrit = 0;
  double rbc_volume_flux = 0, total_volume_flux = 0;  // m^3/s, window means
  std::string total_flux_source;

  double margination_index = 0;  // with the edge-method delta

  std::vector<double> bin_edges;                                           // m
  std::vector<double> rbc_density, platelet_density, rbc_volume_fraction;  // window means
  std::vector<ProfileFrame> frames;
  std::string shape;          // vessel.shape
  AxialObservables axial;     // per axial station over the window; empty for a straight tube
  std::vector<EndFlux> ends;  // an open vessel's inlet and outlet over the window; empty when periodic
  // A surface vessel's (a bifurcation's): each outlet's shares over the window, and over
  // consecutive intervals of the run (the phase-separation points over time); its run has no
  // radial observables. A branching vessel that carries cells adds the cell-free layer along each
  // branch; what passes a branch is its end's (ends[b]: the parent's the inlet's, daughter i's
  // outlet_i's).
  bool surface = false;
  std::vector<BranchShare> branches;
  struct ShareInterval {
    double start = 0, end = 0;  // s
    std::vector<BranchShare> shares;
  };
  std::vector<ShareInterval> shares_over_time;
  std::vector<BranchLayer> branch_layers;

  std::vector<std::string> notes;  // caveats worth reading (short run, few points, ...)
};

Analysis analyze_run(const RunData& run, const AnalyzeOptions& opt);

// τ_w of a run's metrics against d ΔP / (4 l) over [t_start, t_end], ΔP the scene's imposed drop
// or, in an open vessel, the realised one: the mean of `inlet_pressure` (the outlet holds 0).
WallShearBalance momentum_balance(const MetricSeries& wall_shear_stress, const MetricSeries& inlet_pressure,
                                  const Scene& scene, double t_start, double t_end);

// What the run's closing summary says of the momentum balance (coordinator/run.cpp prints it as a
// run ends): judge_balance over the second half of the run's wall_shear_stress_Pa samples, which
// is `analyze`'s default window. Empty when the balance holds or is not judged; throws
// RunDataError (one line) on a missing or malformed metrics.csv.
std::string closing_balance_line(const std::string& run_dir, const Scene& scene);
std::string format_table(const Analysis& a);
std::string format_json(const Analysis& a);
std::string format_profiles_csv(const Analysis& a);

}  // namespace analysis
}  // namespace hemo
