// SPDX-License-Identifier: GPL-3.0-or-later
#include "observables.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <tuple>
#include <unordered_map>

namespace hemo::analysis {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Wraps an unwrapped axial coordinate into [0, L).
double wrap_axial(double z, double length) {
  double w = std::fmod(z, length);
  if (w < 0) w += length;
  return w >= length ? 0 : w;
}

int bin_of(double r, const Tube& tube, int bins) {
  const int b = static_cast<int>(std::floor(r / tube.radius * bins));
  return std::clamp(b, 0, bins - 1);
}

// Gauss-Legendre nodes and weights on [-1, 1] by Newton iteration on P_n.
template <int N>
struct GaussLegendre {
  std::array<double, N> x{}, w{};
  GaussLegendre() {
    for (int i = 0; i < N; ++i) {
      double t = std::cos(kPi * (i + 0.75) / (N + 0.5));
      double dp = 0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1, p1 = t;
        for (int k = 2; k <= N; ++k) {
          const double p2 = ((2 * k - 1) * t * p1 - (k - 1) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = N * (t * p1 - p0) / (t * t - 1);
        const double step = p1 / dp;
        t -= step;
        if (std::abs(step) < 1e-15) break;
      }
      x[i] = t;
      w[i] = 2 / ((1 - t * t) * dp * dp);
    }
  }
};

// Area of the overlap of a circle of radius rho centred on the axis and a circle of radius s
// whose centre is at distance c from it.
double circle_overlap_area(double rho, double s, double c) {
  if (rho <= 0 || s <= 0) return 0;
  if (c >= rho + s) return 0;
  if (c <= std::abs(rho - s)) {
    const double m = std::min(rho, s);
    return kPi * m * m;
  }
  const double a1 = std::clamp((c * c + rho * rho - s * s) / (2 * c * rho), -1.0, 1.0);
  const double a2 = std::clamp((c * c + s * s - rho * rho) / (2 * c * s), -1.0, 1.0);
  const double k = (-c + rho + s) * (c + rho - s) * (c - rho + s) * (c + rho + s);
  return rho * rho * std::acos(a1) + s * s * std::acos(a2) - 0.5 * std::sqrt(std::max(k, 0.0));
}

}  // namespace

double Tube::cross_section() const { return kPi * radius * radius; }
double Tube::volume() const { return mean_section() * length; }

Cells select_species(const Snapshot& s, std::int8_t species) {
  Cells c;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.species[i] != species) continue;
    const double x = s.position[3 * i], y = s.position[3 * i + 1];
    c.id.push_back(s.id[i]);
    c.r.push_back(std::hypot(x, y));
    c.theta.push_back(std::atan2(y, x));
    c.z.push_back(s.position[3 * i + 2]);
    c.vz.push_back(s.velocity[3 * i + 2]);
  }
  return c;
}

// ---- Radial number-density profile ---------------------------------------------------------

std::vector<double> radial_bin_edges(const Tube& tube, int bins) {
  std::vector<double> e(bins + 1);
  for (int b = 0; b <= bins; ++b) e[b] = tube.radius * b / bins;
  return e;
}

std::vector<double> annulus_volumes(const Tube& tube, int bins) {
  const auto e = radial_bin_edges(tube, bins);
  std::vector<double> v(bins);
  for (int b = 0; b < bins; ++b) v[b] = kPi * (e[b + 1] * e[b + 1] - e[b] * e[b]) * tube.length;
  return v;
}

std::vector<double> radial_number_density(const std::vector<double>& r, const Tube& tube, int bins) {
  std::vector<double> n(bins, 0.0);
  for (double ri : r) n[bin_of(ri, tube, bins)] += 1;
  const auto v = annulus_volumes(tube, bins);
  for (int b = 0; b < bins; ++b) n[b] /= v[b];
  return n;
}

std::vector<double> average_profiles(const std::vector<std::vector<double>>& profiles) {
  if (profiles.empty()) return {};
  std::vector<double> mean(profiles.front().size(), 0.0);
  for (const auto& p : profiles)
    for (std::size_t b = 0; b < mean.size(); ++b) mean[b] += p[b];
  for (double& m : mean) m /= static_cast<double>(profiles.size());
  return mean;
}

// ---- RBC volume fraction profile -------------------------------------------------------------

