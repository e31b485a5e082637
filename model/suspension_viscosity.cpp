// SPDX-License-Identifier: GPL-3.0-or-later
#include "suspension_viscosity.h"

#include "named_table.h"

#include <algorithm>
#include <cmath>

namespace hemo {

namespace {

double none(double) { return 1; }

// Einstein (1906, 1911): rigid spheres, dilute, exact to first order in phi.
double einstein(double phi) { return 1 + 2.5 * phi; }

// Krieger & Dougherty (1959, Trans. Soc. Rheol. 3:137) with Einstein's intrinsic viscosity 2.5
// and the random close packing of equal spheres, 0.64 (Scott & Kilgour 1969), as maximum
// packing: (1 - phi/phi_m)^(-2.5 phi_m). A cell packed beyond 99 % of phi_m (soft contacts can
// overlap) is taken at 99 % so that the viscosity stays finite (mu_r <= 1585).
double krieger_dougherty(double phi) {
  constexpr double phi_m = 0.64, intrinsic = 2.5;
  const double p = std::clamp(phi, 0.0, 0.99 * phi_m);
  return std::pow(1 - p / phi_m, -intrinsic * phi_m);
}

}  // namespace

const std::vector<SuspensionViscosity>& suspension_viscosities() {
  static const std::vector<SuspensionViscosity> all = {
      {"none", "the paper's equations: the plasma's viscosity only (no particle stresslet)", none},
      {"einstein", "beyond the paper: Einstein's 1 + 2.5 phi of rigid spheres", einstein},
      {"krieger_dougherty",
       "beyond the paper: Krieger & Dougherty 1959, (1 - phi/0.64)^(-1.6), rigid spheres to close packing",
       krieger_dougherty},
  };
  return all;
}

std::vector<std::string> suspension_viscosity_names() { return names_of(suspension_viscosities()); }

const SuspensionViscosity& suspension_viscosity(const std::string& name) {
  return named_entry(suspension_viscosities(), name, "suspension viscosity");
}

}  // namespace hemo
