// SPDX-License-Identifier: GPL-3.0-or-later
// The table of drag closures by name. A new closure: its own file, one line here, a test.
#include "drag_closure.h"
#include "stokes_drag.h"

#include <functional>
#include <map>
#include <stdexcept>

namespace hemo::particles {

namespace {
using Factory = std::function<std::unique_ptr<DragClosure>(const DragParams&)>;

const std::map<std::string, Factory>& registry() {
  static const std::map<std::string, Factory> table = {
      {"stokes", [](const DragParams& p) { return std::make_unique<StokesDrag>(p); }},
  };
  return table;
}
}  // namespace

std::vector<std::string> drag_closure_names() {
  std::vector<std::string> names;
  for (const auto& [name, factory] : registry()) names.push_back(name);
  return names;
}

std::unique_ptr<DragClosure> make_drag_closure(const std::string& name, const DragParams& params) {
  const auto it = registry().find(name);
  if (it == registry().end()) {
    std::string known;
    for (const auto& n : drag_closure_names()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown drag closure '" + name + "' (known: " + known + ")");
  }
  return it->second(params);
}

std::unique_ptr<DragClosure> make_drag_closure(const Species& species, const Plasma& plasma) {
  DragParams p;
  p.diameter = species.diameter;
  p.fluid_density = plasma.density;
  p.viscosity = plasma.viscosity;
  return make_drag_closure(species.drag, p);
}

}  // namespace hemo::particles