double sphere_volume_inside_cylinder(double a, double c, double rho) {
  if (rho <= 0 || a <= 0) return 0;
  if (c >= rho + a) return 0;
  if (c + a <= rho) return 4.0 / 3.0 * kPi * a * a * a;
  // V = 2 int_0^{pi/2} A(rho, a cos t, c) a cos t dt. The slice area has kinks where a slice
  // circle becomes tangent to the cylinder (s = |rho - c|, s = rho + c); splitting the interval
  // there keeps each panel smooth enough for Gauss-Legendre.
  static const GaussLegendre<16> gl;
  std::vector<double> cuts{0.0, kPi / 2};
  for (double s : {std::abs(rho - c), rho + c})
    if (s > 0 && s < a) cuts.push_back(std::acos(s / a));
  std::sort(cuts.begin(), cuts.end());
  double sum = 0;
  for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
    const double mid = 0.5 * (cuts[k] + cuts[k + 1]), half = 0.5 * (cuts[k + 1] - cuts[k]);
    if (half <= 0) continue;
    for (int i = 0; i < 16; ++i) {
      const double t = mid + half * gl.x[i];
      const double s = a * std::cos(t);
      sum += half * gl.w[i] * circle_overlap_area(rho, s, c) * s;
    }
  }
  return 2 * sum;
}

namespace {
// Spreads cells (centre distance r_k, weight w_k cells) over the annuli they overlap.
std::vector<double> spread_spheres(const std::vector<double>& r, const std::vector<double>* weight, double diameter,
                                   double cell_volume, const Tube& tube, int bins) {
  const double a = diameter / 2;
  const double scale = cell_volume / (kPi / 6 * diameter * diameter * diameter);
  const auto edges = radial_bin_edges(tube, bins);
  const auto vol = annulus_volumes(tube, bins);
  std::vector<double> f(bins, 0.0);
  for (std::size_t k = 0; k < r.size(); ++k) {
    const double w = weight ? (*weight)[k] : 1.0;
    if (w == 0) continue;
    const double c = r[k];
    // Only the annuli the sphere can reach; the part beyond R (soft wall contact) is not in
    // the vessel and is left out.
    const int lo = bin_of(std::max(c - a, 0.0), tube, bins);
    const int hi = bin_of(c + a, tube, bins);
    double inside_lo = sphere_volume_inside_cylinder(a, c, edges[lo]);
    for (int b = lo; b <= hi; ++b) {
      const double inside_hi = sphere_volume_inside_cylinder(a, c, edges[b + 1]);
      f[b] += w * scale * (inside_hi - inside_lo);
      inside_lo = inside_hi;
    }
  }
  for (int b = 0; b < bins; ++b) f[b] /= vol[b];
  return f;
}
}  // namespace

std::vector<double> radial_volume_fraction(const std::vector<double>& r, double diameter, double cell_volume,
                                           const Tube& tube, int bins) {
  return spread_spheres(r, nullptr, diameter, cell_volume, tube, bins);
}

std::vector<double> centre_histogram(const std::vector<double>& r, const Tube& tube, int fine_bins) {
  std::vector<double> counts(fine_bins, 0.0);
  for (double ri : r) counts[bin_of(ri, tube, fine_bins)] += 1;
  return counts;
}

std::vector<double> radial_volume_fraction_from_histogram(const std::vector<double>& counts, double diameter,
                                                          double cell_volume, const Tube& tube, int bins) {
  const double h = tube.radius / static_cast<double>(counts.size());
  std::vector<double> middle(counts.size());
  for (std::size_t k = 0; k < counts.size(); ++k) middle[k] = (k + 0.5) * h;
  return spread_spheres(middle, &counts, diameter, cell_volume, tube, bins);
}

// ---- Cell-free layer thickness ---------------------------------------------------------------

Stations default_stations(double mean_rbc_count, const Tube& tube, double per_station) {
  const double n = mean_rbc_count / per_station;
  const double ratio = 18 * tube.radius / tube.length;  // sectors per slice, 24/16 at d/l = 1/6
  if (!(n >= 1) || !(ratio > 0)) return {1, 1};
  const double axial = std::sqrt(n / ratio);
  Stations st;
  st.axial = std::max(1, static_cast<int>(std::lround(axial)));
  st.sectors = std::max(1, static_cast<int>(std::lround(axial >= 0.5 ? axial * ratio : n)));
  return st;
}

