// SPDX-License-Identifier: GPL-3.0-or-later
#include "observable_table.h"

#include "analyze.h"

#include <fmt/format.h>

#include <cmath>

namespace hemo::analysis {

namespace {

using Style = Shown::Style;
constexpr double kUm = 1e-6;

std::string um(double metres) { return std::isfinite(metres) ? fmt::format("{:.2f}", metres / kUm) : "n/a"; }

std::string cfl_edge_detail(const Analysis& a) {
  return fmt::format("edge method: {} x {} stations, {} samples, {} empty; edge {} ± {} µm", a.stations.axial,
                     a.stations.sectors, a.cfl_edge.samples, a.cfl_edge.empty_samples, um(a.cfl_edge.edge_mean),
                     um(a.cfl_edge.edge_std));
}

std::string cfl_profile_detail(const Analysis& a) {
  const double core = a.cfl_profile.core_mean_fraction;
  return fmt::format("profile method: RBC volume fraction < 10% of its core mean {}",
                     std::isfinite(core) ? fmt::format("{:.3f}", core) : "n/a");
}

std::string diffusion_detail(const Analysis& a) {
  return fmt::format("MSD = 2 D t through the origin over [0, D fit end]: {} points, {} platelets; t = 0 at {:.4g} s",
                     a.diffusion.points, a.msd.empty() ? 0 : a.msd.front().matched, a.msd_reference_time);
}

std::string viscosity_detail(const Analysis& a) {
  auto rate = [](double v) { return std::isfinite(v) ? fmt::format("{:.1f}", v) : "n/a"; };
  return fmt::format("γ̇_w / (8U/d), U = Q/(πR²) of the blood: imposed {} 1/s, apparent {} 1/s; wall shear stress {} Pa (fluid node)",
                     rate(a.rheology.wall_shear_rate), rate(a.rheology.apparent_wall_shear_rate),
                     std::isfinite(a.wall_shear_stress) ? fmt::format("{:.4f}", a.wall_shear_stress) : "n/a");
}

std::string pa(double v) { return std::isfinite(v) ? fmt::format("{:.4f}", v) : "n/a"; }

std::string wall_shear_stress_detail(const Analysis& a) {
  return fmt::format("fluid node, {} samples; {} Pa at the window's end; {} = {} Pa", a.balance.samples,
                     pa(a.balance.end), a.balance_against, pa(a.balance.imposed));
}

std::string balance_detail(const Analysis& a) {
  const auto& v = a.balance_verdict;
  return fmt::format("exact balance: {:.3f} on this mesh, 1 on the circle; {}", a.balance.mesh_ratio,
                     !v.judged ? "not judged"
                     : v.holds ? "holds"
                               : "does not hold");
}

std::string shear_rate_detail(const Analysis& a) {
  const double imposed = a.balance.imposed_wall_shear_rate();
  return fmt::format("τ_w / µ; imposed {} 1/s", std::isfinite(imposed) ? fmt::format("{:.1f}", imposed) : "n/a");
}

std::string axis_detail(const Analysis& a) {
  const auto& e = a.platelet_axis;
  auto share = [](double f) { return std::isfinite(f) ? fmt::format("{:.4f}", f) : "n/a"; };
  return fmt::format("platelets with r < 0.2 R: {} of {} at {:.4g} s ({}), {} of {} at {:.4g} s ({})", e.start_near,
                     e.start_total, e.start_time, share(e.start_fraction), e.end_near, e.end_total, e.end_time,
                     share(e.end_fraction));
}

std::string velocity_detail(const Analysis& a) { return fmt::format("{} samples", a.velocity_samples); }

std::string discharge_detail(const Analysis& a) { return fmt::format("H_D = Q_RBC / Q, Q = {}", a.total_flux_source); }

std::string margination_detail(const Analysis&) { return "platelets with r > R − δ, edge-method δ"; }

// A bifurcation's first outlet, the daughter the phase-separation curve is read for; NaN when the
// run has no outlets' shares.
double first_outlet(const Analysis& a, double BranchShare::*share) {
  return a.branches.empty() ? std::nan("") : a.branches.front().*share;
}
// The in-vivo fit's red-cell share at the first outlet's blood share, from the parent's discharge
// hematocrit (its inlet's) and the branches' diameters; NaN without cells in all three branches.
double first_outlet_in_vivo(const Analysis& a) {
  if (a.branches.empty() || a.ends.size() < 3 || a.branch_layers.size() < 3) return std::nan("");
  return in_vivo_rbc_share(a.branches.front().blood, 2 * a.branch_layers[0].radius, 2 * a.branch_layers[1].radius,
                           2 * a.branch_layers[2].radius, a.ends[0].discharge_hematocrit());
}

}  // namespace

double Observable::value(const Analysis& a) const {
  return a.surface == of_surface ? of(a) : std::nan("");
}

std::string Observable::format(const Analysis& a) const {
  const double v = value(a);
  if (!std::isfinite(v)) return "n/a";
  const double x = v / shown.scale;
  switch (shown.style) {
    case Style::fixed:
      return fmt::format("{:.{}f}", x, shown.digits);
    case Style::scientific:
      return fmt::format("{:.{}e}", x, shown.digits);
    case Style::general:
      return fmt::format("{:.{}g}", x, shown.digits);
  }
  return "";
}

std::string Observable::header() const {
  return shown.unit.empty() ? std::string(label) : fmt::format("{} ({})", label, shown.unit);
}

const std::vector<Observable>& observable_table() {
  // One observable a row, as the table is read.
  // clang-format off
  static const std::vector<Observable> table = {
      {"end_time_s", "window.end_s", "t end", "s", "end of the averaging window: the last snapshot",
       [](const Analysis& a) { return a.window_end; }, {Style::general, 4, 1, "s"}},
      {"rbc_count", "window.mean_rbc_count", "RBCs", "1", "red blood cells in the vessel, window mean",
       [](const Analysis& a) { return a.mean_rbc_count; }, {Style::fixed, 0, 1, ""}},
      {"platelet_count", "window.mean_platelet_count", "PLTs", "1", "platelets in the vessel, window mean",
       [](const Analysis& a) { return a.mean_platelet_count; }, {Style::fixed, 0, 1, ""}},
      {"cfl_edge_m", "cfl.edge.thickness_m", "δ edge", "m",
       "cell-free layer thickness R − <RBC core edge> over stations and snapshots (edge method, docs/model.md §5)",
       [](const Analysis& a) { return a.cfl_edge.thickness; }, {Style::fixed, 2, kUm, "µm"}, cfl_edge_detail,
       "CFL thickness δ", "edge method"},
      {"cfl_profile_m", "cfl.profile.thickness_m", "δ profile", "m",
       "cell-free layer thickness where the RBC volume fraction falls below 10 % of its core mean (profile method)",
       [](const Analysis& a) { return a.cfl_profile.thickness; }, {Style::fixed, 2, kUm, "µm"}, cfl_profile_detail,
       "CFL thickness δ", "profile method"},
      {"D_m2_s", "diffusion.D_m2_s", "D", "m^2/s",
       "platelet radial diffusivity from MSD = 2 D t, least squares through the origin",
       [](const Analysis& a) { return a.diffusion.diffusivity; }, {Style::scientific, 3, 1, "m²/s"}, diffusion_detail,
       "platelet D", "radial MSD"},
      {"D_fit_end_s", "diffusion.window_end_s", "D fit end", "s", "largest MSD lag used in the fit of D",
       [](const Analysis& a) { return a.diffusion.window_end; }, {Style::general, 3, 1, "s"}},
      {"relative_apparent_viscosity", "rheology.relative_apparent_viscosity", "µ_app/µ", "1",
       "apparent viscosity relative to the plasma's: imposed wall shear rate over 8 U / d, U the blood's mean velocity",
       [](const Analysis& a) { return a.rheology.relative_viscosity; }, {Style::fixed, 3, 1, ""}, viscosity_detail,
       "µ_app / µ", "γ̇ / (8Ū/d)"},
      {"mean_velocity_m_s", "rheology.mean_velocity_m_s", "U", "m/s",
       "mean blood velocity Q / (π R²): plasma (fluid node) and cells, window mean",
       [](const Analysis& a) { return a.rheology.mean_velocity; }, {Style::scientific, 3, 1, "m/s"}, velocity_detail},
      {"wall_shear_stress_Pa", "momentum_balance.wall_shear_stress_Pa", "τ_w", "Pa",
       "wall shear stress the fluid node realises, window mean (docs/model.md §5 momentum balance)",
       [](const Analysis& a) { return a.balance.mean; }, {Style::fixed, 4, 1, "Pa"}, wall_shear_stress_detail},
      {"wall_shear_stress_ratio", "momentum_balance.ratio", "τ_w/τ_w,imposed", "1",
       "realised over imposed wall shear stress, τ_w / (d ΔP / (4 l)): 1 when the wall takes up the whole driving",
       [](const Analysis& a) { return a.balance.ratio(); }, {Style::fixed, 3, 1, ""}, balance_detail},
      {"wall_shear_rate_per_s", "momentum_balance.wall_shear_rate_per_s", "wall shear rate", "1/s",
       "realised wall shear rate τ_w / µ, window mean",
       [](const Analysis& a) { return a.balance.wall_shear_rate(); }, {Style::fixed, 1, 1, "1/s"}, shear_rate_detail},
      {"tube_hematocrit", "hematocrit.tube", "H_T", "1", "tube hematocrit N_RBC V_RBC / (π R² L), window mean",
       [](const Analysis& a) { return a.tube_hematocrit; }, {Style::fixed, 3, 1, ""}},
      {"discharge_hematocrit", "hematocrit.discharge", "H_D", "1",
       "discharge hematocrit Q_RBC / Q: the RBC share of the volume flux",
       [](const Analysis& a) { return a.discharge_hematocrit; }, {Style::fixed, 3, 1, ""}, discharge_detail},
      {"fahraeus_ratio", "hematocrit.fahraeus_ratio", "H_T/H_D", "1",
       "tube over discharge hematocrit: below 1 when the red cells ride the fast core (Fåhræus effect)",
       [](const Analysis& a) { return a.tube_hematocrit / a.discharge_hematocrit; }, {Style::fixed, 3, 1, ""}},
      {"in_vitro_fahraeus_ratio", "in_vitro.fahraeus_ratio", "H_T/H_D in vitro", "1",
       "H_T/H_D of blood in a glass tube of this diameter at this run's H_D (Pries et al. 1990, docs/model.md §7.4)",
       [](const Analysis& a) { return in_vitro_fahraeus_ratio(2 * a.tube.radius, a.discharge_hematocrit); },
       {Style::fixed, 3, 1, ""}},
      {"in_vitro_relative_viscosity", "in_vitro.relative_viscosity", "µ_app/µ in vitro", "1",
       "relative apparent viscosity of blood in a glass tube of this diameter at this run's H_D (Pries et al. 1992, docs/model.md §7.4)",
       [](const Analysis& a) { return in_vitro_relative_viscosity(2 * a.tube.radius, a.discharge_hematocrit); },
       {Style::fixed, 3, 1, ""}},
      {"margination_index", "margination.index", "margination", "1",
       "fraction of platelets in the cell-free layer, r > R − δ (edge method), window mean",
       [](const Analysis& a) { return a.margination_index; }, {Style::fixed, 3, 1, ""}, margination_detail},
      {"platelet_axis_enrichment", "platelet_axis.enrichment", "axis enrichment", "1",
       "fraction of platelets within 0.2 R of the axis at the window's end over that at the first snapshot",
       [](const Analysis& a) { return a.platelet_axis.enrichment; }, {Style::fixed, 3, 1, ""}, axis_detail},
      {"outlet_1_blood_share", "phase_separation.outlet_1.blood_share", "F_B out 1", "1",
       "a bifurcation's outlet 1's share of the blood leaving through the outlets, window",
       [](const Analysis& a) { return first_outlet(a, &BranchShare::blood); }, {Style::fixed, 4, 1, ""}, nullptr,
       "outlet 1's share", "blood", true},
      {"outlet_1_rbc_share", "phase_separation.outlet_1.rbc_share", "F_E out 1", "1",
       "outlet 1's share of the red cells leaving through the outlets, window",
       [](const Analysis& a) { return first_outlet(a, &BranchShare::rbc); }, {Style::fixed, 4, 1, ""}, nullptr,
       "outlet 1's share", "red cells", true},
      {"outlet_1_platelet_share", "phase_separation.outlet_1.platelet_share", "F_P out 1", "1",
       "outlet 1's share of the platelets leaving through the outlets, window",
       [](const Analysis& a) { return first_outlet(a, &BranchShare::platelet); }, {Style::fixed, 4, 1, ""}, nullptr,
       "outlet 1's share", "platelets", true},
      {"outlet_1_rbc_share_in_vivo", "in_vivo.outlet_1_rbc_share", "F_E out 1 in vivo", "1",
       "outlet 1's red-cell share at its F_B in the in-vivo fit of Pries et al. 1989 / Pries & Secomb 2005, parent H_D and the branches' diameters (docs/model.md §5)",
       first_outlet_in_vivo, {Style::fixed, 4, 1, ""}, nullptr, "outlet 1's share", "red cells, in vivo fit", true},
  };
  // clang-format on
  return table;
}

}  // namespace hemo::analysis
