// SPDX-License-Identifier: GPL-3.0-or-later
#include "vessel_ends.h"

#include "geometry.h"
#include "named_table.h"
#include "scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hemo {

const std::vector<VesselEnds>& vessel_ends() {
  static const std::vector<VesselEnds> all = {
      {"periodic", "z = 0 and z = l are one cyclic pair, driven by the body force G = dP/(rho l)", false},
      {"open", "an inlet at z = 0 takes the nominal tube's flow rate, the outlet at z = l holds p = 0", true},
  };
  return all;
}

std::vector<std::string> vessel_end_names() { return names_of(vessel_ends()); }

const VesselEnds& vessel_end(const std::string& name) { return named_entry(vessel_ends(), name, "vessel ends"); }

const std::vector<VesselInlet>& vessel_inlets() {
  static const std::vector<VesselInlet> all = {
      {"feeder",
       "the section of a periodic feeder vessel beside it (OpenFOAM's mapped inlet): its own flow, the periodic "
       "tube's at dP",
       VesselInlet::Profile::feeder, false},
      {"feeder_at_q", "the section of a periodic feeder vessel beside it, scaled to Q", VesselInlet::Profile::feeder,
       true},
      {"poiseuille", "the parabolic profile of Q, fixed", VesselInlet::Profile::parabola},
      {"uniform", "a flat profile of Q, fixed (the textbook entrance flow)", VesselInlet::Profile::flat},
  };
  return all;
}

std::vector<std::string> vessel_inlet_names() { return names_of(vessel_inlets()); }

const VesselInlet& vessel_inlet(const std::string& name) { return named_entry(vessel_inlets(), name, "vessel inlet"); }

bool open_ends(const Vessel& vessel) { return vessel_end(vessel.ends).open; }

bool fed_by_feeder(const Vessel& vessel) {
  return open_ends(vessel) && vessel_inlet(vessel.inlet).profile == VesselInlet::Profile::feeder;
}

double feeder_axis_x(const Vessel& vessel) { return 3 * vessel.radius(); }

int feeder_axial_cells(const Vessel& vessel, int axial_cells) {
  const double dz = vessel.length / axial_cells;
  const int gap = static_cast<int>(std::ceil(vessel.diameter / dz * (1 - 1e-12)));
  return axial_cells + gap;
}

double feeder_length(const Vessel& vessel, int axial_cells) {
  return vessel.length / axial_cells * feeder_axial_cells(vessel, axial_cells);
}

FeederLayout feeder_layout(const Vessel& vessel, int axial_cells) {
  if (!fed_by_feeder(vessel)) throw std::invalid_argument("the vessel has no feeder (vessel.ends, vessel.inlet)");
  FeederLayout layout;
  layout.vessel_length = vessel.length;
  layout.period = feeder_length(vessel, axial_cells);
  layout.axis_x = feeder_axis_x(vessel);
  layout.radius = make_vessel_geometry(vessel)->radius_at(0);
  layout.split_x = 0.5 * (vessel.radius() + layout.axis_x - layout.radius);
  return layout;
}

}  // namespace hemo
