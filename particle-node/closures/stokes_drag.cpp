// SPDX-License-Identifier: GPL-3.0-or-later
#include "stokes_drag.h"

#include <units.h>

#include <stdexcept>

namespace hemo::particles {

StokesDrag::StokesDrag(const ClosureParams& p) : beta_(3.0 * units::pi * p.viscosity * p.diameter) {
  if (!(p.viscosity > 0) || !(p.diameter > 0))
    throw std::invalid_argument("stokes drag needs a positive viscosity and diameter");
}

}  // namespace hemo::particles
