// SPDX-License-Identifier: GPL-3.0-or-later
#include "surface.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

namespace hemo {

std::string surface_region::outlet(int n) { return "outlet_" + std::to_string(n); }

int Surface::region_index(const std::string& name) const {
  const auto it = std::find(region_names.begin(), region_names.end(), name);
  return it == region_names.end() ? -1 : static_cast<int>(it - region_names.begin());
}

namespace {
// Twice a triangle's area vector.
Surface::Point cross_of(const Surface& s, const std::array<int, 3>& t) {
  const auto& a = s.points[static_cast<std::size_t>(t[0])];
  const auto& b = s.points[static_cast<std::size_t>(t[1])];
  const auto& c = s.points[static_cast<std::size_t>(t[2])];
  return (b - a).cross(c - a);
}
}  // namespace

double Surface::area(int which) const {
  double sum = 0;
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (which < 0 || region[i] == which) sum += cross_of(*this, triangles[i]).norm() / 2;
  return sum;
}

Surface::Point Surface::area_vector(int which) const {
  Point sum = Point::Zero();
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (region[i] == which) sum += cross_of(*this, triangles[i]) / 2;
  return sum;
}

Surface::Point Surface::centroid(int which) const {
  Point sum = Point::Zero();
  double a = 0;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    if (region[i] != which) continue;
    const auto& t = triangles[i];
    const double ai = cross_of(*this, t).norm() / 2;
    sum += ai * (points[static_cast<std::size_t>(t[0])] + points[static_cast<std::size_t>(t[1])] +
                 points[static_cast<std::size_t>(t[2])]) /
           3;
    a += ai;
  }
  return a > 0 ? Point(sum / a) : Point(Point::Constant(std::nan("")));
}

double Surface::volume() const {
  // Each triangle with the origin spans a tetrahedron of signed volume a . (b x c) / 6; about the
  // centre of the bounding box rather than the origin, so that far-off surfaces lose no digits.
  const Point o = (lower() + upper()) / 2;
  double sum = 0;
  for (const auto& t : triangles) {
    const Point a = points[static_cast<std::size_t>(t[0])] - o, b = points[static_cast<std::size_t>(t[1])] - o,
                c = points[static_cast<std::size_t>(t[2])] - o;
    sum += a.dot(b.cross(c));
  }
  return sum / 6;
}

Surface::Point Surface::lower() const {
  Point p = Point::Constant(std::numeric_limits<double>::infinity());
  for (const auto& q : points) p = p.cwiseMin(q);
  return p;
}

Surface::Point Surface::upper() const {
  Point p = Point::Constant(-std::numeric_limits<double>::infinity());
  for (const auto& q : points) p = p.cwiseMax(q);
  return p;
}

void check_surface(const Surface& s) {
  if (s.triangles.empty()) throw SurfaceError("the surface has no triangles");
  for (std::size_t i = 0; i < s.points.size(); ++i)
    if (!s.points[i].allFinite())
      throw SurfaceError(fmt::format("point {} of the surface is not finite ({} {} {})", i, s.points[i].x(),
                                     s.points[i].y(), s.points[i].z()));
  if (s.region.size() != s.triangles.size())
    throw SurfaceError(fmt::format("the surface has {} triangles but {} region labels", s.triangles.size(),
                                   s.region.size()));
  const int n = static_cast<int>(s.points.size());
  std::vector<int> per_region(s.region_names.size(), 0);
  // Each directed edge (a, b) of a triangle; a closed, consistently oriented surface has every one
  // exactly once and its reverse exactly once.
  std::map<std::pair<int, int>, int> directed;
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    const auto& t = s.triangles[i];
    for (int v : t)
      if (v < 0 || v >= n) throw SurfaceError(fmt::format("triangle {} names point {}, not one of the {}", i, v, n));
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      throw SurfaceError(fmt::format("triangle {} repeats a point ({} {} {})", i, t[0], t[1], t[2]));
    const int r = s.region[i];
    if (r < 0 || r >= static_cast<int>(s.region_names.size()))
      throw SurfaceError(fmt::format("triangle {} is in region {}, not one of the {}", i, r, s.region_names.size()));
    ++per_region[static_cast<std::size_t>(r)];
    for (int k = 0; k < 3; ++k) ++directed[{t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)]}];
  }
  for (const auto& [edge, count] : directed) {
    const auto back = directed.find({edge.second, edge.first});
    const int reverse = back == directed.end() ? 0 : back->second;
    const auto& a = s.points[static_cast<std::size_t>(edge.first)];
    const auto& b = s.points[static_cast<std::size_t>(edge.second)];
    const std::string where = fmt::format("the edge from ({:.6g} {:.6g} {:.6g}) to ({:.6g} {:.6g} {:.6g})", a.x(),
                                          a.y(), a.z(), b.x(), b.y(), b.z());
    if (count + reverse != 2)
      throw SurfaceError(fmt::format("the surface is not closed: {} is shared by {} triangle(s), not 2", where,
                                     count + reverse));
    if (count != 1)
      throw SurfaceError(
          fmt::format("the surface is not consistently oriented: {} runs the same way in two triangles", where));
  }
  for (std::size_t r = 0; r < per_region.size(); ++r)
    if (per_region[r] == 0) throw SurfaceError(fmt::format("region '{}' has no triangles", s.region_names[r]));
  if (!(s.volume() > 0))
    throw SurfaceError(fmt::format("the surface's normals point inwards (enclosed volume {:.6g} m^3)", s.volume()));
}

