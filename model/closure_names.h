// The closure names a scene may give each slot (rbc.drag, platelet.lift, ...): the one
// registration of the names on the model's side, so that validating a scene reads nothing of the
// particle node. The classes behind them are the particle node's (particle-node/closures/, one
// HEMO_CLOSURE line per closure in its header, made into closure_table.h at configure time);
// particle-node/closures/registry.cpp static_asserts that its table names exactly these, in this
// order, so a closure added on one side only stops the particle node's build with the slot named.
// Each list is in byte order: the order every list of closure names has, in messages too.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace hemo {

inline constexpr std::array<std::string_view, 4> kDragClosureNames = {"oblate", "rbc_fit", "schiller_naumann",
                                                                      "stokes"};
inline constexpr std::array<std::string_view, 4> kLiftClosureNames = {"none", "oblate", "rbc_lift", "shear_lift"};
inline constexpr std::array<std::string_view, 2> kTorqueClosureNames = {"none", "oblate"};

// The same lists as strings, for validation and messages.
const std::vector<std::string>& known_drag_closures();
const std::vector<std::string>& known_lift_closures();
const std::vector<std::string>& known_torque_closures();

// Whether a table's names are `names`, element by element (for the particle node's static_assert).
template <std::size_t N, std::size_t M>
constexpr bool same_closure_names(const std::string_view (&table)[N], const std::array<std::string_view, M>& names) {
  if (N != M) return false;
  for (std::size_t i = 0; i < N; ++i)
    if (table[i] != names[i]) return false;
  return true;
}

}  // namespace hemo
