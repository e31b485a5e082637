// hemocosim plot RUN_DIR [RUN_DIR...]: the paper-style figures as PNG (radial number-density
// profiles over time, MSD with the fitted D, the momentum balance over time, and for several runs CFL, D and mu_app/mu
// against the swept parameter; a bifurcation's outlet shares over time and against the blood's, and its branches'
// cell-free layer, H_D and platelet flux). The drawing is hemocosim_plot.py (matplotlib, headless); this side makes
// sure every run is analysed first and finds the script and a Python that can run it.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "analyze.h"

#include <string>
#include <vector>

namespace hemo {

struct PlotOptions {
  std::vector<std::string> run_dirs;
  std::string out;                  // default: RUN_DIR/figures for one run, ./figures for several
  std::string key;                  // swept scene key (dotted); empty: the script finds the one that differs
  std::vector<std::string> labels;  // names of the runs in the figures, one per run (optional)
  std::string xlabel;               // title of the swept axis; empty: the key
  bool reanalyze = false;           // analyse even when analysis.json is up to date
  bool quiet = false;               // do not print the list of files
};

// Draws the figures and returns the PNG files written; throws std::runtime_error with one line
// (no such run directory, no snapshots, no Python with matplotlib, the script failed).
std::vector<std::string> plot_runs(const PlotOptions& opt);
int plot_command(const PlotOptions& opt);

// Analyses a run with the default options of `hemocosim analyze` and writes RUN_DIR/analysis.json
// and RUN_DIR/profiles.csv; throws analysis::RunDataError (one line) on a missing or bad input.
analysis::Analysis analyze_run_dir(const std::string& run_dir);

// Writes RUN_DIR/analysis.json and RUN_DIR/profiles.csv with the default analysis options
// unless both exist, are newer than particles.h5 and analysis.json declares its observables (or
// `force`). Returns true if it analysed.
bool ensure_analysis(const std::string& run_dir, bool force = false);

// Where hemocosim_plot.py is: $HEMOCOSIM_PLOT_SCRIPT, then <exe dir>/../share/hemocosim/ (build
// tree and install prefix), then the source tree this binary was built from. Throws naming
// every place tried.
std::string find_plot_script();

// A Python 3 that imports matplotlib and numpy: $HEMOCOSIM_PYTHON, then /usr/bin/python3 (where
// Debian's python3-matplotlib lives), then python3 in PATH. Throws naming every one tried.
std::string find_python();

}  // namespace hemo
