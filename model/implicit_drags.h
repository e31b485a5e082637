// The coefficients K a scene may choose with coupling.implicit_drag: how the particle node
// hands the fluid the implicit part of the particles' drag (docs/model.md, the coupling). One
// table, read by the scene (names, `hemocosim check`) and the particle node (what it deposits and
// whether each cell's plasma relaxes with its particles, particle-node/cell_plasma.h); no other
// place spells a name.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <vector>

namespace hemo {

struct ImplicitDrag {
  // What a particle's deposited drag response (the K of the cell, times V dt) is:
  enum class Response {
    interval,       // the derivative of the interval's drag in the plasma velocity, m (1 - exp(-B/m))
    instantaneous,  // B, the interval's integral of beta dt (the particle's velocity held)
    none,           // 0: the plasma answered within the interval (co_relaxes), the fluid takes it explicitly
  };
  std::string name;     // the scene value
  std::string reading;  // whose coefficient it is, in a few words (hemocosim check)
  Response response = Response::interval;
  // Each cell's plasma answers its particles' drag at every DEM step (particle-node/cell_plasma.h).
  bool co_relaxes = false;
};

// Every coefficient, the default ("interval_response") first.
const std::vector<ImplicitDrag>& implicit_drags();
std::vector<std::string> implicit_drag_names();
// The coefficient named `name`; throws std::invalid_argument naming the known ones when there is none (named_table.h).
const ImplicitDrag& implicit_drag(const std::string& name);

}  // namespace hemo