void check_regions(const Surface& s, const std::vector<std::string>& names) {
  for (const auto& name : names) {
    if (s.region_index(name) >= 0) continue;
    std::string known;
    for (const auto& r : s.region_names) known += (known.empty() ? "" : ", ") + r;
    throw SurfaceError(fmt::format("the surface has no region '{}' (its regions: {})", name, known));
  }
}

Surface read_stl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SurfaceError(fmt::format("{}: cannot be read", path));
  Surface s;
  std::map<std::tuple<double, double, double>, int> index;  // equal coordinates: one point
  std::string line;
  int line_no = 0, current = -1, in_facet = 0;
  std::array<int, 3> tri{};
  auto fail = [&](const std::string& why) { throw SurfaceError(fmt::format("{}:{}: {}", path, line_no, why)); };
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find('\0') != std::string::npos) fail("not an ASCII STL (binary STL is not read: write it as ASCII)");
    std::istringstream words(line);
    std::string word;
    if (!(words >> word)) continue;
    if (word == "solid") {
      if (current >= 0) fail("a solid inside a solid");
      std::string name;
      std::getline(words >> std::ws, name);
      while (!name.empty() && std::isspace(static_cast<unsigned char>(name.back()))) name.pop_back();
      if (name.empty()) name = "solid";
      current = s.region_index(name);
      if (current < 0) {
        current = static_cast<int>(s.region_names.size());
        s.region_names.push_back(name);
      }
    } else if (word == "endsolid") {
      if (current < 0) fail("endsolid without solid");
      current = -1;
    } else if (word == "facet") {
      if (current < 0) fail("a facet outside a solid");
      in_facet = 1;
    } else if (word == "vertex") {
      if (in_facet < 1 || in_facet > 3) fail("a vertex outside a facet's loop of three");
      // strtod, not >>: it reads "nan" and "inf", which are then refused by name.
      std::string text[3];
      if (!(words >> text[0] >> text[1] >> text[2])) fail("a vertex needs three coordinates");
      double c[3];
      for (int k = 0; k < 3; ++k) {
        char* end = nullptr;
        c[k] = std::strtod(text[k].c_str(), &end);
        if (end == text[k].c_str() || *end != '\0') fail("'" + text[k] + "' is not a number");
        if (!std::isfinite(c[k])) fail("vertex coordinate '" + text[k] + "' is not a finite number");
      }
      const auto key = std::make_tuple(c[0], c[1], c[2]);
      auto it = index.find(key);
      if (it == index.end()) {
        it = index.emplace(key, static_cast<int>(s.points.size())).first;
        s.points.emplace_back(c[0], c[1], c[2]);
      }
      tri[static_cast<std::size_t>(in_facet - 1)] = it->second;
      ++in_facet;
    } else if (word == "endfacet") {
      if (in_facet != 4) fail("a facet without three vertices");
      s.triangles.push_back(tri);
      s.region.push_back(current);
      in_facet = 0;
    } else if (word != "outer" && word != "endloop") {
      fail("'" + word + "' is not a word of ASCII STL");
    }
  }
  if (current >= 0) fail("the file ends inside solid '" + s.region_names[static_cast<std::size_t>(current)] + "'");
  if (s.triangles.empty()) throw SurfaceError(fmt::format("{}: holds no triangles", path));
  return s;
}

void write_stl(const std::string& path, const Surface& s) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path);
  for (std::size_t r = 0; r < s.region_names.size(); ++r) {
    out << "solid " << s.region_names[r] << '\n';
    for (std::size_t i = 0; i < s.triangles.size(); ++i) {
      if (s.region[i] != static_cast<int>(r)) continue;
      const auto& t = s.triangles[i];
      const Surface::Point n = cross_of(s, t).normalized();
      out << fmt::format("facet normal {:.9g} {:.9g} {:.9g}\n outer loop\n", n.x(), n.y(), n.z());
      for (int v : t) {
        const auto& p = s.points[static_cast<std::size_t>(v)];
        out << fmt::format("  vertex {:.17g} {:.17g} {:.17g}\n", p.x(), p.y(), p.z());
      }
      out << " endloop\nendfacet\n";
    }
    out << "endsolid " << s.region_names[r] << '\n';
  }
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace hemo
