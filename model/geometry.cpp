// SPDX-License-Identifier: GPL-3.0-or-later
#include "geometry.h"

#include "bifurcation.h"
#include "scene.h"
#include "surface_wall.h"
#include "units.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace hemo {

double VesselGeometry::axial(double z) const {
  const double w = z - length_ * std::floor(z / length_);
  return w < length_ ? w : 0.0;  // floor's round-off can leave w == length
}

double VesselGeometry::volume() const {
  return axial_integral([](double R) { return units::pi * R * R; });
}

double VesselGeometry::axial_integral(const std::function<double(double)>& f) const {
  // Five-point Gauss-Legendre, exact for polynomials of degree 9, on panels of each smooth piece:
  // 64 panels make the cosine constriction's integrals exact to round-off.
  static constexpr std::array<double, 5> node = {0.0, 0.5384693101056831, -0.5384693101056831, 0.9061798459386640,
                                                 -0.9061798459386640};
  static constexpr std::array<double, 5> weight = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                                                   0.2369268850561891, 0.2369268850561891};
  constexpr int panels = 64;
  const std::vector<double> b = breakpoints();
  double sum = 0;
  for (std::size_t piece = 0; piece + 1 < b.size(); ++piece) {
    const double h = (b[piece + 1] - b[piece]) / panels;
    for (int p = 0; p < panels; ++p) {
      const double mid = b[piece] + (p + 0.5) * h;
      for (std::size_t i = 0; i < node.size(); ++i) sum += weight[i] * h / 2 * f(radius_at(mid + node[i] * h / 2));
    }
  }
  return sum;
}

// The nearest wall point of (r, z) in the meridian plane minimises
// g(z') = (z' - z)^2 + (R(z') - r)^2. The wall point at z itself is |r - R(z)| away, so the
// nearest lies within that distance along z: sampled there, then refined by Newton's method on
// g'(z') / 2 = (z' - z) + (R - r) R' = 0 within the best sample's neighbourhood.
double VesselGeometry::nearest_wall_z(double r, double z) const {
  const double reach = std::abs(r - radius_at(z));
  if (reach == 0) return z;
  constexpr int samples = 16;
  auto g = [&](double zp) { return (zp - z) * (zp - z) + (radius_at(zp) - r) * (radius_at(zp) - r); };
  double best = z, best_g = g(z);
  const double h = 2 * reach / samples;
  for (int i = 0; i <= samples; ++i) {
    const double zp = z - reach + i * h;
    if (const double gi = g(zp); gi < best_g) best = zp, best_g = gi;
  }
  const double lo = best - h, hi = best + h;
  double zp = best;
  for (int it = 0; it < 20; ++it) {
    const double R = radius_at(zp), dR = radius_slope(zp), d2R = radius_curvature(zp);
    const double grad = (zp - z) + (R - r) * dR, hess = 1 + dR * dR + (R - r) * d2R;
    if (!(hess > 0)) break;  // not convex here: keep the sample
    const double next = std::clamp(zp - grad / hess, lo, hi);
    const bool done = std::abs(next - zp) <= 1e-15 * (std::abs(zp) + length_);
    zp = next;
    if (done) break;
  }
  return g(zp) <= best_g ? zp : best;
}

double VesselGeometry::signed_distance(const Point& x) const {
  const double r = std::hypot(x.x(), x.y()), z = x.z();
  const double zs = nearest_wall_z(r, z);
  const double d = std::hypot(zs - z, radius_at(zs) - r);
  return r < radius_at(z) ? -d : d;
}

VesselGeometry::Point VesselGeometry::outward_normal(const Point& x) const {
  const double r = std::hypot(x.x(), x.y());
  const double zs = nearest_wall_z(r, x.z());
  const double dR = radius_slope(zs), n = std::sqrt(1 + dR * dR);
  // On the axis every direction is as near: take x's.
  const double cx = r > 0 ? x.x() / r : 1.0, cy = r > 0 ? x.y() / r : 0.0;
  return Point(cx / n, cy / n, -dR / n);
}

