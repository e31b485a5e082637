// SPDX-License-Identifier: GPL-3.0-or-later
#include "facet_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace hemo {

using Point = Eigen::Vector3d;

// By the region of the triangle's plane the projection of x falls in: a vertex's, an edge's or
// the face's (the barycentric tests of the Voronoi regions).
Point nearest_on_triangle(const Point& x, const Point& a, const Point& b, const Point& c) {
  const Point ab = b - a, ac = c - a, ax = x - a;
  const double d1 = ab.dot(ax), d2 = ac.dot(ax);
  if (d1 <= 0 && d2 <= 0) return a;
  const Point bx = x - b;
  const double d3 = ab.dot(bx), d4 = ac.dot(bx);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Point cx = x - c;
  const double d5 = ab.dot(cx), d6 = ac.dot(cx);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denominator = 1 / (va + vb + vc);
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

double furthest_outside(const VesselWall& wall, const std::vector<WallTriangle>& facets) {
  double most = 0;
  for (const auto& f : facets) {
    const auto& v = f.vertex;
    for (const Point& x : {Point(v[0]), Point(v[1]), Point(v[2]), Point((v[0] + v[1]) / 2), Point((v[1] + v[2]) / 2),
                           Point((v[2] + v[0]) / 2), Point((v[0] + v[1] + v[2]) / 3)})
      most = std::max(most, wall.signed_distance(x));
  }
  return most;
}

FacetDistance::FacetDistance(std::vector<WallTriangle> facets, double reach)
    : facets_(std::move(facets)), reach_(reach) {
  if (!(reach > 0)) throw std::invalid_argument("facet distance: the reach must be positive");
  Point lo = Point::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& f : facets_) {
    for (const auto& v : f.vertex) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  }
  lo_ = facets_.empty() ? Point::Zero() : Point(lo - Point::Constant(reach));
  const Point extent = facets_.empty() ? Point::Constant(reach) : Point(hi - lo + Point::Constant(2 * reach));
  // Bins of at least the reach, and not more than about 2^21 of them.
  h_ = std::max(reach, std::cbrt(extent.prod() / double(1 << 21)));
  for (int d = 0; d < 3; ++d) n_[d] = std::max(1, static_cast<int>(std::ceil(extent[d] / h_)));
  bins_.resize(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]);
  auto index = [&](double v, int d) { return std::clamp(static_cast<int>(std::floor((v - lo_[d]) / h_)), 0, n_[d] - 1); };
  for (std::size_t t = 0; t < facets_.size(); ++t) {
    Point flo = facets_[t].vertex[0], fhi = flo;
    for (const auto& v : facets_[t].vertex) flo = flo.cwiseMin(v), fhi = fhi.cwiseMax(v);
    flo -= Point::Constant(reach), fhi += Point::Constant(reach);
    for (int k = index(flo.z(), 2); k <= index(fhi.z(), 2); ++k)
      for (int j = index(flo.y(), 1); j <= index(fhi.y(), 1); ++j)
        for (int i = index(flo.x(), 0); i <= index(fhi.x(), 0); ++i)
          bins_[(static_cast<std::size_t>(k) * n_[1] + j) * n_[0] + i].push_back(static_cast<int>(t));
  }
}

double FacetDistance::distance(const Point& x) const {
  constexpr double kNone = std::numeric_limits<double>::infinity();
  int ijk[3];
  for (int d = 0; d < 3; ++d) {
    const double u = std::floor((x[d] - lo_[d]) / h_);
    if (u < 0 || u >= n_[d]) return kNone;  // farther than the reach from every facet
    ijk[d] = static_cast<int>(u);
  }
  double best = kNone;
  for (const int t : bins_[(static_cast<std::size_t>(ijk[2]) * n_[1] + ijk[1]) * n_[0] + ijk[0]]) {
    const auto& v = facets_[static_cast<std::size_t>(t)].vertex;
    best = std::min(best, (x - nearest_on_triangle(x, v[0], v[1], v[2])).norm());
  }
  return best <= reach_ ? best : kNone;
}

}  // namespace hemo
