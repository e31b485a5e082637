// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_fix_styles.h"

#include "dem_fixes.h"
#include "dem_open_ends.h"
#include "dem_streaming_neighbours.h"
#include "dem_tracking.h"

#include <lammps.h>
#include <modify.h>

#include <map>
#include <string>

namespace hemo::particles::dem {

namespace {

using FixCreator = LAMMPS_NS::Fix* (*)(LAMMPS_NS::LAMMPS*, int, char**);

// LIGGGHTS keeps its fix styles in a private map of Modify (filled from its compiled-in style
// list at start-up) and offers no call to add one. A style of ours goes into the same map, named
// through an explicit instantiation (where C++ does not check access), so that `fix ... STYLE`
// creates it as it creates LIGGGHTS's own: no copy of LIGGGHTS's sources, no change to them.
using FixStyleMap = std::map<std::string, FixCreator>;
using FixStyleMember = FixStyleMap* LAMMPS_NS::Modify::*;
FixStyleMember fix_style_map();
template <FixStyleMember M>
struct FixStyleAccess {
  friend FixStyleMember fix_style_map() { return M; }
};
template struct FixStyleAccess<&LAMMPS_NS::Modify::fix_map>;

}  // namespace

void register_fix_styles(LAMMPS_NS::LAMMPS& lmp) {
  static const std::map<std::string, FixCreator> ours = {
      {kStreamingNeighbourStyle, &create_streaming_neighbours},
      {kOpenEndsStyle, &create_open_ends},
      {kTrackingStyle, &create_tracking_fix},
      {kFluidForceStyle, &create_fluid_force_fix},
  };
  for (const auto& [style, create] : ours) (*(lmp.modify->*fix_style_map()))[style] = create;
}

}  // namespace hemo::particles::dem
