// What the particle side asks of a vessel's wall, whatever its shape: how far a point is from it,
// which way it faces, and the vessel's section through the point (its local radius, the point's
// distance from that section's centre line, the centre-line speed there). An axisymmetric shape
// (VesselGeometry, model/geometry.h) answers from R(z); a bifurcation (model/bifurcation.h) from
// the branch the point is in. The cell locator's wall gap, placement, the DEM's wall, the
// closures' local vessel diameter and centre-line speed and the node's wall diagnostics ask this
// interface, so a shape that answers it can carry cells.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <Eigen/Dense>

#include <array>
#include <vector>

namespace hemo {

// A facet of the wall the DEM collides with.
struct WallTriangle {
  std::array<Eigen::Vector3d, 3> vertex;
};

class VesselWall {
 public:
  using Point = Eigen::Vector3d;
  virtual ~VesselWall() = default;

  // The signed distance from x to the wall, m: negative inside, zero on the wall, positive
  // outside.
  virtual double signed_distance(const Point& x) const = 0;
  // The wall's outward unit normal at the wall point nearest x.
  virtual Point outward_normal(const Point& x) const = 0;
  bool inside(const Point& x) const { return signed_distance(x) < 0; }

  // The vessel's section through a point.
  struct Section {
    double radius = 0;       // m, the wall's radius there
    double off_axis = 0;     // m, the point's distance from the section's centre line
    double speed_scale = 1;  // the centre-line speed there is the vessel's fastest times its square
    // The centre-line speed there, m/s, from the vessel's fastest centre-line speed.
    double centreline_speed(double fastest) const { return fastest * speed_scale * speed_scale; }
  };
  virtual Section section_at(const Point& x) const = 0;
  // Whether section_at gives a centre-line speed (speed_scale); an imported surface's does not.
  virtual bool defines_centreline_speed() const { return true; }

  // The wall the DEM collides with, as facets whose normals point into the vessel (LIGGGHTS's fix
  // mesh/surface reads them from an STL file: write_stl, model/geometry.h). Open where the vessel
  // has open ends.
  virtual std::vector<WallTriangle> dem_wall() const = 0;

  // The outlets of the vessel with open ends: each cap's centre, outward unit normal and radius
  // (its area's equivalent), in the order of the fluid mesh's outlet patches (outlet_1, ...).
  struct Opening {
    Point centre, normal;
    double radius = 0;
  };
  virtual std::vector<Opening> outlets() const = 0;

  // Whether the wall is r = R(z) about the z axis (VesselGeometry); else a surface vessel's.
  virtual bool axisymmetric() const { return false; }

  // A branching vessel's branches, each a tube of its radius about an axis segment that runs with
  // the flow: the parent (from the inlet) first, then the daughters in the order of their outlets.
  // None for a vessel that does not branch.
  struct Branch {
    Point start, end;
    double radius = 0;  // m
    // How far inside the vessel a point of the branch's circle may lie and still be on the
    // branch's own wall, m: 0 for an exact wall, a triangulated wall's facets' deviation else.
    double tolerance = 0;
  };
  virtual std::vector<Branch> branches() const { return {}; }
  // The index into branches() of the branch x is in; -1 for a vessel that does not branch.
  virtual int branch_at(const Point& /*x*/) const { return -1; }
};

}  // namespace hemo