namespace {

// Today's tube, in closed form; the same floating-point operations the code used before shapes.
class Straight final : public VesselGeometry {
 public:
  Straight(double radius, double length) : VesselGeometry(radius, length) {}
  double radius_at(double) const override { return nominal_radius(); }
  double radius_slope(double) const override { return 0; }
  double radius_curvature(double) const override { return 0; }
  double throat_radius() const override { return nominal_radius(); }
  bool uniform() const override { return true; }
  double volume() const override { return units::pi * nominal_radius() * nominal_radius() * length(); }
  double signed_distance(const Point& x) const override { return std::hypot(x.x(), x.y()) - nominal_radius(); }
  Point outward_normal(const Point& x) const override {
    const double r = std::hypot(x.x(), x.y());
    return r > 0 ? Point(x.x() / r, x.y() / r, 0) : Point(1, 0, 0);
  }
};

class Stenosis final : public VesselGeometry {
 public:
  Stenosis(double radius, double length, double severity, double constriction_length)
      : VesselGeometry(radius, length),
        severity_(severity),
        half_(constriction_length / 2),
        centre_(length / 2),
        k_(2 * units::pi / constriction_length) {}
  double radius_at(double z) const override {
    const double u = offset(z);
    return std::abs(u) <= half_ ? nominal_radius() * (1 - severity_ / 2 * (1 + std::cos(k_ * u))) : nominal_radius();
  }
  double radius_slope(double z) const override {
    const double u = offset(z);
    return std::abs(u) <= half_ ? nominal_radius() * severity_ / 2 * k_ * std::sin(k_ * u) : 0;
  }
  double radius_curvature(double z) const override {
    const double u = offset(z);
    return std::abs(u) <= half_ ? nominal_radius() * severity_ / 2 * k_ * k_ * std::cos(k_ * u) : 0;
  }
  double throat_radius() const override { return nominal_radius() * (1 - severity_); }
  std::vector<double> breakpoints() const override {
    std::vector<double> b{0, centre_ - half_, centre_ + half_, length()};
    b.erase(std::unique(b.begin(), b.end()), b.end());
    return b;
  }

 private:
  // z - z_c, wrapped into [-length/2, length/2].
  double offset(double z) const {
    const double u = z - centre_;
    return u - length() * std::round(u / length());
  }
  double severity_, half_, centre_, k_;
};

}  // namespace

std::vector<WallTriangle> wall_surface(const VesselGeometry& geometry, int around, int along) {
  if (around < 3 || along < 1) throw std::invalid_argument("a wall surface needs >= 3 vertices around, >= 1 station");
  std::vector<VesselGeometry::Point> ring;  // station k's vertex i at k * around + i
  ring.reserve(static_cast<std::size_t>(around) * static_cast<std::size_t>(along + 1));
  for (int k = 0; k <= along; ++k) {
    const double z = k == along ? geometry.length() : geometry.length() * k / along;
    const double R = geometry.radius_at(z);
    for (int i = 0; i < around; ++i) {
      const double t = 2 * units::pi * i / around;
      ring.emplace_back(R * std::cos(t), R * std::sin(t), z);
    }
  }
  auto at = [&](int k, int i) { return ring[static_cast<std::size_t>(k * around + i % around)]; };
  std::vector<WallTriangle> out;
  out.reserve(2 * static_cast<std::size_t>(around) * static_cast<std::size_t>(along));
  for (int k = 0; k < along; ++k)
    for (int i = 0; i < around; ++i) {
      // Counter-clockwise seen from the axis: the normal (b - a) x (c - a) points inwards.
      out.push_back({{at(k, i), at(k + 1, i), at(k + 1, i + 1)}});
      out.push_back({{at(k, i), at(k + 1, i + 1), at(k, i + 1)}});
    }
  return out;
}

WallResolution dem_wall_resolution(const VesselGeometry& geometry) {
  // The facets within 2e-3 R0 of the wall: around, 1 - cos(pi / n) <= 1e-3 (n >= 71; 72, a
  // multiple of the O-grid's 4 blocks); along, the chord of R(z) between stations, max|R''| h^2 / 8,
  // at most 1e-3 R0 more, and stations at most R0 / 2 apart (LIGGGHTS bins facets by their boxes: long ones
  // sit in many bins). What the facets cost per DEM step: docs/performance.md §7.
  constexpr double tolerance = 1e-3;
  constexpr int around = 72;
  const double R0 = geometry.nominal_radius(), length = geometry.length();
  double curvature = 0;
  constexpr int samples = 4096;
  for (int i = 0; i < samples; ++i)
    curvature = std::max(curvature, std::abs(geometry.radius_curvature(length * i / samples)));
  double spacing = R0 / 2;
  if (curvature > 0) spacing = std::min(spacing, std::sqrt(8 * tolerance * R0 / curvature));
  return {around, std::max(1, static_cast<int>(std::ceil(length / spacing)))};
}