StationEdges rbc_core_edges(const Cells& rbc, double rbc_diameter, const Tube& tube, const Stations& st) {
  std::vector<double> edge(st.count(), -1.0);
  for (std::size_t i = 0; i < rbc.size(); ++i) {
    const double zw = wrap_axial(rbc.z[i], tube.length);
    const int ia = std::clamp(static_cast<int>(zw / tube.length * st.axial), 0, st.axial - 1);
    const int is = std::clamp(static_cast<int>((rbc.theta[i] + kPi) / (2 * kPi) * st.sectors), 0, st.sectors - 1);
    double& e = edge[ia * st.sectors + is];
    e = std::max(e, rbc.r[i] + rbc_diameter / 2);
  }
  StationEdges out;
  for (double e : edge) {
    if (e < 0)
      ++out.empty;
    else
      out.edge.push_back(e);
  }
  return out;
}

CflThickness cfl_thickness_edge(const std::vector<StationEdges>& per_snapshot, const Tube& tube) {
  CflThickness c;
  c.method = "edge";
  double sum = 0, sum2 = 0;
  for (const auto& s : per_snapshot) {
    c.empty_samples += s.empty;
    for (double e : s.edge) {
      sum += e;
      sum2 += e * e;
      ++c.samples;
    }
  }
  if (c.samples == 0) {
    c.thickness = c.edge_mean = c.edge_std = kNaN;
    return c;
  }
  c.edge_mean = sum / c.samples;
  c.edge_std = std::sqrt(std::max(sum2 / c.samples - c.edge_mean * c.edge_mean, 0.0));
  c.thickness = tube.radius - c.edge_mean;
  return c;
}

CflThickness cfl_thickness_profile(const std::vector<double>& f, const Tube& tube, double threshold,
                                   double core_radius_fraction) {
  CflThickness c;
  c.method = "profile";
  c.thickness = c.edge_mean = c.core_mean_fraction = kNaN;
  c.edge_std = 0;
  const int bins = static_cast<int>(f.size());
  if (bins == 0) return c;
  const auto vol = annulus_volumes(tube, bins);
  const double width = tube.radius / bins;
  auto centre = [&](int b) { return (b + 0.5) * width; };
  double fv = 0, v = 0;
  for (int b = 0; b < bins && centre(b) < core_radius_fraction * tube.radius; ++b) {
    fv += f[b] * vol[b];
    v += vol[b];
  }
  if (v <= 0 || fv <= 0) return c;
  c.core_mean_fraction = fv / v;
  const double level = threshold * c.core_mean_fraction;
  // From the wall inward: a dip inside the core (layering) must not end the core early.
  int last = -1;
  for (int b = bins - 1; b >= 0; --b)
    if (f[b] >= level) {
      last = b;
      break;
    }
  if (last < 0) return c;
  if (last == bins - 1) {
    c.edge_mean = tube.radius;  // cells reach the wall: no cell-free layer
  } else {
    const double drop = f[last] - f[last + 1];
    const double frac = drop > 0 ? (f[last] - level) / drop : 0;
    c.edge_mean = centre(last) + frac * width;
  }
  c.thickness = tube.radius - c.edge_mean;
  return c;
}

// ---- Radial mean squared displacement and diffusivity ----------------------------------------

MsdPoint radial_msd(const Cells& reference, double t_reference, const Cells& now, double t_now) {
  std::unordered_map<std::int64_t, double> r0;
  r0.reserve(reference.size());
  for (std::size_t i = 0; i < reference.size(); ++i) r0.emplace(reference.id[i], reference.r[i]);
  MsdPoint p;
  p.lag_s = t_now - t_reference;
  double sum = 0;
  for (std::size_t i = 0; i < now.size(); ++i) {
    const auto it = r0.find(now.id[i]);
    if (it == r0.end()) continue;
    const double d = now.r[i] - it->second;
    sum += d * d;
    ++p.matched;
  }
  p.msd_m2 = p.matched > 0 ? sum / p.matched : kNaN;
  return p;
}

Cells radii_at_nominal_wall(const Cells& cells, const VesselGeometry& vessel) {
  if (vessel.uniform()) return cells;
  Cells out = cells;
  for (std::size_t i = 0; i < out.size(); ++i)
    out.r[i] = cells.r[i] * vessel.nominal_radius() / vessel.radius_at(cells.z[i]);
  return out;
}

