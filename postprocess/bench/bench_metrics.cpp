// SPDX-License-Identifier: GPL-3.0-or-later
#include "bench_metrics.h"

#include "analyze.h"
#include "plot.h"
#include "run_data.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace hemo::bench {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

RunCost read_profile(const std::string& run_dir) {
  RunCost c{kNaN, kNaN, kNaN, kNaN, kNaN};
  std::ifstream in(run_dir + "/profile.csv");
  std::string line;
  std::getline(in, line);  // header node,phase,total_s,per_step_ms
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string node, phase, total;
    std::getline(ss, node, ',');
    std::getline(ss, phase, ',');
    std::getline(ss, total, ',');
    const double v = total.empty() ? kNaN : std::strtod(total.c_str(), nullptr);
    if (node == "fluid" && phase == "compute_s") c.fluid_compute_s = v;
    if (node == "particles" && phase == "compute_s") c.particle_compute_s = v;
    if (node == "fluid" && phase == "peak_memory_MiB") c.fluid_peak_mib = v;
    if (node == "particles" && phase == "peak_memory_MiB") c.particle_peak_mib = v;
    if (node == "lockstep" && phase == "coupling_overhead_s") c.coupling_overhead_s = v;
  }
  return c;
}

std::vector<double> radial_fractions(const std::vector<double>& r, double radius) {
  if (r.empty()) return {};
  std::vector<double> f(kProfileBins, 0.0);
  for (double x : r) {
    int b = static_cast<int>(std::floor(x / radius * kProfileBins));
    b = std::max(0, std::min(kProfileBins - 1, b));
    f[b] += 1.0 / static_cast<double>(r.size());
  }
  return f;
}

double mean_of(const std::vector<double>& r) {
  if (r.empty()) return kNaN;
  double s = 0;
  for (double x : r) s += x;
  return s / static_cast<double>(r.size());
}

double l1_distance(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.empty() || a.size() != b.size()) return kNaN;
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += std::abs(a[i] - b[i]);
  return s;
}

double relative_error(double x, double ref) {
  if (!std::isfinite(x) || !std::isfinite(ref) || ref == 0) return kNaN;
  return std::abs(x - ref) / std::abs(ref);
}

RunMeasures measure_run(const std::string& run_dir) {
  const analysis::Analysis a = analyze_run_dir(run_dir);
  const analysis::RunData run = analysis::open_run(run_dir);
  RunMeasures m;
  m.mean_velocity = a.rheology.mean_velocity;
  m.diffusivity = a.diffusion.diffusivity;
  const analysis::Snapshot last = run.load(run.snapshots.size() - 1);
  const auto rbc = analysis::select_species(last, analysis::kRbc);
  const auto plt = analysis::select_species(last, analysis::kPlatelet);
  m.rbcs = static_cast<long>(rbc.size());
  m.platelets = static_cast<long>(plt.size());
  m.mean_r_rbc = mean_of(rbc.r);
  m.mean_r_platelet = mean_of(plt.r);
  m.profile_rbc = radial_fractions(rbc.r, a.tube.radius);
  m.profile_platelet = radial_fractions(plt.r, a.tube.radius);
  return m;
}

BenchErrors errors_against(const RunMeasures& run, const RunMeasures& ref) {
  BenchErrors e;
  e.u = relative_error(run.mean_velocity, ref.mean_velocity);
  e.r_platelet = relative_error(run.mean_r_platelet, ref.mean_r_platelet);
  e.r_rbc = relative_error(run.mean_r_rbc, ref.mean_r_rbc);
  e.d = relative_error(run.diffusivity, ref.diffusivity);
  e.l1_platelet = l1_distance(run.profile_platelet, ref.profile_platelet);
  e.l1_rbc = l1_distance(run.profile_rbc, ref.profile_rbc);
  e.d_noise = run.platelets > 0 ? std::sqrt(2.0 / static_cast<double>(run.platelets)) : kNaN;
  return e;
}

DemFloor read_dem_floor(const std::string& run_dir) {
  const std::string file = run_dir + "/dem-bench.json";
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file + ": missing");
  try {
    const auto j = nlohmann::json::parse(in);
    DemFloor f;
    f.particles = j.at("particles").get<long>();
    f.ranks = j.at("ranks").get<int>();
    f.dem_ns = j.at("intervals").at("ns_per_particle_step").get<double>();
    f.callback_ns = j.at("intervals").at("callback_ns").get<double>();
    f.one_run_ns = j.at("one_run").at("ns_per_particle_step").get<double>();
    f.bare_ns = j.at("bare_liggghts").at("ns_per_particle_step").get<double>();
    f.bare_particles = j.at("bare_liggghts").at("particles").get<long>();
    f.peak_mib = j.at("peak_memory_MiB_per_rank").get<double>();
    f.neighbour_rebuild = j.at("neighbour_rebuild").get<std::string>();
    f.builds_per_1000 = j.at("intervals").at("neighbour_builds_per_1000_steps").get<double>();
    f.bare_builds_per_1000 = j.at("bare_liggghts").at("neighbour_builds_per_1000_steps").get<double>();
    if (j.contains("bare_liggghts_streaming")) {
      f.has_bare_streaming = true;
      f.bare_streaming_ns = j.at("bare_liggghts_streaming").at("ns_per_particle_step").get<double>();
      f.bare_streaming_builds_per_1000 =
          j.at("bare_liggghts_streaming").at("neighbour_builds_per_1000_steps").get<double>();
    }
    return f;
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(file + ": " + e.what());
  }
}

}  // namespace hemo::bench