std::vector<WallTriangle> VesselGeometry::dem_wall() const {
  const WallResolution res = dem_wall_resolution(*this);
  return wall_surface(*this, res.around, res.along);
}

void write_stl(const std::string& path, const std::vector<WallTriangle>& triangles) {
  std::ofstream out(path);
  out.precision(17);
  out << "solid vessel_wall\n";
  for (const WallTriangle& t : triangles) {
    const VesselGeometry::Point n = (t.vertex[1] - t.vertex[0]).cross(t.vertex[2] - t.vertex[0]).normalized();
    out << " facet normal " << n.x() << ' ' << n.y() << ' ' << n.z() << "\n  outer loop\n";
    for (const auto& v : t.vertex) out << "   vertex " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    out << "  endloop\n endfacet\n";
  }
  out << "endsolid vessel_wall\n";
  if (!out.flush()) throw std::runtime_error("cannot write the vessel wall's surface to " + path);
}

double stenosis_severity(double area_reduction) { return 1 - std::sqrt(1 - area_reduction); }

namespace {

BifurcationSpec bifurcation_spec(const Vessel& v) {
  BifurcationSpec b;
  b.parent_diameter = v.diameter;
  b.parent_length = v.length;
  b.daughter_diameter[0] = v.daughter_diameter[0];
  b.daughter_diameter[1] = v.daughter_diameter[1];
  b.daughter_length = v.daughter_length;
  b.angle = v.bifurcation_angle;
  return b;
}

// The STL's solids as the vessel's regions: the inlet and outlets the scene names become "inlet"
// and "outlet_1", ... in the scene's order, every other solid the wall.
Surface imported_surface(const Vessel& v) {
  Surface s = read_stl(v.surface_path.empty() ? v.surface_file : v.surface_path);
  const std::vector<std::string> outlets = surface_outlet_names(v);
  if (outlets.empty()) throw SurfaceError("vessel.surface_outlets names no outlet");
  std::vector<std::string> named = {v.surface_inlet};
  named.insert(named.end(), outlets.begin(), outlets.end());
  check_regions(s, named);
  std::vector<std::string> regions = {surface_region::wall, surface_region::inlet};
  for (std::size_t k = 0; k < outlets.size(); ++k) regions.push_back(surface_region::outlet(static_cast<int>(k) + 1));
  std::vector<int> to(s.region_names.size(), 0);
  for (std::size_t r = 0; r < s.region_names.size(); ++r)
    for (std::size_t k = 0; k < named.size(); ++k)
      if (s.region_names[r] == named[k]) to[r] = static_cast<int>(k) + 1;
  for (int& r : s.region) r = to[static_cast<std::size_t>(r)];
  s.region_names = regions;
  check_surface(s);
  return s;
}

}  // namespace

std::vector<std::string> surface_outlet_names(const Vessel& v) {
  std::vector<std::string> out;
  std::istringstream words(v.surface_outlets);
  for (std::string w; words >> w;) out.push_back(w);
  return out;
}

std::unique_ptr<VesselWall> make_vessel_wall(const Vessel& vessel) {
  const VesselShape& shape = vessel_shape(vessel.shape);
  if (shape.make) return make_vessel_geometry(vessel);
  if (shape.make_wall) return shape.make_wall(vessel);
  throw std::invalid_argument("vessel.shape \"" + shape.name +
                              "\" carries plasma alone: the particle node does not "
                              "know its branches");
}

bool surface_vessel(const Vessel& vessel) { return vessel_shape(vessel.shape).surface(); }

Surface make_vessel_surface(const Vessel& vessel) {
  const VesselShape& shape = vessel_shape(vessel.shape);
  if (!shape.surface())
    throw std::invalid_argument("vessel.shape \"" + shape.name + "\" is axisymmetric, not a closed surface");
  return shape.make_surface(vessel);
}

