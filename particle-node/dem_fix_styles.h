// Our LIGGGHTS fix styles, made known to a LIGGGHTS instance before its input names them: the
// table in dem_fix_styles.cpp, one row per style, each style defined in its own unit
// (dem_streaming_neighbours.h, dem_open_ends.h, dem_tracking.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

namespace LAMMPS_NS {
class LAMMPS;
}

namespace hemo::particles::dem {

void register_fix_styles(LAMMPS_NS::LAMMPS& lmp);

}  // namespace hemo::particles::dem
