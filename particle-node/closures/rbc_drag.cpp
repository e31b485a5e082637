// SPDX-License-Identifier: GPL-3.0-or-later
#include "rbc_drag.h"

#include <units.h>

#include <cmath>
#include <stdexcept>

namespace hemo::particles {

namespace {
constexpr double kA = 73.146, kB = 29.86, kExponent = 27.079;
// Below this Re the correction 29.86 Re^27.079 < 3e-18 is below a double's resolution of 1.
constexpr double kStokesBelow = 0.2;
}  // namespace

RbcFitDrag::RbcFitDrag(const ClosureParams& p)
    : params_(p),
      beta0_(0.125 * kA * units::pi * p.viscosity * p.diameter),
      stokes_slip_squared_(std::pow(0.99 * kStokesBelow * p.kinematic_viscosity() / p.diameter, 2)) {
  if (!(p.viscosity > 0) || !(p.diameter > 0) || !(p.fluid_density > 0))
    throw std::invalid_argument("rbc_fit drag needs a positive viscosity, density and diameter");
}

double RbcFitDrag::coefficient(double re) const {
  return re < kStokesBelow ? beta0_ : beta0_ / (1 + kB * std::pow(re, kExponent));
}

double RbcFitDrag::drag_coefficient(double re) { return kA / (re * (1 + kB * std::pow(re, kExponent))); }

}  // namespace hemo::particles
