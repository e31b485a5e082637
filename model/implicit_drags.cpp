// SPDX-License-Identifier: GPL-3.0-or-later
#include "implicit_drags.h"

#include "named_table.h"

namespace hemo {

const std::vector<ImplicitDrag>& implicit_drags() {
  using R = ImplicitDrag::Response;
  static const std::vector<ImplicitDrag> table = {
      {"interval_response", "ours: K from the interval's drag response", R::interval, false},
      {"instantaneous", "CFDEM's implicitCouple: the fluid takes K = sum beta / V", R::instantaneous, false},
      {"co_relaxed", "ours: each cell's plasma answers its particles every DEM step", R::none, true},
  };
  return table;
}

std::vector<std::string> implicit_drag_names() { return names_of(implicit_drags()); }

const ImplicitDrag& implicit_drag(const std::string& name) {
  return named_entry(implicit_drags(), name, "coupling.implicit_drag");
}

}  // namespace hemo
