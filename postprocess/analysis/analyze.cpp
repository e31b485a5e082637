// SPDX-License-Identifier: GPL-3.0-or-later
#include "analyze.h"

#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <limits>

namespace hemo {

namespace analysis {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kUm = 1e-6;
constexpr int kFineBins = 4096;  // centre histogram behind the RBC volume fraction

// The averaging window: the second half of the run unless asked otherwise.
void choose_window(Analysis& a, const RunData& run, double window_start) {
  const double first = run.snapshots.front().time_s, last = run.snapshots.back().time_s;
  a.window_is_default = !(window_start >= 0);
  a.window_start = a.window_is_default ? first + 0.5 * (last - first) : window_start;
  a.window_end = last;
  if (a.window_start > last)
    throw RunDataError(fmt::format("{}: window start {} s is after the last snapshot at {} s", run.particles_path,
                                   a.window_start, last));
}

// Window means of the fluid node's metrics, and what follows from them.
void fluid_observables(Analysis& a, const RunData& run, double mean_cells_flux) {
  const auto u = metric_series(run.metrics, "mean_velocity_m_s");
  const auto tau = metric_series(run.metrics, "wall_shear_stress_Pa");
  const auto sup = metric_series(run.metrics, "superficial_velocity_m_s");
  const double inf = std::numeric_limits<double>::infinity();
  const double mean_u = time_mean(u.time_s, u.value, a.window_start, inf);
  for (double t : u.time_s) a.velocity_samples += t >= a.window_start;
  if (u.empty()) a.notes.push_back("metrics.csv has no mean_velocity_m_s: no apparent viscosity");
  a.rheology = apparent_viscosity(mean_u, run.scene.vessel.diameter, run.scene.driving.wall_shear_rate);
  a.wall_shear_stress = time_mean(tau.time_s, tau.value, a.window_start, inf);

  const double mean_sup = time_mean(sup.time_s, sup.value, a.window_start, inf);
  if (std::isfinite(mean_sup)) {
    a.total_volume_flux = total_volume_flux(mean_sup, mean_cells_flux, a.tube);
    a.total_flux_source = "pi R^2 <alpha u_z> (superficial_velocity_m_s) + sum V_p v_z / L over all cells";
  } else {
    // Without the plasma's superficial velocity, the blood is taken to move at the plasma's mean.
    a.total_volume_flux = a.tube.cross_section() * mean_u;
    a.total_flux_source = "pi R^2 U (superficial_velocity_m_s not reported)";
  }
  a.discharge_hematocrit = discharge_hematocrit(a.rbc_volume_flux, a.total_volume_flux);
}

}  // namespace

Analysis analyze_run(const RunData& run, const AnalyzeOptions& opt) {
  const int bins = opt.bins;
  const double t_fit = opt.t_fit;
  if (run.snapshots.empty()) throw RunDataError(run.particles_path + ": no snapshots");
  if (bins < 1) throw RunDataError(fmt::format("bins must be at least 1 (got {})", bins));
  if (!(t_fit > 0)) throw RunDataError(fmt::format("t_fit must be positive (got {})", t_fit));
  Analysis a;
  a.run_dir = run.dir;
  a.tube = {run.scene.vessel.radius(), run.scene.vessel.length};
  a.rbc_diameter = run.scene.rbc.diameter;
  a.rbc_volume = run.scene.rbc.volume;
  a.platelet_volume = run.scene.platelet.volume;
  a.bins = bins;
  a.bin_edges = radial_bin_edges(a.tube, bins);
  choose_window(a, run, opt.window_start);

  const Snapshot first = run.load(0);
  const Cells reference = select_species(first, kPlatelet);
  a.msd_reference_time = first.time_s;

  std::vector<StationEdges> edges;
  std::vector<std::vector<double>> rbc_n, plt_n;
  std::vector<double> rbc_centres(kFineBins, 0.0);
  double margination_sum = 0, hematocrit_sum = 0, rbc_flux_sum = 0, cells_flux_sum = 0, rbc_count = 0, plt_count = 0;
  int margination_snapshots = 0;
  std::vector<std::vector<double>> window_platelet_r;
  bool stations_chosen = false;

  for (std::size_t i = 0; i < run.snapshots.size(); ++i) {
    const Snapshot s = i == 0 ? first : run.load(i);
    const Cells rbc = select_species(s, kRbc), plt = select_species(s, kPlatelet);
    a.frames.push_back({s.time_s, radial_number_density(rbc.r, a.tube, bins), radial_number_density(plt.r, a.tube, bins)});
    if (i > 0) a.msd.push_back(radial_msd(reference, first.time_s, plt, s.time_s));
    if (s.time_s < a.window_start) continue;

    // Stations are sized once, from the first window snapshot (the RBC count of a periodic
    // vessel does not change); counts given on the command line win.
    if (!stations_chosen) {
      a.stations = default_stations(static_cast<double>(rbc.size()), a.tube);
      if (opt.slices > 0) a.stations.axial = opt.slices;
      if (opt.sectors > 0) a.stations.sectors = opt.sectors;
      stations_chosen = true;
    }
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
  a.rbc_volume_fraction = radial_volume_fraction_from_histogram(rbc_centres, a.rbc_diameter, a.rbc_volume, a.tube, bins);
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
  if (a.diffusion.points == 0)
    a.notes.push_back(fmt::format("no MSD point in (0, {}] s: no D (output more often or raise --t-fit)", t_fit));
  else if (a.diffusion.points < 3)
    a.notes.push_back(fmt::format("D from only {} MSD point(s)", a.diffusion.points));
  if (a.diffusion.points > 0 && a.diffusion.window_end < 0.99 * t_fit)
    a.notes.push_back(fmt::format("the run ends before t_fit: D fitted over [0, {:.4g}] s only", a.diffusion.window_end));

  a.tube_hematocrit = hematocrit_sum / n;
  a.rbc_volume_flux = rbc_flux_sum / n;
  fluid_observables(a, run, cells_flux_sum / n);
  return a;
}

// ---- Output ----------------------------------------------------------------------------------

namespace {

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.9g}", v) : "null"; }

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      out += fmt::format("\\u{:04x}", static_cast<int>(c));
      continue;
    }
    out += c;
  }
  return out + "\"";
}

