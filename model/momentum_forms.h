// The forms of the momentum coupling a scene chooses with coupling.momentum: how the pressure
// (the periodic vessel's imposed mean drop included) and the plasma's viscous stress are shared
// between the plasma's equation and the particles, and what the particles hand back to the
// plasma (R_pf). One table, read by the scene (names, `hemocosim check`), the fluid node (its
// momentum equation, what it publishes) and the particle node (the forces it applies); the
// equations and why each form balances, or does not, are in docs/model.md, section 1.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <vector>

namespace hemo {

struct MomentumForm {
  // How the plasma's viscous term is written (kinematic, nu the plasma's):
  enum class Viscous {
    fraction_outside,  // alpha div(nu grad u): OpenFOAM alpha*fvm::laplacian(nu, U)
    fraction_inside,   // div(alpha nu grad u): fvm::laplacian(alpha*nu, U)
    whole,             // div(nu grad u): fvm::laplacian(nu, U)
  };

  std::string name;     // the scene value
  std::string reading;  // whose form it is, in a few words (hemocosim check)
  // Plasma. pressure_on_fraction: -alpha grad p and alpha G (the plasma's share of the pressure
  // and of the imposed drop), else -grad p and G (the whole).
  bool pressure_on_fraction = true;
  Viscous viscous = Viscous::fraction_outside;
  // The transposed part of the viscous stress, div(nu dev2((grad u)^T)) (alpha inside with
  // Viscous::fraction_inside), as CFDEMcoupling writes it; zero for a divergence-free u.
  bool transposed_stress = false;
  // Particles. pressure_force: F_p = -V_p grad P, P the plasma's pressure with the imposed drop;
  // viscous_force: F_v = V_p div(tau), tau the plasma's viscous stress (mu lap u, and with
  // transposed_stress mu's transposed part as CFDEM's viscForce has it).
  bool pressure_force = false;
  bool viscous_force = false;
  // F_p and F_v handed to the plasma with the drag and lift (in R_pf); else they act on the
  // particle alone.
  bool stress_exchanged = false;
  // The drag coefficient divided by the cell's void fraction, beta / alpha (Zhou et al.'s set II).
  bool drag_over_void_fraction = false;
  // The steady wall force equals the imposed driving (pressure drop times cross-section) to the
  // discretisation's round-off (docs/model.md says why for each form).
  bool exact_balance = false;

  // What the fluid publishes per cell for the particles.
  bool needs_pressure_gradient() const { return pressure_force; }
  bool needs_viscous_force() const { return viscous_force; }
};

// Every form, the default ("paper") first.
const std::vector<MomentumForm>& momentum_forms();
std::vector<std::string> momentum_form_names();
// The form named `name`; throws std::invalid_argument naming the known ones when there is none.
const MomentumForm& momentum_form(const std::string& name);

}  // namespace hemo
