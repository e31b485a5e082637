// A vessel given as a closed triangulated surface with named regions (docs/design.md, "Surface
// vessels"): the wall and the ends through which plasma enters and leaves. The fluid node meshes
// it with OpenFOAM's blockMesh + snappyHexMesh (fluid-node/surface_mesh.h), and each region
// becomes a patch of that name. Engine-free: points, triangles, regions, and their checks.
//
// The carrier is ASCII STL with one `solid <region>` per region: snappyHexMesh reads a
// multi-solid ASCII STL's solids as the surface's regions, so the names travel with the file.
// STL repeats each vertex in every triangle; reading merges vertices of equal coordinates (our
// writer prints round-trip precision, so a written surface reads back with its own topology).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <Eigen/Dense>

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace hemo {

// A surface that cannot be a vessel, or a file that holds none: one line saying why.
class SurfaceError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// The region names a surface vessel's patches take (fluid-node/surface_mesh.h): the wall, the
// inlet, and outlets outlet_1, outlet_2, ...
namespace surface_region {
inline constexpr const char* wall = "wall";
inline constexpr const char* inlet = "inlet";
std::string outlet(int n);  // "outlet_<n>", n from 1
}  // namespace surface_region

struct Surface {
  using Point = Eigen::Vector3d;
  std::vector<Point> points;
  std::vector<std::array<int, 3>> triangles;  // counter-clockwise seen from outside: normals point out
  std::vector<int> region;                    // per triangle, an index into region_names
  std::vector<std::string> region_names;

  // The index of the region named `name`; -1 when there is none.
  int region_index(const std::string& name) const;
  // The area of one region, or of the whole surface (region -1), m^2.
  double area(int region = -1) const;
  // The area vector (sum of the triangles' area-weighted outward normals) and the area-weighted
  // centroid of one region.
  Point area_vector(int region) const;
  Point centroid(int region) const;
  // The enclosed volume, m^3 (divergence theorem; positive when the normals point out).
  double volume() const;
  // The axis-aligned bounding box of the points.
  Point lower() const;
  Point upper() const;
};

// Checks that `surface` can be a vessel: every coordinate finite, every triangle's indices valid
// and distinct, a region per triangle, every edge shared by exactly two triangles that run it in
// opposite directions (closed and consistently oriented), normals pointing out, and a triangle in
// every region. Throws SurfaceError naming the first problem.
void check_surface(const Surface& surface);
// And that it has regions of each of `names`; throws SurfaceError naming the missing one and the
// regions it has.
void check_regions(const Surface& surface, const std::vector<std::string>& names);

// Reads an ASCII STL; each solid's name is a region's (several solids of one name are one
// region). The triangles keep the file's orientation; the facets' normal lines are not used (the
// vertices' order defines them). Throws SurfaceError on a file that cannot be read, a binary STL,
// a malformed line or a coordinate that is not a finite number, naming the line. Not checked:
// closedness (check_surface).
Surface read_stl(const std::string& path);
// Writes one solid per region, at round-trip precision; throws std::runtime_error when the file
// cannot be written.
void write_stl(const std::string& path, const Surface& surface);

}  // namespace hemo