// A fixed-point figure, or "n/a" for an undefined one.
std::string fixed(double v, int digits, double scale = 1) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v / scale, digits) : "n/a";
}
std::string sci(double v) { return std::isfinite(v) ? fmt::format("{:.3e}", v) : "n/a"; }

}  // namespace

std::string format_table(const Analysis& a) {
  std::string t;
  auto line = [&t](const std::string& label, const std::string& text) { t += fmt::format("  {:<18}{}\n", label, text); };
  t += fmt::format("{}: analysis\n", a.run_dir);
  line("vessel", fmt::format("d = {} um, l = {} um; {} RBCs, {} platelets (window mean)", fixed(2 * a.tube.radius, 1, kUm),
                             fixed(a.tube.length, 1, kUm), fixed(a.mean_rbc_count, 0), fixed(a.mean_platelet_count, 0)));
  line("window", fmt::format("t = {:.4g} .. {:.4g} s, {} snapshots{}", a.window_start, a.window_end, a.window_snapshots,
                             a.window_is_default ? " (default: second half of the run)" : ""));
  line("CFL thickness", fmt::format("delta = {} um  [edge method: {} x {} stations, {} samples, {} empty; edge {} +- {} um]",
                                    fixed(a.cfl_edge.thickness, 2, kUm), a.stations.axial, a.stations.sectors,
                                    a.cfl_edge.samples, a.cfl_edge.empty_samples, fixed(a.cfl_edge.edge_mean, 2, kUm),
                                    fixed(a.cfl_edge.edge_std, 2, kUm)));
  line("", fmt::format("delta = {} um  [profile method: RBC volume fraction < 10% of core mean {}]",
                       fixed(a.cfl_profile.thickness, 2, kUm), fixed(a.cfl_profile.core_mean_fraction, 3)));
  line("radial diffusion", fmt::format("D = {} m^2/s  [MSD = 2 D t through the origin over [0, {:.4g}] s: {} points, "
                                       "{} platelets; t = 0 at {:.4g} s]",
                                       sci(a.diffusion.diffusivity), a.diffusion.points > 0 ? a.diffusion.window_end : 0.0,
                                       a.diffusion.points, a.msd.empty() ? 0 : a.msd.front().matched, a.msd_reference_time));
  line("mean velocity", fmt::format("U = {} m/s  [{} samples]", sci(a.rheology.mean_velocity), a.velocity_samples));
  line("wall shear rate", fmt::format("imposed {} 1/s, apparent 8U/d = {} 1/s", fixed(a.rheology.wall_shear_rate, 1),
                                      fixed(a.rheology.apparent_wall_shear_rate, 1)));
  line("wall shear stress", fmt::format("{} Pa  [fluid node]", fixed(a.wall_shear_stress, 4)));
  line("viscosity", fmt::format("mu_app/mu = {}", fixed(a.rheology.relative_viscosity, 3)));
  line("hematocrit", fmt::format("tube H_T = {}, discharge H_D = {}  [H_D = Q_RBC / Q, Q = {}]", fixed(a.tube_hematocrit, 4),
                                 fixed(a.discharge_hematocrit, 4), a.total_flux_source));
  line("margination", fmt::format("index = {}  [platelets with r > R - delta, edge-method delta]",
                                  fixed(a.margination_index, 3)));
  for (const auto& n : a.notes) line("note", n);
  return t;
}

