// SPDX-License-Identifier: GPL-3.0-or-later
// The tables of closures by name. A new closure: its own file, one line here, a test, and its
// name in the scene's list (common/scene.h).
#include "closure.h"
#include "oblate.h"
#include "rbc_drag.h"
#include "rbc_lift.h"
#include "schiller_naumann_drag.h"
#include "shear_lift.h"
#include "stokes_drag.h"

#include <functional>
#include <map>
#include <stdexcept>

namespace hemo::particles {

namespace {

template <class Base>
using Table = std::map<std::string, std::function<std::unique_ptr<Base>(const ClosureParams&)>>;

template <class T, class Base>
std::unique_ptr<Base> make(const ClosureParams& p) {
  return std::make_unique<T>(p);
}

const Table<DragClosure>& drags() {
  static const Table<DragClosure> t = {
      {"stokes", make<StokesDrag, DragClosure>},
      {"rbc_fit", make<RbcFitDrag, DragClosure>},
      {"oblate", make<OblateDrag, DragClosure>},
      {"schiller_naumann", make<SchillerNaumannDrag, DragClosure>},
  };
  return t;
}
const Table<LiftClosure>& lifts() {
  static const Table<LiftClosure> t = {
      {"none", [](const ClosureParams&) { return std::unique_ptr<LiftClosure>(); }},
      {"rbc_lift", make<RbcLift, LiftClosure>},
      {"oblate", make<OblateLift, LiftClosure>},
      {"shear_lift", make<ShearLift, LiftClosure>},
  };
  return t;
}
const Table<TorqueClosure>& torques() {
  static const Table<TorqueClosure> t = {
      {"none", [](const ClosureParams&) { return std::unique_ptr<TorqueClosure>(); }},
      {"oblate", make<OblateTorque, TorqueClosure>},
  };
  return t;
}

template <class Base>
std::vector<std::string> names(const Table<Base>& t) {
  std::vector<std::string> n;
  for (const auto& [name, f] : t) n.push_back(name);
  return n;
}

template <class Base>
std::unique_ptr<Base> find(const Table<Base>& t, const char* kind, const std::string& name, const ClosureParams& p) {
  const auto it = t.find(name);
  if (it == t.end()) {
    std::string known;
    for (const auto& n : names(t)) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument(std::string("unknown ") + kind + " closure '" + name + "' (known: " + known + ")");
  }
  return it->second(p);
}

}  // namespace

std::vector<std::string> drag_closure_names() { return names(drags()); }
std::vector<std::string> lift_closure_names() { return names(lifts()); }
std::vector<std::string> torque_closure_names() { return names(torques()); }

std::unique_ptr<DragClosure> make_drag_closure(const std::string& name, const ClosureParams& p) {
  return find(drags(), "drag", name, p);
}
std::unique_ptr<LiftClosure> make_lift_closure(const std::string& name, const ClosureParams& p) {
  return find(lifts(), "lift", name, p);
}
std::unique_ptr<TorqueClosure> make_torque_closure(const std::string& name, const ClosureParams& p) {
  return find(torques(), "torque", name, p);
}

ClosureParams closure_params(const Species& species, const Scene& scene) {
  ClosureParams p;
  p.diameter = species.diameter;
  p.fluid_density = scene.plasma.density;
  p.viscosity = scene.plasma.viscosity;
  p.vessel_diameter = scene.vessel.diameter;
  p.aspect_ratio = species.semi_axis_a > 0 ? species.semi_axis_c / species.semi_axis_a : 1.0;
  return p;
}

}  // namespace hemo::particles
