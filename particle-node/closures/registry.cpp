// SPDX-License-Identifier: GPL-3.0-or-later
// The factories of the closures in the closure table. Both includes below are generated from the
// HEMO_CLOSURE lines of closures/*.h (closure_table.cmake): a new closure needs no line here, and
// its name one line in model/closure_names.h.
#include "closure.h"
#include "closure_headers.h"  // every header that registers a closure
#include "closure_table.h"    // HEMO_{DRAG,LIFT,TORQUE}_CLOSURES(X): X("name", Class), by name

#include <closure_names.h>

#include <initializer_list>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace hemo::particles {

// Friend of NamedClosure: the one place a closure is given its table name.
class ClosureRegistry {
 public:
  template <class T, class Base>
  static std::unique_ptr<Base> make(const char* name, const ClosureParams& p) {
    if constexpr (std::is_same_v<T, NoClosure>) {
      return nullptr;
    } else {
      auto c = std::make_unique<T>(p);
      c->name_ = name;
      return c;
    }
  }
};

namespace {

// The scene validates closure names against model/closure_names.h, which cannot read this table:
// the two lists must be the same, or the build stops here naming the slot.
#define HEMO_CLOSURE_NAME(name, cls) std::string_view(name),
constexpr std::string_view kTableDragNames[] = {HEMO_DRAG_CLOSURES(HEMO_CLOSURE_NAME)};
constexpr std::string_view kTableLiftNames[] = {HEMO_LIFT_CLOSURES(HEMO_CLOSURE_NAME)};
constexpr std::string_view kTableTorqueNames[] = {HEMO_TORQUE_CLOSURES(HEMO_CLOSURE_NAME)};
#undef HEMO_CLOSURE_NAME
static_assert(same_closure_names(kTableDragNames, kDragClosureNames),
              "the drag closures' HEMO_CLOSURE lines and model/closure_names.h's kDragClosureNames differ");
static_assert(same_closure_names(kTableLiftNames, kLiftClosureNames),
              "the lift closures' HEMO_CLOSURE lines and model/closure_names.h's kLiftClosureNames differ");
static_assert(same_closure_names(kTableTorqueNames, kTorqueClosureNames),
              "the torque closures' HEMO_CLOSURE lines and model/closure_names.h's kTorqueClosureNames differ");

template <class Base>
using Factory = std::unique_ptr<Base> (*)(const ClosureParams&);

// In the table's order (by name, for messages), with a map beside it to find a name.
template <class Base>
struct Table {
  std::vector<std::string> names;
  std::map<std::string, Factory<Base>> factories;
  Table(std::initializer_list<std::pair<const char*, Factory<Base>>> entries) {
    for (const auto& [name, f] : entries) {
      names.push_back(name);
      factories.emplace(name, f);
    }
  }
};

// A table line as a factory; Base is the slot's closure type, named where the table is expanded.
#define HEMO_CLOSURE_ENTRY(name, cls) \
  {name, [](const ClosureParams& p) { return ClosureRegistry::make<cls, Base>(name, p); }},

const Table<DragClosure>& drags() {
  using Base = DragClosure;
  static const Table<Base> t = {HEMO_DRAG_CLOSURES(HEMO_CLOSURE_ENTRY)};
  return t;
}
const Table<LiftClosure>& lifts() {
  using Base = LiftClosure;
  static const Table<Base> t = {HEMO_LIFT_CLOSURES(HEMO_CLOSURE_ENTRY)};
  return t;
}
const Table<TorqueClosure>& torques() {
  using Base = TorqueClosure;
  static const Table<Base> t = {HEMO_TORQUE_CLOSURES(HEMO_CLOSURE_ENTRY)};
  return t;
}
#undef HEMO_CLOSURE_ENTRY

template <class Base>
std::unique_ptr<Base> find(const Table<Base>& t, const char* kind, const std::string& name, const ClosureParams& p) {
  const auto it = t.factories.find(name);
  if (it == t.factories.end()) {
    std::string known;
    for (const auto& n : t.names) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument(std::string("unknown ") + kind + " closure '" + name + "' (known: " + known + ")");
  }
  return it->second(p);
}

}  // namespace

std::vector<std::string> drag_closure_names() { return drags().names; }
std::vector<std::string> lift_closure_names() { return lifts().names; }
std::vector<std::string> torque_closure_names() { return torques().names; }

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
