// SPDX-License-Identifier: GPL-3.0-or-later
#include "vessel_ends.h"

#include "geometry.h"
#include "named_table.h"
#include "scene.h"
#include "surface.h"
#include "units.h"

#include <fmt/format.h>

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

double feeder_axis_x(double widest_x, double radius) { return widest_x + 2 * radius; }

FeederLayout feeder_layout(const Vessel& vessel, int axial_cells) {
  if (!fed_by_feeder(vessel)) throw std::invalid_argument("the vessel has no feeder (vessel.ends, vessel.inlet)");
  FeederLayout layout;
  layout.vessel_length = vessel.length;
  layout.period = feeder_length(vessel, axial_cells);
  layout.axis_x = feeder_axis_x(vessel);
  layout.radius = make_vessel_geometry(vessel)->radius_at(0);
  layout.split_x = 0.5 * (vessel.radius() + layout.axis_x - layout.radius);
  layout.layers = feeder_axial_cells(vessel, axial_cells);
  return layout;
}

namespace {

// A surface vessel's feeder: beside the surface, its axis through the inlet's centre's y, its
// layers the surface mesh's cubes thick, its period whole layers over at least the vessel's z
// extent and one inlet diameter (the O-grid's rule, with the inlet's diameter for the nominal).
FeederLayout surface_feeder_layout(const Scene& scene) {
  const Surface surface = make_vessel_surface(scene.vessel);
  const int inlet = surface.region_index(surface_region::inlet);
  if (inlet < 0) throw std::invalid_argument("the vessel's surface has no inlet region to feed");
  const Surface::Point a = surface.area_vector(inlet);
  const Surface::Point c = surface.centroid(inlet);
  const Surface::Point facing = a.normalized();
  const double tilt_deg = std::acos(std::clamp(-facing.z(), -1.0, 1.0)) * 180 / units::pi;
  if (!(tilt_deg <= kFeederInletMaxTiltDeg))
    throw std::invalid_argument(
        fmt::format("a feeder needs the surface's inlet to face -z: it faces ({:.3f}, {:.3f}, {:.3f}), {:.1f} "
                    "degrees off (at most {:g}); turn the surface or use vessel.inlet = \"poiseuille\"",
                    facing.x(), facing.y(), facing.z(), tilt_deg, kFeederInletMaxTiltDeg));
  FeederLayout layout;
  layout.radius = std::sqrt(surface.area(inlet) / units::pi);
  layout.inlet_x = c.x();
  layout.inlet_y = c.y();
  layout.inlet_z = c.z();
  const Surface::Point lo = surface.lower(), hi = surface.upper();
  // The DEM box is periodic along z over [inlet_z, inlet_z + period): nothing of the vessel may
  // lie below the inlet plane but the rim of an inlet tilted within the limit (R sin t), and a
  // hundredth of R of faceting.
  const double slack = layout.radius * (std::sin(kFeederInletMaxTiltDeg * units::pi / 180) + 0.01);
  if (lo.z() < layout.inlet_z - slack)
    throw std::invalid_argument(
        fmt::format("a feeder needs the surface above its inlet plane z = {:.4g} um: it "
                    "reaches z = {:.4g} um",
                    layout.inlet_z * 1e6, lo.z() * 1e6));
  layout.vessel_length = hi.z() - layout.inlet_z;
  const double h = surface_cell_size(scene);
  layout.layers = static_cast<int>(std::ceil((layout.vessel_length + 2 * layout.radius) / h * (1 - 1e-12)));
  layout.period = h * layout.layers;
  layout.axis_x = feeder_axis_x(hi.x(), layout.radius);
  layout.split_x = 0.5 * (hi.x() + layout.axis_x - layout.radius);
  return layout;
}

}  // namespace

FeederLayout feeder_layout(const Scene& scene) {
  if (!fed_by_feeder(scene.vessel)) throw std::invalid_argument("the vessel has no feeder (vessel.ends, vessel.inlet)");
  return surface_vessel(scene.vessel) ? surface_feeder_layout(scene)
                                      : feeder_layout(scene.vessel, scene.mesh.axial_cells);
}

}  // namespace hemo