std::string format_json(const Analysis& a) {
  std::string j = "{\n";
  j += fmt::format("  \"run_dir\": {},\n", quoted(a.run_dir));
  j += fmt::format("  \"units\": \"SI (m, s, m^2/s, m^3/s, Pa)\",\n");
  j += fmt::format("  \"vessel\": {{\"radius_m\": {}, \"length_m\": {}}},\n", num(a.tube.radius), num(a.tube.length));
  j += fmt::format(
      "  \"window\": {{\"start_s\": {}, \"end_s\": {}, \"snapshots\": {}, \"default_second_half\": {}, "
      "\"mean_rbc_count\": {}, \"mean_platelet_count\": {}}},\n",
      num(a.window_start), num(a.window_end), a.window_snapshots, a.window_is_default ? "true" : "false",
      num(a.mean_rbc_count), num(a.mean_platelet_count));
  j += fmt::format(
      "  \"cfl\": {{\n    \"edge\": {{\"method\": \"edge\", \"thickness_m\": {}, \"edge_mean_m\": {}, \"edge_std_m\": {}, "
      "\"stations_axial\": {}, \"stations_sectors\": {}, \"samples\": {}, \"empty_samples\": {}}},\n",
      num(a.cfl_edge.thickness), num(a.cfl_edge.edge_mean), num(a.cfl_edge.edge_std), a.stations.axial,
      a.stations.sectors, a.cfl_edge.samples, a.cfl_edge.empty_samples);
  j += fmt::format(
      "    \"profile\": {{\"method\": \"profile\", \"thickness_m\": {}, \"edge_m\": {}, \"threshold_of_core_mean\": 0.1, "
      "\"core_radius_fraction\": 0.5, \"core_mean_volume_fraction\": {}}}\n  }},\n",
      num(a.cfl_profile.thickness), num(a.cfl_profile.edge_mean), num(a.cfl_profile.core_mean_fraction));
  j += fmt::format(
      "  \"diffusion\": {{\"D_m2_s\": {}, \"fit\": \"MSD = 2 D t, least squares through the origin\", \"t_fit_s\": {}, "
      "\"window_start_s\": 0, \"window_end_s\": {}, \"points\": {}, \"reference_time_s\": {},\n    \"msd\": [",
      num(a.diffusion.diffusivity), num(a.diffusion.t_fit), num(a.diffusion.window_end), a.diffusion.points,
      num(a.msd_reference_time));
  for (std::size_t i = 0; i < a.msd.size(); ++i)
    j += fmt::format("{}{{\"lag_s\": {}, \"msd_m2\": {}, \"matched\": {}}}", i ? ", " : "", num(a.msd[i].lag_s),
                     num(a.msd[i].msd_m2), a.msd[i].matched);
  j += "]},\n";
  j += fmt::format(
      "  \"rheology\": {{\"mean_velocity_m_s\": {}, \"samples\": {}, \"wall_shear_rate_per_s\": {}, "
      "\"apparent_wall_shear_rate_per_s\": {}, \"relative_apparent_viscosity\": {}, \"wall_shear_stress_Pa\": {}}},\n",
      num(a.rheology.mean_velocity), a.velocity_samples, num(a.rheology.wall_shear_rate),
      num(a.rheology.apparent_wall_shear_rate), num(a.rheology.relative_viscosity), num(a.wall_shear_stress));
  j += fmt::format(
      "  \"hematocrit\": {{\"tube\": {}, \"discharge\": {}, \"rbc_volume_flux_m3_s\": {}, \"total_volume_flux_m3_s\": {}, "
      "\"total_flux_source\": {}, \"rbc_volume_m3\": {}}},\n",
      num(a.tube_hematocrit), num(a.discharge_hematocrit), num(a.rbc_volume_flux), num(a.total_volume_flux),
      quoted(a.total_flux_source), num(a.rbc_volume));
  j += fmt::format("  \"margination\": {{\"index\": {}, \"cfl_method\": \"edge\", \"inner_radius_m\": {}}},\n",
                   num(a.margination_index), num(a.tube.radius - a.cfl_edge.thickness));
  j += fmt::format("  \"profiles\": {{\"bins\": {}, \"file\": \"profiles.csv\"}},\n", a.bins);
  j += "  \"notes\": [";
  for (std::size_t i = 0; i < a.notes.size(); ++i) j += (i ? ", " : "") + quoted(a.notes[i]);
  j += "]\n}\n";
  return j;
}

std::string format_profiles_csv(const Analysis& a) {
  // Long format: the window mean first (t_start < t_end), then one block per snapshot
  // (t_start = t_end); the volume fraction is computed for the window only.
  std::string c = "t_start_s,t_end_s,r_inner_m,r_outer_m,r_mid_over_R,rbc_per_m3,platelet_per_m3,rbc_volume_fraction\n";
  auto block = [&](double t0, double t1, const std::vector<double>& rbc, const std::vector<double>& plt,
                   const std::vector<double>* phi) {
    for (int b = 0; b < a.bins; ++b)
      c += fmt::format("{:.9g},{:.9g},{:.9g},{:.9g},{:.6g},{:.9g},{:.9g},{}\n", t0, t1, a.bin_edges[b], a.bin_edges[b + 1],
                       (b + 0.5) / a.bins, rbc.empty() ? 0.0 : rbc[b], plt.empty() ? 0.0 : plt[b],
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
