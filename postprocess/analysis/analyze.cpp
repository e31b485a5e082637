// SPDX-License-Identifier: GPL-3.0-or-later
#include "analyze.h"

#include "geometry.h"
#include "momentum_balance.h"
#include "observable_table.h"
#include "surface.h"
#include "vessel_ends.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>

namespace hemo {

namespace analysis {

namespace {

// tau_w = d dP / (4 l) is the balance of a wall parallel to the axis: a narrowing vessel's wall
// takes part of the drop as pressure on its slopes, so there tau_w alone is not judged. An open
// vessel is driven by its inlet's flow rate; the drop that flow needs, the inlet's pressure over
// the outlet's p = 0, is what its wall must carry, the developed inflow bringing in the momentum
// the outflow takes out.
BalanceVerdict judge_run_balance(const WallShearBalance& b, const Scene& scene) {
  if (!make_vessel_geometry(scene.vessel)->uniform()) {
    BalanceVerdict v;
    v.why_not_judged = fmt::format(
        "a {} vessel's wall takes part of the drop as pressure on its slopes, so the "
        "wall shear stress alone does not balance it",
        scene.vessel.shape);
    return v;
  }
  return judge_balance(b, settling_time(scene.vessel.diameter, scene.plasma.kinematic_viscosity()));
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kUm = 1e-6;
constexpr int kFineBins = 4096;      // centre histogram behind the RBC volume fraction
constexpr int kBalancePoints = 200;  // τ_w / τ_w,imposed over time in analysis.json

// The averaging window: the second half of the run unless asked otherwise (an end alone: the
// second half of the run up to it, so that a longer run can be read as a shorter one).
void choose_window(Analysis& a, const RunData& run, double window_start, double window_end) {
  const double first = run.snapshots.front().time_s, last = run.snapshots.back().time_s;
  a.window_end = window_end >= 0 ? window_end : last;
  a.window_is_default = !(window_start >= 0) && !(window_end >= 0);
  a.window_start = window_start >= 0 ? window_start : first + 0.5 * (a.window_end - first);
  if (a.window_start > last)
    throw RunDataError(fmt::format("{}: window start {} s is after the last snapshot at {} s", run.particles_path,
                                   a.window_start, last));
  if (a.window_end > last)
    throw RunDataError(
        fmt::format("{}: window end {} s is after the last snapshot at {} s", run.particles_path, a.window_end, last));
  if (a.window_end < a.window_start)
    throw RunDataError(
        fmt::format("{}: window end {} s is before its start {} s", run.particles_path, a.window_end, a.window_start));
}

// Window means of the fluid node's metrics, and what follows from them.
void fluid_observables(Analysis& a, const RunData& run, double mean_cells_flux) {
  const auto u = metric_series(run.metrics, "mean_velocity_m_s");
  const auto tau = metric_series(run.metrics, "wall_shear_stress_Pa");
  const auto sup = metric_series(run.metrics, "superficial_velocity_m_s");
  const double mean_u = time_mean(u.time_s, u.value, a.window_start, a.window_end);
  for (double t : u.time_s) a.velocity_samples += t >= a.window_start && t <= a.window_end;
  if (u.empty()) a.notes.push_back("metrics.csv has no mean_velocity_m_s: no apparent viscosity");
  a.plasma_mean_velocity = mean_u;

  const double mean_sup = time_mean(sup.time_s, sup.value, a.window_start, a.window_end);
  if (std::isfinite(mean_sup)) {
    a.total_volume_flux = total_volume_flux(mean_sup, mean_cells_flux, a.tube);
    a.total_flux_source = "V/L <alpha u_z> (superficial_velocity_m_s) + sum V_p v_z / L over all cells";
  } else {
    // Without the plasma's superficial velocity, the blood is taken to move at the plasma's mean.
    a.total_volume_flux = a.tube.mean_section() * mean_u;
    a.total_flux_source = "V/L U (superficial_velocity_m_s not reported)";
  }
  a.discharge_hematocrit = discharge_hematocrit(a.rbc_volume_flux, a.total_volume_flux);
  const bool open = open_ends(run.scene.vessel);
  a.balance =
      momentum_balance(tau, metric_series(run.metrics, "inlet_pressure_Pa"), run.scene, a.window_start, a.window_end);
  if (open) a.balance_against = "the inlet's d p_in / (4 l)";
  // The paper's 8 U / d is built from the realised mean velocity of the blood, plasma and cells,
  // against the wall shear rate of the drop (imposed, or an open vessel's realised one).
  a.rheology = apparent_viscosity(a.total_volume_flux / a.tube.cross_section(), run.scene.vessel.diameter,
                                  open ? a.balance.imposed_wall_shear_rate() : run.scene.driving.wall_shear_rate);

  a.wall_shear_stress = a.balance.mean;
  a.settling_time = settling_time(run.scene.vessel.diameter, run.scene.plasma.kinematic_viscosity());
  a.balance_verdict = judge_run_balance(a.balance, run.scene);
  // The whole run, for `plot`: a point per 1/200 of it (the calibration run: every 0.01 s).
  for (const auto& p : binned_means(tau.time_s, tau.value, kBalancePoints))
    a.balance_over_time.push_back({p.time_s, p.value / a.balance.imposed});
  if (tau.empty())
    a.notes.push_back("metrics.csv has no wall_shear_stress_Pa: no momentum balance");
  else if (!a.balance_verdict.judged)
    a.notes.push_back("momentum balance not judged: " + a.balance_verdict.why_not_judged);
  else if (!a.balance_verdict.holds)
    a.notes.push_back(a.balance_verdict.line);
}

// An open vessel's ends over [t_start, t_end]: the plasma's flux (the fluid node's) and the cells
// the particle node counted through each (into the vessel at the inlet: inserted - left back).
std::vector<EndFlux> end_fluxes(const Analysis& a, const RunData& run, double t_start, double t_end) {
  if (!open_ends(run.scene.vessel)) return {};
  auto rate = [&](const std::string& name) {
    const auto series = metric_series(run.metrics, name);
    return series.empty() ? 0.0 : window_rate(series.time_s, series.value, t_start, t_end);
  };
  auto plasma = [&](const std::string& name) {
    const auto series = metric_series(run.metrics, name);
    return time_mean(series.time_s, series.value, t_start, t_end);
  };
  std::vector<EndFlux> ends = {{"inlet", plasma("inlet_plasma_flux_m3_s"),
                                rate("rbc_inserted") - rate("rbc_left_inlet"),
                                rate("platelet_inserted") - rate("platelet_left_inlet")}};
  // A surface vessel's outlets are outlet_1, outlet_2, ... in both nodes' metrics.
  if (surface_vessel(run.scene.vessel)) {
    const Surface surface = make_vessel_surface(run.scene.vessel);
    for (int n = 1; surface.region_index(surface_region::outlet(n)) >= 0; ++n) {
      const std::string name = surface_region::outlet(n), number = std::to_string(n);
      ends.push_back({name, plasma(name + "_plasma_flux_m3_s"), rate("rbc_left_outlet_" + number),
                      rate("platelet_left_outlet_" + number)});
    }
    // One outlet's counts are the whole's (the particle node names each only when there are several).
    if (ends.size() == 2) {
      ends[1].rbc_rate = rate("rbc_left_outlet");
      ends[1].platelet_rate = rate("platelet_left_outlet");
    }
  } else {
    ends.push_back(
        {"outlet", plasma("outlet_plasma_flux_m3_s"), rate("rbc_left_outlet"), rate("platelet_left_outlet")});
  }
  for (EndFlux& e : ends) {
    e.rbc_volume_flux = e.rbc_rate * a.rbc_volume;
    e.platelet_volume_flux = e.platelet_rate * a.platelet_volume;
  }
  return ends;
}

// The outlets' shares over consecutive intervals of the run, each of about the same number of the
// particle node's count samples and bounded by two of them (a count is read at the last sample at
// or before a time: a bound between samples would take a step's cells into the wrong interval).
constexpr int kShareIntervals = 20;
std::vector<Analysis::ShareInterval> shares_over_time(const Analysis& a, const RunData& run) {
  const std::vector<double> t = metric_series(run.metrics, "rbc_inserted").time_s;
  const int n = std::min(kShareIntervals, static_cast<int>(t.size()) - 1);
  std::vector<Analysis::ShareInterval> out;
  for (int k = 0; k < n; ++k) {
    const double t0 = t[static_cast<std::size_t>(std::lround(double(k) * double(t.size() - 1) / n))];
    const double t1 = t[static_cast<std::size_t>(std::lround(double(k + 1) * double(t.size() - 1) / n))];
    const auto ends = end_fluxes(a, run, t0, t1);
    out.push_back({t0, t1, branch_shares({ends.begin() + 1, ends.end()})});
  }
  return out;
}

// A surface vessel's run: what went through each end over the window and each outlet's shares, and
// along a branching vessel's branches the cell-free layer. Its vessel is no tube: no radial
// profiles, MSD or wall-shear balance.
Analysis analyze_branches(const RunData& run, const AnalyzeOptions& opt) {
  Analysis a;
  a.run_dir = run.dir;
  a.surface = true;
  a.shape = run.scene.vessel.shape;
  a.tube = {run.scene.vessel.radius(), run.scene.vessel.length};
  a.rbc_diameter = run.scene.rbc.diameter;
  a.rbc_volume = run.scene.rbc.volume;
  a.platelet_volume = run.scene.platelet.volume;
  choose_window(a, run, opt.window_start, opt.window_end);
  a.ends = end_fluxes(a, run, a.window_start, a.window_end);
  a.branches = branch_shares({a.ends.begin() + 1, a.ends.end()});
  a.shares_over_time = shares_over_time(a, run);
  const std::unique_ptr<VesselWall> wall =
      vessel_shape(run.scene.vessel.shape).carries_cells() ? make_vessel_wall(run.scene.vessel) : nullptr;
  std::optional<BranchAccumulator> layers;
  if (wall && !wall->branches().empty())
    layers.emplace(*wall, opt.slices > 0 ? opt.slices : kBranchSlices, opt.sectors, a.rbc_diameter);
  for (std::size_t i = 0; i < run.snapshots.size(); ++i) {
    const double t = run.snapshots[i].time_s;
    if (t < a.window_start || t > a.window_end) continue;
    if (layers) layers->add(run.load(i));
    ++a.window_snapshots;
  }
  if (layers) a.branch_layers = layers->result();
  for (const BranchLayer& l : a.branch_layers)
    if (!(l.span.length() > 0)) a.notes.push_back(l.name + ": no section is the branch's own: no cell-free layer");
  a.notes.push_back(
      "a surface vessel: the ends' fluxes, each outlet's shares and the layer along each branch only (no radial "
      "observables)");
  return a;
}

}  // namespace

WallShearBalance momentum_balance(const MetricSeries& tau, const MetricSeries& inlet_pressure, const Scene& scene,
                                  double t_start, double t_end) {
  // An open vessel's drop is realised, not imposed: its inlet's mean pressure over the window.
  const double carried =
      open_ends(scene.vessel)
          ? wall_shear_stress_of(scene.vessel.diameter,
                                 time_mean(inlet_pressure.time_s, inlet_pressure.value, t_start, t_end),
                                 scene.vessel.length)
          : imposed_wall_shear_stress(scene);
  return wall_shear_balance(tau.time_s, tau.value, t_start, t_end, carried, scene.plasma.viscosity,
                            mesh_balance_ratio(scene));
}

std::string closing_balance_line(const std::string& run_dir, const Scene& scene) {
  if (surface_vessel(scene.vessel)) return "";  // no tube: no wall-shear balance
  const auto tau = read_metric_series(run_dir + "/metrics.csv", "wall_shear_stress_Pa");
  if (tau.empty()) return "";
  const auto [first, last] = std::minmax_element(tau.time_s.begin(), tau.time_s.end());
  const auto inlet = read_metric_series(run_dir + "/metrics.csv", "inlet_pressure_Pa");
  const auto b = momentum_balance(tau, inlet, scene, *first + 0.5 * (*last - *first), *last);
  return judge_run_balance(b, scene).line;
}

Analysis analyze_run(const RunData& run, const AnalyzeOptions& opt) {
  const int bins = opt.bins;
  const double t_fit = opt.t_fit;
  if (run.snapshots.empty()) throw RunDataError(run.particles_path + ": no snapshots");
  if (surface_vessel(run.scene.vessel)) return analyze_branches(run, opt);
  if (bins < 1) throw RunDataError(fmt::format("bins must be at least 1 (got {})", bins));
  if (!(t_fit > 0)) throw RunDataError(fmt::format("t_fit must be positive (got {})", t_fit));
  Analysis a;
  a.run_dir = run.dir;
  a.tube = {run.scene.vessel.radius(), run.scene.vessel.length};
  const auto geometry = make_vessel_geometry(run.scene.vessel);
  if (!geometry->uniform()) a.tube.narrowed_section = geometry->volume() / run.scene.vessel.length;
  a.rbc_diameter = run.scene.rbc.diameter;
  a.rbc_volume = run.scene.rbc.volume;
  a.platelet_volume = run.scene.platelet.volume;
  a.bins = bins;
  a.bin_edges = radial_bin_edges(a.tube, bins);
  choose_window(a, run, opt.window_start, opt.window_end);

  const bool open = open_ends(run.scene.vessel);
  const Snapshot first = run.load(0);
  const Cells reference = radii_at_nominal_wall(select_species(first, kPlatelet), *geometry);
  a.msd_reference_time = first.time_s;

  std::vector<StationEdges> edges;
  std::vector<std::vector<double>> rbc_n, plt_n;
  std::vector<double> rbc_centres(kFineBins, 0.0);
  double margination_sum = 0, hematocrit_sum = 0, rbc_flux_sum = 0, cells_flux_sum = 0, rbc_count = 0, plt_count = 0;
  int margination_snapshots = 0;
  std::vector<std::vector<double>> window_platelet_r;
  bool stations_chosen = false;
  a.shape = run.scene.vessel.shape;
  std::optional<AxialAccumulator> axial;  // a shape that narrows: along the vessel
  std::vector<double> end_platelet_r;     // of the last snapshot up to the window's end
  double end_time = first.time_s;

  for (std::size_t i = 0; i < run.snapshots.size(); ++i) {
    const Snapshot s = i == 0 ? first : run.load(i);
    const Cells rbc = select_species(s, kRbc), plt = select_species(s, kPlatelet);
    a.frames.push_back(
        {s.time_s, radial_number_density(rbc.r, a.tube, bins), radial_number_density(plt.r, a.tube, bins)});
    // An open vessel's cells come and go, and their ids are given again: no displacement to follow.
    if (i > 0 && !open)
      a.msd.push_back(radial_msd(reference, first.time_s, radii_at_nominal_wall(plt, *geometry), s.time_s));
    if (s.time_s <= a.window_end) {
      end_platelet_r = plt.r;
      end_time = s.time_s;
    }
    if (s.time_s < a.window_start || s.time_s > a.window_end) continue;

    // Stations are sized once, from the first window snapshot (the RBC count of a periodic
    // vessel does not change); counts given on the command line win.
    if (!stations_chosen) {
      a.stations = default_stations(static_cast<double>(rbc.size()), a.tube);
      if (opt.slices > 0) a.stations.axial = opt.slices;
      if (opt.sectors > 0) a.stations.sectors = opt.sectors;
      stations_chosen = true;
      if (!geometry->uniform() || open) {
        // Along the vessel: the CFL stations, but at least one per R0 / 2 of length unless the
        // slices are given, so that the constriction (or an open vessel's entrance) is resolved.
        Stations along = a.stations;
        if (opt.slices <= 0)
          along.axial = std::max(along.axial, static_cast<int>(std::lround(2 * a.tube.length / a.tube.radius)));
        axial.emplace(*geometry, along, a.rbc_diameter, a.rbc_volume, run.scene.platelet.diameter);
        if (!geometry->uniform())
          a.notes.push_back(
              "the radial profiles, δ and margination above are of the nominal tube (R0 = d/2; H_T, "
              "H_D and µ_app take the vessel's own volume and flux); along the vessel, each station "
              "is against its local radius R(z)");
      }
    }
    if (axial) axial->add(s);
    ++a.window_snapshots;
    rbc_n.push_back(a.frames.back().rbc);
    plt_n.push_back(a.frames.back().platelet);
    const auto h = centre_histogram(rbc.r, a.tube, kFineBins);
    for (int k = 0; k < kFineBins; ++k) rbc_centres[k] += h[k];
    if (rbc.size() > 0) edges.push_back(rbc_core_edges(rbc, a.rbc_diameter, a.tube, a.stations));
    window_platelet_r.push_back(plt.r);
    rbc_count += rbc.size();
    plt_count += plt.size();
    hematocrit_sum += tube_hematocrit(rbc.size(), a.rbc_volume, a.tube);
    const double q_rbc = cell_volume_flux(rbc.vz, a.rbc_volume, a.tube);
    rbc_flux_sum += q_rbc;
    cells_flux_sum += q_rbc + cell_volume_flux(plt.vz, a.platelet_volume, a.tube);
  }

  const double n = a.window_snapshots;
  a.mean_rbc_count = rbc_count / n;
  a.mean_platelet_count = plt_count / n;
  a.rbc_density = average_profiles(rbc_n);
  a.platelet_density = average_profiles(plt_n);
  for (double& c : rbc_centres) c /= n;
  a.rbc_volume_fraction =
      radial_volume_fraction_from_histogram(rbc_centres, a.rbc_diameter, a.rbc_volume, a.tube, bins);
  a.cfl_edge = cfl_thickness_edge(edges, a.tube);
  a.cfl_profile = cfl_thickness_profile(a.rbc_volume_fraction, a.tube);
  if (a.mean_rbc_count == 0) a.notes.push_back("no RBCs: no cell-free layer");

  for (const auto& r : window_platelet_r) {
    const double m = margination_index(r, a.tube.radius, a.cfl_edge.thickness);
    if (std::isfinite(m)) {
      margination_sum += m;
      ++margination_snapshots;
    }
  }
  a.margination_index = margination_snapshots > 0 ? margination_sum / margination_snapshots : kNaN;

  a.diffusion = fit_diffusivity(a.msd, t_fit);
  if (open)
    a.notes.push_back("an open vessel's cells come and go (their ids are given again): no radial MSD or D");
  else if (a.diffusion.points == 0)
    a.notes.push_back(fmt::format("no MSD point in (0, {}] s: no D (output more often or raise --t-fit)", t_fit));
  else if (a.diffusion.points < 3)
    a.notes.push_back(fmt::format("D from only {} MSD point(s)", a.diffusion.points));
  if (a.diffusion.points > 0 && a.diffusion.window_end < 0.99 * t_fit)
    a.notes.push_back(
        fmt::format("the run ends before t_fit: D fitted over [0, {:.4g}] s only", a.diffusion.window_end));

  a.platelet_axis = axis_enrichment(reference.r, first.time_s, end_platelet_r, end_time, a.tube.radius);
  if (a.platelet_axis.start_total > 0 && a.platelet_axis.start_near == 0)
    a.notes.push_back(fmt::format("no platelet within {} R of the axis at the start: no axis enrichment", kAxisRegion));

  if (axial) a.axial = axial->result();
  a.tube_hematocrit = hematocrit_sum / n;
  a.rbc_volume_flux = rbc_flux_sum / n;
  fluid_observables(a, run, cells_flux_sum / n);
  a.ends = end_fluxes(a, run, a.window_start, a.window_end);
  return a;
}

// ---- Output ----------------------------------------------------------------------------------

namespace {

// A fixed-point figure, or "n/a" for an undefined one.
std::string fixed(double v, int digits, double scale = 1) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v / scale, digits) : "n/a";
}

// JSON has no NaN: an undefined number is null.
nlohmann::ordered_json number(double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nullptr; }

// An outlet's shares as analysis.json names them, over the window ("branches") and per interval
// ("shares_over_time").
constexpr std::pair<const char*, double BranchShare::*> kShareFields[] = {
    {"blood_fraction", &BranchShare::blood},
    {"plasma_fraction", &BranchShare::plasma},
    {"rbc_fraction", &BranchShare::rbc},
    {"platelet_fraction", &BranchShare::platelet}};

nlohmann::ordered_json::json_pointer pointer(const std::string& dotted) {
  std::string p;
  for (char c : dotted) p += c == '.' ? '/' : c;
  return nlohmann::ordered_json::json_pointer("/" + p);
}

}  // namespace

std::string format_table(const Analysis& a) {
  std::string t;
  auto line = [&t](const std::string& label, const std::string& text) {
    t += fmt::format("  {:<18}{}\n", label, text);
  };
  t += fmt::format("{}: analysis\n", a.run_dir);
  line("vessel", fmt::format("{}d = {} µm, l = {} µm", a.surface ? a.shape + ", inlet " : "",
                             fixed(2 * a.tube.radius, 1, kUm), fixed(a.tube.length, 1, kUm)));
  line("window", fmt::format("t = {:.4g} .. {:.4g} s, {} snapshots{}", a.window_start, a.window_end, a.window_snapshots,
                             a.window_is_default ? " (default: second half of the run)" : ""));
  for (const auto& o : a.surface ? std::vector<Observable>{} : observable_table()) {
    std::string text = o.format(a);
    if (!o.shown.unit.empty()) text += fmt::format(" {}", o.shown.unit);
    if (o.detail) text = fmt::format("{:<14} [{}]", text, o.detail(a));
    line(std::string(o.label), text);
  }
  if (!a.axial.z.empty()) {
    t += fmt::format("  along the vessel ({}, {} stations; gaps to the local wall r = R(z)):\n", a.shape,
                     a.axial.z.size());
    t += fmt::format("    {:>7} {:>7} {:>8} {:>6} {:>6} {:>14} {:>16}\n", "z µm", "R µm", "CFL µm", "CFL/R", "Ht",
                     "plt near wall", "wall contacts");
    t += fmt::format("    {:>7} {:>7} {:>8} {:>6} {:>6} {:>14} {:>16}\n", "", "", "", "", "", "1/mm²", "1/(mm² s)");
    for (std::size_t k = 0; k < a.axial.z.size(); ++k)
      t += fmt::format("    {:>7} {:>7} {:>8} {:>6} {:>6} {:>14} {:>16}\n", fixed(a.axial.z[k], 1, kUm),
                       fixed(a.axial.radius[k], 2, kUm), fixed(a.axial.cfl[k], 2, kUm),
                       fixed(a.axial.cfl[k] / a.axial.radius[k], 3), fixed(a.axial.hematocrit[k], 3),
                       fixed(a.axial.platelet_near_wall[k], 1, 1e6), fixed(a.axial.wall_contact_rate[k], 1, 1e6));
  }
  if (!a.ends.empty()) {
    t += "  through the ends (window means; cells counted through each):\n";
    t += fmt::format("    {:<8} {:>12} {:>10} {:>12} {:>12} {:>6}\n", "", "plasma nl/s", "RBC 1/s", "platelet 1/s",
                     "blood nl/s", "H_D");
    for (const EndFlux& e : a.ends)
      t += fmt::format("    {:<8} {:>12} {:>10} {:>12} {:>12} {:>6}\n", e.end, fixed(e.plasma_flux, 3, 1e-12),
                       fixed(e.rbc_rate, 0), fixed(e.platelet_rate, 0), fixed(e.blood_flux(), 3, 1e-12),
                       fixed(e.discharge_hematocrit(), 3));
  }
  if (!a.branches.empty()) {
    t += "  each outlet's share of what leaves (phase separation: RBC against blood):\n";
    t += fmt::format("    {:<10} {:>7} {:>7} {:>7} {:>9}\n", "", "blood", "plasma", "RBC", "platelet");
    for (const BranchShare& b : a.branches)
      t += fmt::format("    {:<10} {:>7} {:>7} {:>7} {:>9}\n", b.outlet, fixed(b.blood, 3), fixed(b.plasma, 3),
                       fixed(b.rbc, 3), fixed(b.platelet, 3));
  }
  if (!a.branch_layers.empty()) {
    t += "  each branch (what passes its end; δ: the edge method in the branch's own sections):\n";
    t += fmt::format("    {:<11} {:<9} {:>6} {:>11} {:>7} {:>6} {:>6} {:>12} {:>10}\n", "", "end", "R µm", "span µm",
                     "δ µm", "δ/R", "H_D", "platelet 1/s", "plt/µl");
    for (std::size_t b = 0; b < a.branch_layers.size() && b < a.ends.size(); ++b) {
      const BranchLayer& l = a.branch_layers[b];
      const EndFlux& e = a.ends[b];
      t += fmt::format("    {:<11} {:<9} {:>6} {:>11} {:>7} {:>6} {:>6} {:>12} {:>10}\n", l.name, e.end,
                       fixed(l.radius, 1, kUm), fixed(l.span.start, 0, kUm) + ".." + fixed(l.span.end, 0, kUm),
                       fixed(l.whole.thickness, 2, kUm), fixed(l.whole.thickness / l.radius, 3),
                       fixed(e.discharge_hematocrit(), 3), fixed(e.platelet_rate, 0),
                       fixed(e.discharge_platelet_density(), 0, 1e9));
    }
    t += "  δ along each branch (µm, at s µm from its start: the inlet's or the junction's):\n";
    for (const BranchLayer& l : a.branch_layers) {
      std::string row;
      for (std::size_t k = 0; k < l.s.size(); ++k)
        row += fmt::format("  {}: {}", fixed(l.s[k], 0, kUm), fixed(l.station[k].thickness, 2, kUm));
      t += fmt::format("    {:<11}{}  ({} slices x {} sectors)\n", l.name, row, l.stations.axial, l.stations.sectors);
    }
  }
  for (const auto& n : a.notes) line("note", n);
  return t;
}

std::string format_json(const Analysis& a) {
  // The context around the observables; each observable is then put at its json_path.
  nlohmann::ordered_json j;
  j["run_dir"] = a.run_dir;
  j["units"] = "SI (m, s, m^2/s, m^3/s, Pa)";
  j["vessel"] = {{"radius_m", number(a.tube.radius)},
                 {"length_m", number(a.tube.length)},
                 {"shape", a.shape},
                 {"surface", a.surface}};
  if (!a.axial.z.empty()) {
    auto series = [](const std::vector<double>& v) {
      nlohmann::ordered_json out = nlohmann::ordered_json::array();
      for (double x : v) out.push_back(number(x));
      return out;
    };
    j["axial"] = {{"z_m", series(a.axial.z)},
                  {"radius_m", series(a.axial.radius)},
                  {"cfl_m", series(a.axial.cfl)},
                  {"hematocrit", series(a.axial.hematocrit)},
                  {"platelet_near_wall_per_m2", series(a.axial.platelet_near_wall)},
                  {"wall_contact_rate_per_m2_s", series(a.axial.wall_contact_rate)},
                  {"near_wall_gap_platelet_diameters", kNearWallDiameters},
                  {"contact_gap_platelet_diameters", kWallContactDiameters},
                  {"snapshots", a.axial.snapshots}};
  }
  for (const EndFlux& e : a.ends)
    j["ends"][e.end] = {
        {"plasma_flux_m3_s", number(e.plasma_flux)},  {"rbc_per_s", number(e.rbc_rate)},
        {"platelets_per_s", number(e.platelet_rate)}, {"rbc_volume_flux_m3_s", number(e.rbc_volume_flux)},
        {"blood_flux_m3_s", number(e.blood_flux())},  {"discharge_hematocrit", number(e.discharge_hematocrit())}};
  for (const BranchShare& b : a.branches)
    for (const auto& [name, share] : kShareFields) j["branches"][b.outlet][name] = number(b.*share);
  j["window"] = {{"start_s", number(a.window_start)},
                 {"end_s", number(a.window_end)},
                 {"snapshots", a.window_snapshots},
                 {"default_second_half", a.window_is_default}};
  if (!a.shares_over_time.empty()) {
    nlohmann::ordered_json over = {{"start_s", nlohmann::ordered_json::array()},
                                   {"end_s", nlohmann::ordered_json::array()}};
    for (const auto& interval : a.shares_over_time) {
      over["start_s"].push_back(number(interval.start));
      over["end_s"].push_back(number(interval.end));
      for (const BranchShare& b : interval.shares) {
        auto& o = over["outlets"][b.outlet];
        for (const auto& [name, share] : kShareFields) o[name].push_back(number(b.*share));
      }
    }
    j["shares_over_time"] = over;
  }
  for (std::size_t b = 0; b < a.branch_layers.size() && b < a.ends.size(); ++b) {
    const BranchLayer& l = a.branch_layers[b];
    const EndFlux& e = a.ends[b];
    nlohmann::ordered_json s = nlohmann::ordered_json::array(), delta = nlohmann::ordered_json::array(),
                           samples = nlohmann::ordered_json::array();
    for (std::size_t k = 0; k < l.s.size(); ++k) {
      s.push_back(number(l.s[k]));
      delta.push_back(number(l.station[k].thickness));
      samples.push_back(l.station[k].samples);
    }
    j["per_branch"][l.name] = {{"end", e.end},
                               {"radius_m", number(l.radius)},
                               {"axis_length_m", number(l.length)},
                               {"discharge_hematocrit", number(e.discharge_hematocrit())},
                               {"platelets_per_s", number(e.platelet_rate)},
                               {"discharge_platelet_density_per_m3", number(e.discharge_platelet_density())},
                               {"cfl",
                                {{"method", "edge, in the branch's own sections"},
                                 {"thickness_m", number(l.whole.thickness)},
                                 {"span_start_m", number(l.span.start)},
                                 {"span_end_m", number(l.span.end)},
                                 {"slices", l.stations.axial},
                                 {"sectors", l.stations.sectors},
                                 {"samples", l.whole.samples},
                                 {"empty_samples", l.whole.empty_samples},
                                 {"mean_rbc_count", number(l.mean_rbc_count)},
                                 {"stations", {{"s_m", s}, {"thickness_m", delta}, {"samples", samples}}}}}};
  }
  if (a.surface) {  // no tube: nothing radial to report
    j["notes"] = a.notes;
    return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
  }
  j["cfl"]["edge"] = {{"method", "edge"},
                      {"edge_mean_m", number(a.cfl_edge.edge_mean)},
                      {"edge_std_m", number(a.cfl_edge.edge_std)},
                      {"stations_axial", a.stations.axial},
                      {"stations_sectors", a.stations.sectors},
                      {"samples", a.cfl_edge.samples},
                      {"empty_samples", a.cfl_edge.empty_samples}};
  j["cfl"]["profile"] = {{"method", "profile"},
                         {"edge_m", number(a.cfl_profile.edge_mean)},
                         {"threshold_of_core_mean", 0.1},
                         {"core_radius_fraction", 0.5},
                         {"core_mean_volume_fraction", number(a.cfl_profile.core_mean_fraction)}};
  nlohmann::ordered_json msd = nlohmann::ordered_json::array();
  for (const auto& p : a.msd)
    msd.push_back({{"lag_s", number(p.lag_s)}, {"msd_m2", number(p.msd_m2)}, {"matched", p.matched}});
  j["diffusion"] = {{"fit", "MSD = 2 D t, least squares through the origin"},
                    {"t_fit_s", number(a.diffusion.t_fit)},
                    {"window_start_s", 0},
                    {"points", a.diffusion.points},
                    {"reference_time_s", number(a.msd_reference_time)},
                    {"msd", msd}};
  j["rheology"] = {
      {"samples", a.velocity_samples},
      {"wall_shear_rate_per_s", number(a.rheology.wall_shear_rate)},
      {"apparent_wall_shear_rate_per_s", number(a.rheology.apparent_wall_shear_rate)},
      {"mean_velocity_source", "Q / (pi R^2), Q the blood's volume flux (hematocrit.total_volume_flux_m3_s)"},
      {"plasma_mean_velocity_m_s", number(a.plasma_mean_velocity)},
      {"wall_shear_stress_Pa", number(a.wall_shear_stress)}};
  const auto& b = a.balance;
  j["momentum_balance"] = {
      {"relation", "tau_w,imposed = d dP / (4 l); realised gamma_w = tau_w / mu"},
      {"window_start_s", number(b.window_start)},
      {"window_end_s", number(b.window_end)},
      {"samples", b.samples},
      {"wall_shear_stress_end_Pa", number(b.end)},
      {"imposed_wall_shear_stress_Pa", number(b.imposed)},
      {"imposed_wall_shear_rate_per_s", number(b.imposed_wall_shear_rate())},
      {"mesh_ratio", number(b.mesh_ratio)},
      {"tolerance", kBalanceTolerance},
      {"settling_time_s", number(a.settling_time)},
      {"judged", a.balance_verdict.judged},
      {"holds", a.balance_verdict.judged ? nlohmann::ordered_json(a.balance_verdict.holds) : nullptr}};
  nlohmann::ordered_json times = nlohmann::ordered_json::array(), ratios = nlohmann::ordered_json::array();
  for (const auto& p : a.balance_over_time) {
    times.push_back(number(p.time_s));
    ratios.push_back(number(p.value));
  }
  j["momentum_balance"]["over_time"] = {{"time_s", times}, {"ratio", ratios}};
  const auto& e = a.platelet_axis;
  j["platelet_axis"] = {{"region_radius_fraction", kAxisRegion}, {"start_time_s", number(e.start_time)},
                        {"end_time_s", number(e.end_time)},      {"start_platelets", e.start_total},
                        {"end_platelets", e.end_total},          {"start_near_axis", e.start_near},
                        {"end_near_axis", e.end_near},           {"start_fraction", number(e.start_fraction)},
                        {"end_fraction", number(e.end_fraction)}};
  j["hematocrit"] = {{"rbc_volume_flux_m3_s", number(a.rbc_volume_flux)},
                     {"total_volume_flux_m3_s", number(a.total_volume_flux)},
                     {"total_flux_source", a.total_flux_source},
                     {"rbc_volume_m3", number(a.rbc_volume)}};
  j["margination"] = {{"cfl_method", "edge"}, {"inner_radius_m", number(a.tube.radius - a.cfl_edge.thickness)}};
  j["profiles"] = {{"bins", a.bins}, {"file", "profiles.csv"}};
  j["notes"] = a.notes;
  // The declaration too, so that a reader (hemocosim_plot.py) needs no list of its own.
  nlohmann::ordered_json declared = nlohmann::ordered_json::array();
  for (const auto& o : observable_table()) {
    j[pointer(std::string(o.json_path))] = number(o.value(a));
    const char* style = o.shown.style == Shown::Style::scientific ? "scientific"
                        : o.shown.style == Shown::Style::general  ? "general"
                                                                  : "fixed";
    declared.push_back({{"name", std::string(o.name)},
                        {"path", std::string(o.json_path)},
                        {"label", std::string(o.label)},
                        {"unit", std::string(o.unit)},
                        {"description", std::string(o.description)},
                        {"shown_unit", std::string(o.shown.unit)},
                        {"shown_scale", o.shown.scale},
                        {"shown_style", style},
                        {"sweep_panel", std::string(o.sweep_panel)},
                        {"sweep_series", std::string(o.sweep_series)}});
  }
  j["observables"] = declared;
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

std::string format_profiles_csv(const Analysis& a) {
  // Long format: the window mean first (t_start < t_end), then one block per snapshot
  // (t_start = t_end); the volume fraction is computed for the window only.
  std::string c = "t_start_s,t_end_s,r_inner_m,r_outer_m,r_mid_over_R,rbc_per_m3,platelet_per_m3,rbc_volume_fraction\n";
  auto block = [&](double t0, double t1, const std::vector<double>& rbc, const std::vector<double>& plt,
                   const std::vector<double>* phi) {
    for (int b = 0; b < a.bins; ++b)
      c += fmt::format("{:.9g},{:.9g},{:.9g},{:.9g},{:.6g},{:.9g},{:.9g},{}\n", t0, t1, a.bin_edges[b],
                       a.bin_edges[b + 1], (b + 0.5) / a.bins, rbc.empty() ? 0.0 : rbc[b], plt.empty() ? 0.0 : plt[b],
                       phi && !phi->empty() ? fmt::format("{:.9g}", (*phi)[b]) : "");
  };
  block(a.window_start, a.window_end, a.rbc_density, a.platelet_density, &a.rbc_volume_fraction);
  for (const auto& f : a.frames) block(f.time_s, f.time_s, f.rbc, f.platelet, nullptr);
  return c;
}

}  // namespace analysis

namespace {
void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw analysis::RunDataError(path + ": cannot write");
}
}  // namespace

int analyze_command(const AnalyzeOptions& opt) {
  const auto run = analysis::open_run(opt.run_dir);
  const auto a = analysis::analyze_run(run, opt);
  const std::string json = analysis::format_json(a);
  write_file(opt.run_dir + "/analysis.json", json);
  write_file(opt.run_dir + "/profiles.csv", analysis::format_profiles_csv(a));
  if (opt.json)
    fmt::print("{}", json);
  else
    fmt::print("{}  {:<18}{}/analysis.json, {}/profiles.csv\n", analysis::format_table(a), "files", opt.run_dir,
               opt.run_dir);
  return 0;
}

}  // namespace hemo
