// The observables `analyze` reports, declared once. The text table (format_table), analysis.json
// (format_json), a study's summary.csv and its report.md all iterate observable_table(), so an
// observable added here reaches all four; tests/studies/test_observables.cpp checks that it does.
// analysis.json also carries the declaration itself ("observables"), from which hemocosim_plot.py
// draws its sweep figure.
//
// analysis.json holds more than these (stations, sample counts, the MSD points, how the flux was
// taken): that context is written by format_json around them and shown by the table as the
// bracketed detail of the observable it qualifies.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace hemo::analysis {

struct Analysis;

// How the table and the report print a value: value / scale, in `unit`.
struct Shown {
  enum class Style { fixed, scientific, general } style = Style::fixed;
  int digits = 3;         // after the point (fixed), of the mantissa (scientific), significant (general)
  double scale = 1;       // e.g. 1e-6 to print metres as µm
  std::string_view unit;  // as printed ("µm"); empty for a pure number
};

struct Observable {
  std::string_view name;             // the summary.csv column; unique
  std::string_view json_path;        // where analysis.json holds it, dotted ("cfl.edge.thickness_m")
  std::string_view label;            // its name in the text table and the report ("δ edge")
  std::string_view unit;             // SI unit of the stored value (JSON, CSV); "1" for a pure number
  std::string_view description;      // one line, for the report's legend
  double (*of)(const Analysis&);     // NaN when undefined
  Shown shown;
  std::string (*detail)(const Analysis&) = nullptr;  // the text table's bracketed context, if any
  // The panel of `plot`'s sweep figure (its y-axis title) that draws it against the swept key,
  // as `sweep_series`; observables with the same panel share it. Empty: not in that figure.
  std::string_view sweep_panel = {}, sweep_series = {};
  // Of which vessels: a surface vessel's (a bifurcation's outlets) or else a tube's (the radial and
  // rheological observables, which a surface run does not measure).
  bool of_surface = false;

  // Its value in `a`: NaN when undefined there, or when `a` is of the other kind of vessel.
  double value(const Analysis& a) const;
  // "1.23" in the shown unit, or "n/a" for NaN.
  std::string format(const Analysis& a) const;
  // The report's column header: the label and the shown unit, "δ edge (µm)".
  std::string header() const;
};

// In the order of the table, the CSV columns and the report's columns.
const std::vector<Observable>& observable_table();

}  // namespace hemo::analysis
