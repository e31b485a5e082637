// The vessel's shape, asked by every part that needs it (the fluid mesh, the DEM wall, the cell
// locator, placement, the closures' wall distance, the analysis's profiles): one interface,
// VesselGeometry, and one registration per shape (vessel_shapes()). Every shape is periodic
// along z over [0, length) and axisymmetric about the z axis: its wall is r = R(z).
//
//   "straight"   R(z) = R0: today's tube, every answer in closed form.
//   "stenosis"   a cosine constriction centred at z_c = length / 2, of axial length L_s:
//                  R(z) = R0 (1 - s/2 (1 + cos(2 pi (z - z_c) / L_s)))   for |z - z_c| <= L_s / 2,
//                  R(z) = R0                                            elsewhere,
//                with the severity s = 1 - sqrt(1 - A) from the scene's area reduction A at the
//                throat (vessel.stenosis_area_reduction; 0.5: the throat's cross-section is half
//                the vessel's, R_throat = R0 sqrt(1 - A)). R is continuous with its slope; the
//                curvature jumps at the constriction's ends.
// Adding a shape: a class deriving from VesselGeometry and one entry in vessel_shapes()
// (model/geometry.cpp); docs/design.md, "A new vessel shape".
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "surface.h"
#include "vessel_wall.h"

#include <Eigen/Dense>

#include <array>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace hemo {

struct Vessel;

class VesselGeometry : public VesselWall {
 public:
  double nominal_radius() const { return radius_; }  // R0, m: the radius the scene's diameter gives
  double length() const { return length_; }          // m, the periodic length along z
  // The axial coordinate of a point, wrapped into [0, length).
  double axial(double z) const;

  // The wall's radius at axial coordinate z (any z: the shape is periodic), m, and its first and
  // second derivatives along z.
  virtual double radius_at(double z) const = 0;
  virtual double radius_slope(double z) const = 0;
  virtual double radius_curvature(double z) const = 0;
  // The narrowest radius, m.
  virtual double throat_radius() const = 0;
  // Whether R(z) is the same everywhere (the DEM may then use its cylinder primitive).
  virtual bool uniform() const { return false; }
  // The centre-line speed at axial coordinate z of a flow whose fastest centre-line speed (at the
  // throat) is `fastest`, m/s: every section passes the same flux, and a section's profile is
  // Poiseuille's in lubrication theory (slopes << 1), so u_c(z) = fastest (R_throat / R(z))^2.
  // Exactly `fastest` in a uniform vessel.
  double centreline_speed_at(double z, double fastest) const {
    const double ratio = throat_radius() / radius_at(z);
    return fastest * ratio * ratio;
  }

  // The vessel's volume, m^3: the integral of pi R(z)^2 over the length.
  virtual double volume() const;
  // The integral over one period of f(R(z)) dz, by composite Gauss-Legendre on each of the
  // shape's smooth pieces (breakpoints()).
  double axial_integral(const std::function<double(double)>& f) const;
  // Where R(z) is not smooth, in [0, length], sorted, both ends included.
  virtual std::vector<double> breakpoints() const { return {0, length_}; }

  // The signed distance from x to the wall, m: negative inside, zero on the wall, positive
  // outside; the exact Euclidean distance to the surface r = R(z).
  double signed_distance(const Point& x) const override;
  // The wall's outward unit normal at the wall point nearest x (at x itself when x is on the
  // wall); the gradient of signed_distance wherever that is differentiable.
  Point outward_normal(const Point& x) const override;
  // The section at x's z: radius R(z), x's distance from the z axis, u_c(z) as
  // centreline_speed_at.
  Section section_at(const Point& x) const override {
    return {radius_at(x.z()), std::hypot(x.x(), x.y()), throat_radius() / radius_at(x.z())};
  }
  bool axisymmetric() const override { return true; }
  // wall_surface at dem_wall_resolution.
  std::vector<WallTriangle> dem_wall() const override;
  // The plane z = length, facing +z.
  std::vector<Opening> outlets() const override {
    return {{Point(0, 0, length()), Point::UnitZ(), radius_at(length())}};
  }

