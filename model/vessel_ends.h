// What happens at the vessel's two ends along z (vessel.ends), and, for open ends, what the inlet
// takes in (vessel.inlet): one registration each, read by the scene (names, refusals,
// `hemocosim check`) and the fluid node's mesh and case (fluid-node/vessel_mesh.cpp,
// fluid_case.cpp); docs/model.md §1.2, docs/design.md "Open ends".
//
//   vessel.ends  "periodic"  (default) z = 0 and z = length are one cyclic pair; the body force
//                            G = dP / (rho l) drives the whole vessel.
//                "open"      an inlet at z = 0 takes the flow rate Q the scene's driving gives in
//                            the nominal tube (nominal_flow_rate, driving.h); the outlet at
//                            z = length holds p = 0. G drives nothing in the vessel itself.
//   vessel.inlet "feeder"    (default for open ends) a straight periodic feeder vessel of the
//                            inlet's radius, driven by G, a disconnected region of the same fluid
//                            mesh beside the vessel (its axis at x = feeder_axis_x); the inlet
//                            maps the velocity of the feeder's end section, scaled to the flux Q.
//                "poiseuille" the parabolic profile of Q, fixed.
//                "uniform"   a flat profile of Q, fixed: the textbook entrance flow (Durst et al. 2005,
//                            J. Fluids Eng. 127:1154), which the vessel's first ~0.6 d develop.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <vector>

namespace hemo {

struct Vessel;

struct VesselEnds {
  std::string name;
  std::string description;  // a few words (hemocosim check)
  bool open = false;        // an inlet and an outlet instead of a cyclic pair
};

struct VesselInlet {
  // feeder: the inlet maps a periodic feeder's section (a region of the fluid mesh); parabola and
  // flat: a fixed profile.
  enum class Profile { feeder, parabola, flat };
  std::string name;
  std::string description;
  Profile profile = Profile::feeder;
};

// Every choice, the default first.
const std::vector<VesselEnds>& vessel_ends();
std::vector<std::string> vessel_end_names();
const VesselEnds& vessel_end(const std::string& name);  // throws std::invalid_argument naming the known
const std::vector<VesselInlet>& vessel_inlets();
std::vector<std::string> vessel_inlet_names();
const VesselInlet& vessel_inlet(const std::string& name);

// Whether the vessel has open ends, and whether its inlet is fed by a feeder vessel (false for a
// periodic vessel).
bool open_ends(const Vessel& vessel);
bool fed_by_feeder(const Vessel& vessel);

// The feeder of an open vessel: a straight tube of the inlet's radius R(0), its axis parallel to
// z at x = feeder_axis_x (m; 3 R0: clear of the vessel's wall polygon by about R0), over
// z in [0, feeder_length) (m). Its layers are as thick as the vessel's (`axial_cells` over its
// length), and it is longer than the vessel by whole layers over at least one nominal diameter:
// the DEM's box is periodic along z with the feeder's length, and that gap beyond the vessel's
// outlet keeps the cells near the outlet out of reach of those near the inlet (particle-node/
// dem_open_ends.h); the feeder's flow is uniform along z, so its length changes nothing else.
double feeder_axis_x(const Vessel& vessel);
double feeder_length(const Vessel& vessel, int axial_cells);
int feeder_axial_cells(const Vessel& vessel, int axial_cells);

}  // namespace hemo