DiffusionFit fit_diffusivity(const std::vector<MsdPoint>& msd, double t_fit) {
  DiffusionFit fit;
  fit.t_fit = t_fit;
  double st2 = 0, stm = 0;
  for (const auto& p : msd) {
    // Small tolerance: output times are sums of coupling intervals and t_fit is often one of them.
    if (!(p.lag_s > 0) || p.lag_s > t_fit * (1 + 1e-9) || !std::isfinite(p.msd_m2)) continue;
    st2 += p.lag_s * p.lag_s;
    stm += p.lag_s * p.msd_m2;
    fit.window_end = std::max(fit.window_end, p.lag_s);
    ++fit.points;
  }
  fit.diffusivity = fit.points > 0 ? stm / st2 / 2 : kNaN;
  return fit;
}

// ---- Apparent viscosity ----------------------------------------------------------------------

ApparentViscosity apparent_viscosity(double mean_velocity, double diameter, double wall_shear_rate) {
  ApparentViscosity a;
  a.mean_velocity = mean_velocity;
  a.wall_shear_rate = wall_shear_rate;
  a.apparent_wall_shear_rate = 8 * mean_velocity / diameter;
  a.relative_viscosity = a.apparent_wall_shear_rate > 0 ? wall_shear_rate / a.apparent_wall_shear_rate : kNaN;
  return a;
}

double time_mean(const std::vector<double>& t, const std::vector<double>& value, double t_start, double t_end) {
  double sum = 0;
  long n = 0;
  for (std::size_t i = 0; i < t.size() && i < value.size(); ++i) {
    if (t[i] < t_start || t[i] > t_end) continue;
    sum += value[i];
    ++n;
  }
  return n > 0 ? sum / n : kNaN;
}

// ---- Through an open vessel's ends ----------------------------------------------------------

double EndFlux::discharge_hematocrit() const {
  return hemo::analysis::discharge_hematocrit(rbc_volume_flux, blood_flux());
}

double EndFlux::discharge_platelet_density() const {
  const double blood = blood_flux();
  return blood != 0 ? platelet_rate / blood : kNaN;
}

std::vector<BranchShare> branch_shares(const std::vector<EndFlux>& outlets) {
  double blood = 0, plasma = 0, rbc = 0, platelet = 0;
  for (const EndFlux& e : outlets) {
    blood += e.blood_flux();
    plasma += e.plasma_flux;
    rbc += e.rbc_rate;
    platelet += e.platelet_rate;
  }
  auto share = [](double part, double whole) { return whole > 0 ? part / whole : kNaN; };
  std::vector<BranchShare> out;
  for (const EndFlux& e : outlets)
    out.push_back({e.end, share(e.blood_flux(), blood), share(e.plasma_flux, plasma), share(e.rbc_rate, rbc),
                   share(e.platelet_rate, platelet)});
  return out;
}

double window_rate(const std::vector<double>& t, const std::vector<double>& count, double t_start, double t_end) {
  if (!(t_end > t_start)) return kNaN;
  auto at = [&](double when) {
    double value = kNaN;
    for (std::size_t i = 0; i < t.size() && i < count.size() && t[i] <= when; ++i) value = count[i];
    return value;
  };
  return (at(t_end) - at(t_start)) / (t_end - t_start);
}

// ---- Momentum balance ------------------------------------------------------------------------

double WallShearBalance::ratio() const { return imposed > 0 ? mean / imposed : kNaN; }
double WallShearBalance::wall_shear_rate() const { return viscosity > 0 ? mean / viscosity : kNaN; }
double WallShearBalance::imposed_wall_shear_rate() const { return viscosity > 0 ? imposed / viscosity : kNaN; }

WallShearBalance wall_shear_balance(const std::vector<double>& t, const std::vector<double>& tau, double t_start,
                                    double t_end, double imposed, double viscosity, double mesh_ratio) {
  WallShearBalance b;
  b.imposed = imposed;
  b.viscosity = viscosity;
  b.mesh_ratio = mesh_ratio;
  b.window_start = t_start;
  b.window_end = t_end;
  b.mean = time_mean(t, tau, t_start, t_end);
  b.end = kNaN;
  double end_time = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < t.size() && i < tau.size(); ++i) {
    if (t[i] < t_start || t[i] > t_end) continue;
    ++b.samples;
    if (t[i] >= end_time) {
      end_time = t[i];
      b.end = tau[i];
    }
  }
  return b;
}

double settling_time(double diameter, double kinematic_viscosity) {
  return std::max(kSuspensionSettling_s, diameter * diameter / kinematic_viscosity);
}