 protected:
  VesselGeometry(double radius, double length) : radius_(radius), length_(length) {}

 private:
  // The axial coordinate of the wall point nearest (r, z) in the meridian plane.
  double nearest_wall_z(double r, double z) const;
  double radius_, length_;
};

// The wall surface the DEM collides with: triangles on r = R(z), `around` vertices per station
// (on the station's circle: the facets' chords lie R (1 - cos(pi / around)) inside it) at `along` + 1 equally spaced
// stations over [0, length], each quad between stations split in two; normals point into the vessel.
std::vector<WallTriangle> wall_surface(const VesselGeometry& geometry, int around, int along);
// The resolution the DEM's wall is made with: its facets within 2e-3 R0 of the wall r = R(z)
// (1e-3 R0 from the chords around, as much from those along).
struct WallResolution {
  int around = 0, along = 0;
};
WallResolution dem_wall_resolution(const VesselGeometry& geometry);
// The triangles as an ASCII STL file (LIGGGHTS's fix mesh/surface reads it); throws
// std::runtime_error when the file cannot be written.
void write_stl(const std::string& path, const std::vector<WallTriangle>& triangles);

// One shape a scene may name (vessel.shape): its name, what it is in a few words, how to build
// it from the scene's vessel, the scene keys of its parameters, the key that sets how narrow it
// gets ("" when it does not narrow), which a throat too narrow for a red cell is blamed on, and
// an example of its parameters, [vessel] lines a scene may hold (the recipe's test builds every
// shape from it: docs/design.md, "A new vessel shape").
//
// A surface vessel (docs/design.md, "Surface vessels") is not axisymmetric: its shape makes a
// closed surface (make_surface; regions "wall", "inlet", "outlet_1", ...: surface.h), which the
// fluid node meshes with snappyHexMesh, and has no `make` (make_vessel_geometry refuses it).
struct VesselShape {
  std::string name;
  std::string description;
  std::function<std::unique_ptr<VesselGeometry>(const Vessel&)> make;
  std::function<Surface(const Vessel&)> make_surface;
  bool surface() const { return static_cast<bool>(make_surface); }
  std::vector<std::string> keys;
  std::string narrowing_key;
  std::string example;
  // A surface vessel's wall as the particle side asks it; none: it carries plasma alone (no shape today).
  std::function<std::unique_ptr<VesselWall>(const Vessel&)> make_wall;
  bool carries_cells() const { return static_cast<bool>(make) || static_cast<bool>(make_wall); }
  bool takes(const std::string& key) const;
};

// Every shape, the default ("straight") first.
const std::vector<VesselShape>& vessel_shapes();
std::vector<std::string> vessel_shape_names();
// The shape named `name`; throws std::invalid_argument naming the known ones when there is none.
const VesselShape& vessel_shape(const std::string& name);

// The geometry of a scene's vessel (vessel.shape and its parameters). Throws
// std::invalid_argument on a vessel that is no such shape (load_scene refuses those first), and
// on a surface vessel, naming it.
std::unique_ptr<VesselGeometry> make_vessel_geometry(const Vessel& vessel);
// The wall of a scene's vessel as the particle side asks it: an axisymmetric shape's geometry, or
// a surface vessel's wall (VesselShape::make_wall). Throws std::invalid_argument on a shape that
// carries plasma alone, naming it.
std::unique_ptr<VesselWall> make_vessel_wall(const Vessel& vessel);

// Whether the vessel is given as a closed surface, and that surface with its regions named
// "wall", "inlet", "outlet_1", ... in order (an imported surface's inlet and outlets renamed so,
// its other solids merged into the wall). Throws SurfaceError on a surface that cannot be a
// vessel, std::invalid_argument on an axisymmetric vessel.
bool surface_vessel(const Vessel& vessel);
Surface make_vessel_surface(const Vessel& vessel);
// The outlets an imported surface's vessel.surface_outlets names, in order.
std::vector<std::string> surface_outlet_names(const Vessel& vessel);

// The stenosis's severity s (R_throat = R0 (1 - s)) from the area reduction A at its throat.
double stenosis_severity(double area_reduction);

}  // namespace hemo
