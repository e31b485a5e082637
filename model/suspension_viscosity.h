// The suspension's own viscous stress, beyond the paper: an effective-viscosity closure a scene
// may add with plasma.suspension_viscosity. Point particles that feel drag, lift, F_p, F_v and
// contacts carry no stresslet, so the unresolved equations give the suspension the plasma's
// viscosity (docs/validation.md §3); a closure here adds the stress (mu_r(phi) - 1) mu (grad u +
// grad u^T) to the mixture through the plasma's equation, phi the cell's solid fraction. One
// table, read by the scene (names, `hemocosim check`) and the fluid node; docs/model.md §7.5.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <vector>

namespace hemo {

struct SuspensionViscosity {
  std::string name;     // the scene value
  std::string reading;  // whose relation it is, in a few words (hemocosim check)
  // mu_r(phi): the suspension's viscosity over the plasma's at solid fraction phi, >= 1.
  double (*relative)(double phi) = nullptr;
  bool adds_stress() const { return name != "none"; }
};

// Every closure, the default ("none": the paper's equations) first.
const std::vector<SuspensionViscosity>& suspension_viscosities();
std::vector<std::string> suspension_viscosity_names();
// The closure named `name`; throws std::invalid_argument naming the known ones when there is none (named_table.h).
const SuspensionViscosity& suspension_viscosity(const std::string& name);

}  // namespace hemo
