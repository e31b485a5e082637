// SPDX-License-Identifier: GPL-3.0-or-later
#include "schiller_naumann_drag.h"

#include <units.h>

#include <stdexcept>

namespace hemo::particles {

SchillerNaumannDrag::SchillerNaumannDrag(const ClosureParams& p)
    : params_(p), stokes_(3 * units::pi * p.viscosity * p.diameter) {
  if (!(p.viscosity > 0) || !(p.diameter > 0) || !(p.fluid_density > 0))
    throw std::invalid_argument("schiller_naumann drag needs a positive viscosity, density and diameter");
}

}  // namespace hemo::particles