BalanceVerdict judge_balance(const WallShearBalance& b, double settling_time_s, double tolerance) {
  BalanceVerdict v;
  const double ratio = b.ratio();
  if (b.samples == 0 || !std::isfinite(ratio)) {
    v.why_not_judged = "no wall_shear_stress_Pa in the window";
    return v;
  }
  if (b.window_start < settling_time_s) {
    v.why_not_judged = fmt::format("the window starts at {:.4g} s, before the flow has settled ({:.4g} s)",
                                   b.window_start, settling_time_s);
    return v;
  }
  v.judged = true;
  const double low = b.mesh_ratio * (1 - tolerance), high = 1 + tolerance;
  v.holds = ratio >= low && ratio <= high;
  if (!v.holds)
    v.line = fmt::format(
        "momentum balance: wall shear stress {:.3f} Pa is {:.3f} of the imposed {:.3f} Pa over t = {:.4g} .. {:.4g} s "
        "(it holds from {:.3f} to {:.3f}: {:.3f} on this mesh, {:g} % tolerance)",
        b.mean, ratio, b.imposed, b.window_start, b.window_end, low, high, b.mesh_ratio, 100 * tolerance);
  return v;
}

std::vector<SeriesPoint> binned_means(const std::vector<double>& t, const std::vector<double>& value, int bins) {
  const std::size_t n = std::min(t.size(), value.size());
  if (n == 0 || bins < 1) return {};
  const auto [lo, hi] = std::minmax_element(t.begin(), t.begin() + static_cast<long>(n));
  const double t0 = *lo, span = *hi - *lo;
  std::vector<double> sum_t(bins, 0.0), sum_v(bins, 0.0);
  std::vector<long> count(bins, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const int b = span > 0 ? std::min(bins - 1, static_cast<int>((t[i] - t0) / span * bins)) : 0;
    sum_t[b] += t[i];
    sum_v[b] += value[i];
    ++count[b];
  }
  std::vector<SeriesPoint> out;
  for (int b = 0; b < bins; ++b)
    if (count[b] > 0) out.push_back({sum_t[b] / count[b], sum_v[b] / count[b]});
  return out;
}

// ---- Platelets on the axis -------------------------------------------------------------------

AxisEnrichment axis_enrichment(const std::vector<double>& start_r, double start_time, const std::vector<double>& end_r,
                               double end_time, double radius, double region) {
  AxisEnrichment e;
  const double limit = region * radius;
  auto near = [limit](const std::vector<double>& r) {
    return static_cast<long>(std::count_if(r.begin(), r.end(), [limit](double ri) { return ri < limit; }));
  };
  e.start_time = start_time;
  e.end_time = end_time;
  e.start_total = static_cast<long>(start_r.size());
  e.end_total = static_cast<long>(end_r.size());
  e.start_near = near(start_r);
  e.end_near = near(end_r);
  e.start_fraction = e.start_total > 0 ? double(e.start_near) / double(e.start_total) : kNaN;
  e.end_fraction = e.end_total > 0 ? double(e.end_near) / double(e.end_total) : kNaN;
  e.enrichment = e.start_fraction > 0 ? e.end_fraction / e.start_fraction : kNaN;
  return e;
}

// ---- Hematocrit ------------------------------------------------------------------------------

double tube_hematocrit(std::size_t rbc_count, double rbc_volume, const Tube& tube) {
  return static_cast<double>(rbc_count) * rbc_volume / tube.volume();
}

double cell_volume_flux(const std::vector<double>& vz, double cell_volume, const Tube& tube) {
  double sum = 0;
  for (double v : vz) sum += v;
  return cell_volume * sum / tube.length;
}

double total_volume_flux(double superficial_plasma_velocity, double cells_volume_flux, const Tube& tube) {
  return tube.mean_section() * superficial_plasma_velocity + cells_volume_flux;
}

double discharge_hematocrit(double rbc_volume_flux, double total_volume_flux) {
  return total_volume_flux != 0 ? rbc_volume_flux / total_volume_flux : kNaN;
}

// ---- Blood in glass tubes: the in-vitro references ---------------------------------------------

namespace {
// The fits take the diameter in micrometres.
double in_micrometres(double diameter) { return diameter / 1e-6; }
}  // namespace

double in_vitro_relative_viscosity(double diameter, double hd) {
  const double D = in_micrometres(diameter);
  // At H_D = 0.45, and the shape of its dependence on H_D.
  const double eta_45 = 220 * std::exp(-1.3 * D) + 3.2 - 2.44 * std::exp(-0.06 * std::pow(D, 0.645));
  const double s = 1 / (1 + 1e-11 * std::pow(D, 12));
  const double c = (0.8 + std::exp(-0.075 * D)) * (-1 + s) + s;
  return 1 + (eta_45 - 1) * (std::pow(1 - hd, c) - 1) / (std::pow(1 - 0.45, c) - 1);
}

