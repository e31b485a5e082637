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

struct Scene;
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

// The feeder of an open O-grid vessel: a straight tube of the inlet's radius R(0), its axis
// parallel to z at x = feeder_axis_x (m; 3 R0: clear of the vessel's wall polygon by about R0),
// over z in [0, feeder_length) (m). Its layers are as thick as the vessel's (`axial_cells` over
// its length), and it is longer than the vessel by whole layers over at least one nominal
// diameter: the DEM's box is periodic along z with the feeder's length, and that gap beyond the
// vessel's outlet keeps the cells near the outlet out of reach of those near the inlet
// (particle-node/dem_open_ends.h); the feeder's flow is uniform along z, so its length changes
// nothing else.
double feeder_axis_x(const Vessel& vessel);
double feeder_length(const Vessel& vessel, int axial_cells);
int feeder_axial_cells(const Vessel& vessel, int axial_cells);

// The feeder's axis beside a vessel whose widest point is at x = widest_x: its wall, of radius
// `radius`, clear of it by a gap of one radius (widest_x + 2 radius). For the straight tube
// (widest_x = R0, radius = R0) it is the O-grid's 3 R0 to the bit.
double feeder_axis_x(double widest_x, double radius);

// How far a surface vessel's inlet may turn from facing -z and still be fed: the feeder's
// section is perpendicular to z and the inlet's faces sample its last layer at one offset, so a
// tilt t puts the inlet's rim R tan t off that layer's mid-plane (0.017 R at 1 degree: inside the
// layer while it is thicker than R / 30).
inline constexpr double kFeederInletMaxTiltDeg = 1.0;

// Where an open vessel and its feeder lie in the space both nodes share (the fluid mesh's two
// regions, the DEM's one box): the vessel over z in [inlet_z, inlet_z + vessel_length], the
// feeder over the whole period beside it. A point at x >= split_x is the feeder's; the feeder is
// the inlet's section repeated, so a feeder point stands for the point at the same offset from
// the inlet's centre in the inlet plane (in_vessel_frame).
//
// The O-grid vessel: its inlet is centred on the z axis at z = 0 (inlet_* all 0), vessel_length
// its length. A surface vessel whose inlet faces -z (model/surface.h): inlet_* the inlet region's
// area-weighted centroid, vessel_length the surface's z extent above the inlet plane, radius the
// inlet's equivalent radius sqrt(A / pi), the layers mesh.surface_cell_size_um thick (its
// effective value), axis_x beside the surface's widest x (feeder_axis_x above).
struct FeederLayout {
  double vessel_length = 0;  // m, the vessel's extent along z from the inlet plane (the O-grid: its outlet plane's z)
  double period = 0;         // m, the feeder's length: the period along z of its cells and the DEM box
  double axis_x = 0;         // m, the feeder's axis (at y = inlet_y)
  double split_x = 0;        // m, midway between the vessel's widest wall and the feeder's (axis_x - radius)
  double radius = 0;         // m, the feeder's radius: the inlet's, R(0) or sqrt(A / pi)
  double inlet_x = 0, inlet_y = 0, inlet_z = 0;  // m, the inlet's centre (0 for the O-grid)
  int layers = 0;                                // the feeder's cells along z, period / layer thickness

  bool in_feeder(double x) const { return x >= split_x; }
  // (x, y, z) of a feeder point moved onto the vessel's inlet plane; a vessel point as it is.
  template <class V>
  V in_vessel_frame(const V& p) const {
    if (!in_feeder(p.x())) return p;
    V q = p;
    q.x() = q.x() - axis_x + inlet_x;
    q.z() = inlet_z;
    return q;
  }
};
// The layout of an O-grid vessel fed by a feeder (fed_by_feeder); throws std::invalid_argument
// otherwise.
FeederLayout feeder_layout(const Vessel& vessel, int axial_cells);

// The layout both nodes use for a scene fed by a feeder: the O-grid's (above, with
// mesh.axial_cells) or a surface vessel's. Throws std::invalid_argument with one line when the
// scene has no feeder, or a surface vessel's inlet does not face -z (naming its direction) or
// its surface reaches below the inlet plane.
FeederLayout feeder_layout(const Scene& scene);

}  // namespace hemo
