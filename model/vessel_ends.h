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
//                            maps the velocity of the feeder's end section as it is: the vessel
//                            carries the feeder's own flow, the periodic tube's at the scene's
//                            drop, with the cells it carries (their apparent viscosity included).
//                "feeder_at_q" the same section scaled to the flux Q.
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
  // The inlet's flux is Q (every fixed profile; a feeder's section if scaled), else the feeder's own.
  bool carries_q = true;
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

// Where an open vessel and its feeder lie in the space both nodes share (the fluid mesh's two
// regions, the DEM's one box): the vessel over z in [0, vessel_length] around the z axis, the
// feeder over the whole period beside it. A point at x >= split_x is the feeder's; the feeder is
// the inlet's section repeated, so a feeder point stands for the point at the same offset from the
// vessel's axis in the inlet plane (in_vessel_frame).
struct FeederLayout {
  double vessel_length = 0;  // m, the outlet plane's z
  double period = 0;         // m, the feeder's length: the period along z of its cells and the DEM box
  double axis_x = 0;         // m, the feeder's axis (y = 0)
  double split_x = 0;        // m, midway between the vessel's widest wall (R0) and the feeder's (axis_x - R(0))
  double radius = 0;         // m, the feeder's radius: the inlet's, R(0)

  bool in_feeder(double x) const { return x >= split_x; }
  // (x, y, z) of a feeder point moved onto the vessel's inlet plane; a vessel point as it is.
  template <class V>
  V in_vessel_frame(const V& p) const {
    if (!in_feeder(p.x())) return p;
    V q = p;
    q.x() -= axis_x;
    q.z() = 0;
    return q;
  }
};
// The layout of a vessel fed by a feeder (fed_by_feeder); throws std::invalid_argument otherwise.
FeederLayout feeder_layout(const Vessel& vessel, int axial_cells);

}  // namespace hemo