double in_vitro_fahraeus_ratio(double diameter, double hd) {
  const double D = in_micrometres(diameter);
  return hd + (1 - hd) * (1 + 1.7 * std::exp(-0.415 * D) - 0.6 * std::exp(-0.011 * D));
}

double in_vivo_rbc_share(double fqb, double parent_diameter, double diameter, double other_diameter, double hd) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!(fqb >= 0 && fqb <= 1) || !(hd >= 0 && hd < 1) || !(parent_diameter > 0) || !(diameter > 0) ||
      !(other_diameter > 0))
    return nan;
  const double per_diameter = (1 - hd) / in_micrometres(parent_diameter);
  const double squares = (diameter / other_diameter) * (diameter / other_diameter);
  const double x0 = 0.964 * per_diameter, b = 1 + 6.98 * per_diameter;
  const double a = -13.29 * ((squares - 1) / (squares + 1)) * per_diameter;
  if (fqb <= x0) return 0;
  if (fqb >= 1 - x0) return 1;
  const double x = (fqb - x0) / (1 - 2 * x0);
  return 1 / (1 + std::exp(-(a + b * std::log(x / (1 - x)))));
}

// ---- Along a branching vessel's branches ------------------------------------------------------

std::string branch_name(int branch) { return branch == 0 ? "parent" : "daughter_" + std::to_string(branch); }

namespace {

using Point = VesselWall::Point;

// Two unit normals of a unit axis, the first in the plane of the axis and the coordinate axis it
// leans least towards (the parent along z: x and y, so that theta is a straight tube's).
std::pair<Point, Point> normals_of(const Point& axis) {
  int least = 0;
  for (int d = 1; d < 3; ++d)
    if (std::abs(axis[d]) < std::abs(axis[least])) least = d;
  Point u = Point::Unit(least) - axis[least] * axis;
  u.normalize();
  return {u, axis.cross(u)};
}

}  // namespace

BranchSpan own_section_span(const VesselWall& wall, int branch) {
  const VesselWall::Branch b = wall.branches().at(static_cast<std::size_t>(branch));
  const Point axis = (b.end - b.start).normalized();
  const double length = (b.end - b.start).norm();
  const auto [u, v] = normals_of(axis);
  // A point of the circle inside the vessel is in another branch's tube; rounding leaves an exact
  // wall within a few ulps of zero, a triangulated one within its facets' deviation.
  const double inside = -1e-9 * b.radius - b.tolerance;
  auto clear = [&](double s) {
    constexpr int points = 64;
    for (int k = 0; k < points; ++k) {
      const double phi = 2 * kPi * k / points;
      if (wall.signed_distance(b.start + s * axis + b.radius * (std::cos(phi) * u + std::sin(phi) * v)) < inside)
        return false;
    }
    return true;
  };
  // From one end inward, to the first clear section, then bisected between it and the last shared one.
  auto first_clear = [&](double from, double towards) -> std::optional<double> {
    const double step = b.radius / 10;
    const int steps = static_cast<int>(std::ceil(std::abs(towards - from) / step));
    const double direction = towards > from ? 1 : -1;
    double shared = from;
    for (int n = 0; n <= steps; ++n) {
      const double s = n == steps ? towards : from + direction * n * step;
      if (!clear(s)) {
        shared = s;
        continue;
      }
      if (n == 0) return s;
      double hi = s;
      while (std::abs(hi - shared) > 1e-4 * b.radius) {
        const double mid = 0.5 * (hi + shared);
        (clear(mid) ? hi : shared) = mid;
      }
      return hi;
    }
    return std::nullopt;
  };
  const auto start = first_clear(0, length);
  if (!start) return {};
  return {*start, *first_clear(length, *start)};
}

BranchAccumulator::BranchAccumulator(const VesselWall& wall, int slices, int sectors, double rbc_diameter)
    : wall_(wall), slices_(std::max(1, slices)), sectors_(sectors), rbc_diameter_(rbc_diameter) {
  const auto branches = wall.branches();
  for (std::size_t b = 0; b < branches.size(); ++b) {
    Frame f;
    f.start = branches[b].start;
    f.length = (branches[b].end - branches[b].start).norm();
    f.axis = (branches[b].end - branches[b].start) / f.length;
    std::tie(f.u, f.v) = normals_of(f.axis);
    f.radius = branches[b].radius;
    f.span = own_section_span(wall, static_cast<int>(b));
    f.edges.resize(static_cast<std::size_t>(slices_));
    branches_.push_back(std::move(f));
  }
}