const std::vector<VesselShape>& vessel_shapes() {
  static const std::vector<VesselShape> shapes = {
      {"straight",
       "a straight periodic tube of the vessel's diameter",
       [](const Vessel& v) { return std::make_unique<Straight>(v.radius(), v.length); },
       nullptr,
       {},
       "",
       "",
       nullptr},
      {"stenosis",
       "a cosine constriction of vessel.stenosis_length_um centred in the length, its throat's area reduced by "
       "vessel.stenosis_area_reduction",
       [](const Vessel& v) {
         if (!(v.stenosis_area_reduction >= 0 && v.stenosis_area_reduction < 1) || !(v.stenosis_length > 0) ||
             !(v.stenosis_length <= v.length))
           throw std::invalid_argument(
               "a stenosis needs an area reduction in [0, 1) and a length in (0, the vessel's length]");
         return std::make_unique<Stenosis>(v.radius(), v.length, stenosis_severity(v.stenosis_area_reduction),
                                           v.stenosis_length);
       },
       nullptr,
       {"vessel.stenosis_area_reduction", "vessel.stenosis_length_um"},
       "vessel.stenosis_area_reduction",
       "stenosis_area_reduction = 0.5\nstenosis_length_um = 300",
       nullptr},
      // Surface vessels: open ends, meshed by snappyHexMesh.
      {"bifurcation",
       "a Y bifurcation: the vessel is the parent, from its inlet at z = 0 along +z, two daughters from its end at "
       "+-vessel.bifurcation_angle_deg / 2 in the x-z plane, each to an outlet",
       nullptr,
       [](const Vessel& v) { return make_bifurcation(bifurcation_spec(v)); },
       {"vessel.daughter_1_diameter_um", "vessel.daughter_2_diameter_um", "vessel.daughter_length_um",
        "vessel.bifurcation_angle_deg", "mesh.surface_cell_size_um"},
       "",
       "ends = \"open\"\ninlet = \"poiseuille\"\ndaughter_length_um = 600",
       [](const Vessel& v) { return std::make_unique<BifurcationWall>(bifurcation_spec(v)); }},
      {"imported",
       "a closed surface from an ASCII STL (vessel.surface), one solid per region",
       nullptr,
       imported_surface,
       {"vessel.surface", "vessel.surface_inlet", "vessel.surface_outlets", "mesh.surface_cell_size_um"},
       "",
       "ends = \"open\"\ninlet = \"poiseuille\"\nsurface = \"surfaces/y-bifurcation.stl\"\nsurface_inlet = \"in\"\n"
       "surface_outlets = \"out_wide out_narrow\"",  // scenes/imported.toml's
       [](const Vessel& v) { return std::make_unique<SurfaceWall>(imported_surface(v)); }},
  };
  return shapes;
}

bool VesselShape::takes(const std::string& key) const { return std::find(keys.begin(), keys.end(), key) != keys.end(); }

std::vector<std::string> vessel_shape_names() {
  std::vector<std::string> names;
  for (const VesselShape& s : vessel_shapes()) names.push_back(s.name);
  return names;
}

const VesselShape& vessel_shape(const std::string& name) {
  for (const VesselShape& s : vessel_shapes())
    if (s.name == name) return s;
  std::string known;
  for (const VesselShape& s : vessel_shapes()) known += (known.empty() ? "" : ", ") + s.name;
  throw std::invalid_argument("no vessel shape '" + name + "' (known: " + known + ")");
}

std::unique_ptr<VesselGeometry> make_vessel_geometry(const Vessel& vessel) {
  if (!(vessel.diameter > 0) || !(vessel.length > 0))
    throw std::invalid_argument("a vessel needs a positive diameter and length");
  const VesselShape& shape = vessel_shape(vessel.shape);
  if (!shape.make)
    throw std::invalid_argument("vessel.shape \"" + shape.name +
                                "\" is a closed surface, not an axisymmetric vessel r = R(z): only the fluid node "
                                "meshes it (docs/design.md, \"Surface vessels\")");
  return shape.make(vessel);
}

}  // namespace hemo
