// SPDX-License-Identifier: GPL-3.0-or-later
#include "closure_names.h"

namespace hemo {

namespace {
template <std::size_t N>
std::vector<std::string> strings(const std::array<std::string_view, N>& names) {
  return {names.begin(), names.end()};
}
}  // namespace

const std::vector<std::string>& known_drag_closures() {
  static const std::vector<std::string> n = strings(kDragClosureNames);
  return n;
}
const std::vector<std::string>& known_lift_closures() {
  static const std::vector<std::string> n = strings(kLiftClosureNames);
  return n;
}
const std::vector<std::string>& known_torque_closures() {
  static const std::vector<std::string> n = strings(kTorqueClosureNames);
  return n;
}

}  // namespace hemo