void BranchAccumulator::add(const Snapshot& s) {
  // Each slice's red cells in its branch's cylindrical coordinates, z from the slice's start.
  std::vector<std::vector<Cells>> slice(branches_.size(), std::vector<Cells>(static_cast<std::size_t>(slices_)));
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.species[i] != kRbc) continue;
    const Point x(s.position[3 * i], s.position[3 * i + 1], s.position[3 * i + 2]);
    const int b = wall_.branch_at(x);
    if (b < 0) continue;
    const Frame& f = branches_[static_cast<std::size_t>(b)];
    const Point d = x - f.start;
    const double z = d.dot(f.axis) - f.span.start, width = f.span.length() / slices_;
    if (!(z >= 0 && z < f.span.length())) continue;
    const int k = std::min(slices_ - 1, static_cast<int>(z / width));
    const Point across = d - d.dot(f.axis) * f.axis;
    Cells& c = slice[static_cast<std::size_t>(b)][static_cast<std::size_t>(k)];
    c.id.push_back(s.id[i]);
    c.r.push_back(across.norm());
    c.theta.push_back(std::atan2(across.dot(f.v), across.dot(f.u)));
    c.z.push_back(z - k * width);
    c.vz.push_back(Point(s.velocity[3 * i], s.velocity[3 * i + 1], s.velocity[3 * i + 2]).dot(f.axis));
  }
  for (std::size_t b = 0; b < branches_.size(); ++b) {
    Frame& f = branches_[b];
    long count = 0;
    for (const Cells& c : slice[b]) count += static_cast<long>(c.size());
    f.rbc_sum += count;
    if (f.sectors == 0)
      f.sectors =
          sectors_ > 0 ? sectors_ : std::max(1, static_cast<int>(std::lround(count / (slices_ * kRbcsPerStation))));
    if (!(f.span.length() > 0)) continue;
    const Tube tube{f.radius, f.span.length() / slices_};
    for (int k = 0; k < slices_; ++k)
      f.edges[static_cast<std::size_t>(k)].push_back(
          rbc_core_edges(slice[b][static_cast<std::size_t>(k)], rbc_diameter_, tube, Stations{1, f.sectors}));
  }
  ++snapshots_;
}

std::vector<BranchLayer> BranchAccumulator::result() const {
  std::vector<BranchLayer> out;
  for (std::size_t b = 0; b < branches_.size(); ++b) {
    const Frame& f = branches_[b];
    BranchLayer l;
    l.name = branch_name(static_cast<int>(b));
    l.radius = f.radius;
    l.length = f.length;
    l.span = f.span;
    l.stations = {slices_, f.sectors};
    const Tube tube{f.radius, f.span.length() / slices_};
    std::vector<StationEdges> all;
    for (int k = 0; k < slices_; ++k) {
      const auto& edges = f.edges[static_cast<std::size_t>(k)];
      l.s.push_back(f.span.start + (k + 0.5) * tube.length);
      l.station.push_back(cfl_thickness_edge(edges, tube));
      all.insert(all.end(), edges.begin(), edges.end());
    }
    l.whole = cfl_thickness_edge(all, {f.radius, f.span.length()});
    l.mean_rbc_count = snapshots_ > 0 ? static_cast<double>(f.rbc_sum) / snapshots_ : kNaN;
    out.push_back(std::move(l));
  }
  return out;
}

// ---- Margination -----------------------------------------------------------------------------

double margination_index(const std::vector<double>& platelet_r, double radius, double cfl_thickness) {
  if (platelet_r.empty() || !std::isfinite(cfl_thickness)) return kNaN;
  const double inner = radius - cfl_thickness;
  const auto n = std::count_if(platelet_r.begin(), platelet_r.end(), [&](double r) { return r > inner; });
  return static_cast<double>(n) / static_cast<double>(platelet_r.size());
}

// ---- Along a vessel shape ----------------------------------------------------------------------

