// Drag closures, chosen by name per species in the scene (`[rbc] drag = "stokes"`).
//
// A closure returns the drag coefficient beta of one particle, such that the drag force is
//   F = beta (u - v)
// For a nonlinear law beta depends on the slip (beta = |F| / |u - v|); the engine applies it
// with the exponential integrator of exponential_drag.h, which stays stable when the DEM step
// exceeds the relaxation time m / beta.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "../vec.h"

#include <scene.h>

#include <memory>
#include <string>
#include <vector>

namespace hemo::particles {

// What a drag closure may depend on besides the slip.
struct DragParams {
  double diameter = 0;       // m, placeholder sphere
  double fluid_density = 0;  // kg/m^3
  double viscosity = 0;      // Pa s, dynamic
};

class DragClosure {
 public:
  virtual ~DragClosure() = default;
  virtual std::string name() const = 0;
  // beta in N s/m for a particle with slip u - v; finite and >= 0, also at zero slip.
  virtual double coefficient(const Vec3& slip) const = 0;
  // True when beta does not depend on the slip (lets the engine compute the exponential
  // factor once per species and step size instead of once per particle and step).
  virtual bool slip_independent() const { return false; }
};

// The closure named `name` for a species; throws std::invalid_argument naming the known ones.
std::unique_ptr<DragClosure> make_drag_closure(const std::string& name, const DragParams& params);
std::unique_ptr<DragClosure> make_drag_closure(const Species& species, const Plasma& plasma);
std::vector<std::string> drag_closure_names();

}  // namespace hemo::particles
