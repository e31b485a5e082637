// SPDX-License-Identifier: GPL-3.0-or-later
#include "momentum_forms.h"

#include "named_table.h"

namespace hemo {

const std::vector<MomentumForm>& momentum_forms() {
  using V = MomentumForm::Viscous;
  static const std::vector<MomentumForm> forms = [] {
    std::vector<MomentumForm> f;
    {
      MomentumForm m;
      m.name = "paper";
      m.reading = "the paper's eq:momentum, F_p and F_v on the particles (Goniva 2012), not exchanged";
      m.pressure_on_fraction = true;
      m.viscous = V::fraction_outside;
      m.pressure_force = m.viscous_force = true;
      m.exact_balance = true;
      f.push_back(m);
    }
    {
      MomentumForm m;
      m.name = "cfdem_A";
      m.reading = "CFDEM's modelType A (Zhou 2010 set I): gradPForce, viscForce on the particles";
      m.pressure_on_fraction = true;
      m.viscous = V::fraction_inside;
      m.transposed_stress = true;
      m.pressure_force = m.viscous_force = true;
      f.push_back(m);
    }
    {
      MomentumForm m;
      m.name = "cfdem_B";
      m.reading = "CFDEM's modelType B (Zhou 2010 set II): whole pressure on the plasma, drag / alpha";
      m.pressure_on_fraction = false;
      m.viscous = V::whole;
      m.transposed_stress = true;
      m.drag_over_void_fraction = true;
      m.exact_balance = true;
      f.push_back(m);
    }
    {
      MomentumForm m;
      m.name = "cfdem_Bfull";
      m.reading = "CFDEM's modelType Bfull: whole pressure on the plasma, gradPForce and viscForce exchanged";
      m.pressure_on_fraction = false;
      m.viscous = V::whole;
      m.transposed_stress = true;
      m.pressure_force = m.viscous_force = m.stress_exchanged = true;
      m.exact_balance = true;
      f.push_back(m);
    }
    {
      MomentumForm m;
      m.name = "plasma_driven";
      m.reading = "ours before: pressure and drop on the plasma's share only, none on the particles";
      m.pressure_on_fraction = true;
      m.viscous = V::fraction_inside;
      f.push_back(m);
    }
    return f;
  }();
  return forms;
}

std::vector<std::string> momentum_form_names() { return names_of(momentum_forms()); }

const MomentumForm& momentum_form(const std::string& name) {
  return named_entry(momentum_forms(), name, "momentum form");
}

}  // namespace hemo