AxialAccumulator::AxialAccumulator(const VesselGeometry& vessel, const Stations& stations, double rbc_diameter,
                                   double rbc_volume, double platelet_diameter)
    : vessel_(vessel),
      stations_(stations),
      rbc_diameter_(rbc_diameter),
      rbc_volume_(rbc_volume),
      platelet_diameter_(platelet_diameter) {
  const int n = stations_.axial;
  volume_.assign(n, 0.0);
  area_.assign(n, 0.0);
  // Each station's volume and wall area by the midpoint rule on 256 panels (R is smooth within a
  // station but for the constriction's ends, where it is still C1).
  constexpr int panels = 256;
  const double h = vessel_.length() / n / panels;
  for (int k = 0; k < n; ++k)
    for (int p = 0; p < panels; ++p) {
      const double z = (k * panels + p + 0.5) * h, R = vessel_.radius_at(z), dR = vessel_.radius_slope(z);
      volume_[k] += kPi * R * R * h;
      area_[k] += 2 * kPi * R * std::sqrt(1 + dR * dR) * h;
    }
  edge_sum_.assign(n, 0.0);
  rbc_volume_sum_.assign(n, 0.0);
  near_wall_sum_.assign(n, 0.0);
  arrivals_.assign(n, 0.0);
  edge_samples_.assign(n, 0);
}

int AxialAccumulator::station_of(double z) const {
  const int k = static_cast<int>(vessel_.axial(z) / vessel_.length() * stations_.axial);
  return std::clamp(k, 0, stations_.axial - 1);
}

double AxialAccumulator::gap(const double* x, double diameter) const {
  return -vessel_.signed_distance(VesselGeometry::Point(x[0], x[1], vessel_.axial(x[2]))) - diameter / 2;
}

void AxialAccumulator::add(const Snapshot& s) {
  const int n = stations_.axial, sectors = stations_.sectors;
  std::vector<double> edge(static_cast<std::size_t>(n) * sectors, kNaN);  // smallest RBC gap per (station, sector)
  std::vector<std::int64_t> touching;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double* x = &s.position[3 * i];
    const int k = station_of(x[2]);
    if (s.species[i] == kRbc) {
      const double g = gap(x, rbc_diameter_);
      const double theta = std::atan2(x[1], x[0]);
      const int sector = std::clamp(static_cast<int>((theta + kPi) / (2 * kPi) * sectors), 0, sectors - 1);
      double& e = edge[static_cast<std::size_t>(k) * sectors + sector];
      e = std::isnan(e) ? g : std::min(e, g);
      rbc_volume_sum_[k] += rbc_volume_ / volume_[k];
    } else if (s.species[i] == kPlatelet) {
      const double g = gap(x, platelet_diameter_);
      if (g < kNearWallDiameters * platelet_diameter_) near_wall_sum_[k] += 1 / area_[k];
      if (g < kWallContactDiameters * platelet_diameter_) {
        touching.push_back(s.id[i]);
        if (snapshots_ > 0 && !std::binary_search(touching_.begin(), touching_.end(), s.id[i])) arrivals_[k] += 1;
      }
    }
  }
  for (int k = 0; k < n; ++k)
    for (int sector = 0; sector < sectors; ++sector)
      if (const double e = edge[static_cast<std::size_t>(k) * sectors + sector]; !std::isnan(e)) {
        edge_sum_[k] += e;
        ++edge_samples_[k];
      }
  std::sort(touching.begin(), touching.end());
  touching_ = std::move(touching);
  if (snapshots_ == 0) first_time_ = s.time_s;
  last_time_ = s.time_s;
  ++snapshots_;
}

AxialObservables AxialAccumulator::result() const {
  AxialObservables o;
  o.snapshots = snapshots_;
  const int n = stations_.axial;
  const double span = last_time_ - first_time_;
  for (int k = 0; k < n; ++k) {
    const double z = (k + 0.5) * vessel_.length() / n;
    o.z.push_back(z);
    o.radius.push_back(vessel_.radius_at(z));
    o.cfl.push_back(edge_samples_[k] > 0 ? edge_sum_[k] / static_cast<double>(edge_samples_[k]) : kNaN);
    o.hematocrit.push_back(snapshots_ > 0 ? rbc_volume_sum_[k] / snapshots_ : kNaN);
    o.platelet_near_wall.push_back(snapshots_ > 0 ? near_wall_sum_[k] / snapshots_ : kNaN);
    o.wall_contact_rate.push_back(span > 0 ? arrivals_[k] / area_[k] / span : kNaN);
    o.wall_area_total += area_[k];
  }
  return o;
}

}  // namespace hemo::analysis
