// SPDX-License-Identifier: GPL-3.0-or-later
#include "surface_wall.h"

#include "facet_distance.h"
#include "units.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace hemo {

using Point = Eigen::Vector3d;

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The most bins (each two candidate lists, made on first use by a search from its centre).
constexpr double kMostBins = 2e5;

// The angle of triangle (a, b, c) at a.
double angle_at(const Point& a, const Point& b, const Point& c) {
  return std::atan2((b - a).cross(c - a).norm(), (b - a).dot(c - a));
}

// The distance t > t_min at which the ray x + t u meets triangle (a, b, c), or +infinity
// (Moeller & Trumbore, J. Graphics Tools 2, 1997).
double ray_triangle(const Point& x, const Point& u, const Point& a, const Point& b, const Point& c, double t_min) {
  const Point e1 = b - a, e2 = c - a, p = u.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-30) return kInfinity;  // the ray runs in the triangle's plane
  const Point s = x - a;
  const double v = s.dot(p) / det;
  if (v < 0 || v > 1) return kInfinity;
  const Point q = s.cross(e1);
  const double w = u.dot(q) / det;
  if (w < 0 || v + w > 1) return kInfinity;
  const double t = e2.dot(q) / det;
  return t > t_min ? t : kInfinity;
}

// The point of triangle (a, b, c) nearest x, as nearest_on_triangle finds it, and the feature it
// is on: vertex 0, 1, 2; edge 3 + k from vertex k to k + 1; the face 6. From the Voronoi region
// the tests put x in, not from barycentric coordinates, which a sliver's round-off would blur.
Point nearest_with_feature(const Point& x, const Point& a, const Point& b, const Point& c, int* feature) {
  const Point ab = b - a, ac = c - a, ax = x - a;
  const double d1 = ab.dot(ax), d2 = ac.dot(ax);
  if (d1 <= 0 && d2 <= 0) return *feature = 0, a;
  const Point bx = x - b;
  const double d3 = ab.dot(bx), d4 = ac.dot(bx);
  if (d3 >= 0 && d4 <= d3) return *feature = 1, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return *feature = 3, Point(a + (d1 / (d1 - d3)) * ab);
  const Point cx = x - c;
  const double d5 = ab.dot(cx), d6 = ac.dot(cx);
  if (d6 >= 0 && d5 <= d6) return *feature = 2, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return *feature = 5, Point(a + (d2 / (d2 - d6)) * ac);
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return *feature = 4, Point(b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b));
  const double denominator = 1 / (va + vb + vc);
  return *feature = 6, Point(a + ab * (vb * denominator) + ac * (vc * denominator));
}

}  // namespace

SurfaceWall::SurfaceWall(Surface surface) : surface_(std::move(surface)) {
  check_surface(surface_);
  wall_region_ = surface_.region_index(surface_region::wall);
  if (wall_region_ < 0) throw SurfaceError("the vessel's surface has no wall region");
  const auto& pts = surface_.points;
  const auto& tris = surface_.triangles;
  auto point = [&](int v) -> const Point& { return pts[static_cast<std::size_t>(v)]; };

  // Pseudo-normals: a face's own; an edge's the sum of its two faces'; a vertex's the sum of its
  // faces' weighted by their angles there.
  face_normal_.resize(tris.size());
  vertex_normal_.assign(pts.size(), Point::Zero());
  std::map<std::pair<int, int>, Point> edge_sum;
  for (std::size_t t = 0; t < tris.size(); ++t) {
    const auto& v = tris[t];
    face_normal_[t] = (point(v[1]) - point(v[0])).cross(point(v[2]) - point(v[0])).normalized();
    for (int k = 0; k < 3; ++k) {
      const int a = v[static_cast<std::size_t>(k)], b = v[static_cast<std::size_t>((k + 1) % 3)],
                c = v[static_cast<std::size_t>((k + 2) % 3)];
      vertex_normal_[static_cast<std::size_t>(a)] += angle_at(point(a), point(b), point(c)) * face_normal_[t];
      edge_sum.try_emplace(std::minmax(a, b), Point::Zero()).first->second += face_normal_[t];  // Eigen leaves a new Point unset
    }
  }
  edge_normal_.resize(tris.size());
  for (std::size_t t = 0; t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k)
      edge_normal_[t][static_cast<std::size_t>(k)] =
          edge_sum.at(std::minmax(tris[t][static_cast<std::size_t>(k)], tris[t][static_cast<std::size_t>((k + 1) % 3)]));

  // Bins of about the mean edge, not more than about kMostBins of them; each holds the
  // triangles whose bounding box meets it.
  double edges = 0;
  for (const auto& v : tris) edges += (point(v[1]) - point(v[0])).norm();
  const Point lo = surface_.lower(), hi = surface_.upper();
  const Point extent = (hi - lo).cwiseMax(Point::Constant(1e-12));
  h_ = std::max(edges / static_cast<double>(tris.size()), std::cbrt(extent.prod() / kMostBins));
  lo_ = lo;
  for (int d = 0; d < 3; ++d) n_[d] = std::max(1, static_cast<int>(std::ceil(extent[d] / h_)));
  bins_.resize(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]);
  for (std::size_t t = 0; t < tris.size(); ++t) {
    Point flo = point(tris[t][0]), fhi = flo;
    for (int v : tris[t]) flo = flo.cwiseMin(point(v)), fhi = fhi.cwiseMax(point(v));
    for (int k = bin_index(flo.z(), 2); k <= bin_index(fhi.z(), 2); ++k)
      for (int j = bin_index(flo.y(), 1); j <= bin_index(fhi.y(), 1); ++j)
        for (int i = bin_index(flo.x(), 0); i <= bin_index(fhi.x(), 0); ++i)
          bins_[(static_cast<std::size_t>(k) * n_[1] + j) * n_[0] + i].push_back(static_cast<int>(t));
  }
  candidates_[0].resize(bins_.size());
  candidates_[1].resize(bins_.size());
  candidates_made_[0].assign(bins_.size(), 0);
  candidates_made_[1].assign(bins_.size(), 0);
}

const std::vector<int>& SurfaceWall::candidates(int i, int j, int k, int region) const {
  const int which = region < 0 ? 0 : 1;
  const std::size_t b = (static_cast<std::size_t>(k) * n_[1] + j) * n_[0] + i;
  auto& list = candidates_[which][b];
  if (candidates_made_[which][b]) return list;
  candidates_made_[which][b] = 1;
  // A point x of a bin of centre c and half-diagonal rho is within d(c) + rho of the surface, and
  // a triangle T is at least dist(c, T) - rho from x: only those with dist(c, T) <= d(c) + 2 rho
  // can be nearest. They are in the box lists of the bins that cube of radius meets.
  const Point c = lo_ + h_ * Point(i + 0.5, j + 0.5, k + 0.5);
  const double reach = nearest_by_shells(c, region).distance + std::sqrt(3.0) * h_;
  const int r = static_cast<int>(std::ceil(reach / h_));
  for (int kk = std::max(0, k - r); kk <= std::min(n_[2] - 1, k + r); ++kk)
    for (int jj = std::max(0, j - r); jj <= std::min(n_[1] - 1, j + r); ++jj)
      for (int ii = std::max(0, i - r); ii <= std::min(n_[0] - 1, i + r); ++ii)
        for (const int t : bin(ii, jj, kk)) {
          if (region >= 0 && surface_.region[static_cast<std::size_t>(t)] != region) continue;
          const auto& v = surface_.triangles[static_cast<std::size_t>(t)];
          if ((c - nearest_on_triangle(c, surface_.points[static_cast<std::size_t>(v[0])],
                                       surface_.points[static_cast<std::size_t>(v[1])],
                                       surface_.points[static_cast<std::size_t>(v[2])]))
                  .norm() <= reach)
            list.push_back(t);
        }
  std::sort(list.begin(), list.end());
  list.erase(std::unique(list.begin(), list.end()), list.end());
  return list;
}

int SurfaceWall::bin_index(double v, int d) const {
  const double u = std::floor((v - lo_[d]) / h_);
  return static_cast<int>(std::clamp(u, 0.0, static_cast<double>(n_[d] - 1)));
}

const std::vector<int>& SurfaceWall::bin(int i, int j, int k) const {
  return bins_[(static_cast<std::size_t>(k) * n_[1] + j) * n_[0] + i];
}

void SurfaceWall::consider(const Point& x, int t, Nearest& best) const {
  const auto& v = surface_.triangles[static_cast<std::size_t>(t)];
  int feature = 0;
  const Point p = nearest_with_feature(x, surface_.points[static_cast<std::size_t>(v[0])],
                                       surface_.points[static_cast<std::size_t>(v[1])],
                                       surface_.points[static_cast<std::size_t>(v[2])], &feature);
  const double d = (x - p).norm();
  if (d < best.distance) best.distance = d, best.point = p, best.triangle = t, best.feature = feature;
}

SurfaceWall::Nearest SurfaceWall::nearest_by_shells(const Point& x, int region) const {
  const int c[3] = {bin_index(x.x(), 0), bin_index(x.y(), 1), bin_index(x.z(), 2)};
  Nearest best;
  // Every point in shell r + 1 is at least r bins from x, so once the nearest found is that close
  // no farther shell can hold a nearer one.
  const int shells = std::max({n_[0], n_[1], n_[2]});
  for (int r = 0; r <= shells; ++r) {
    for (int k = std::max(0, c[2] - r); k <= std::min(n_[2] - 1, c[2] + r); ++k)
      for (int j = std::max(0, c[1] - r); j <= std::min(n_[1] - 1, c[1] + r); ++j)
        for (int i = std::max(0, c[0] - r); i <= std::min(n_[0] - 1, c[0] + r); ++i) {
          if (std::max({std::abs(i - c[0]), std::abs(j - c[1]), std::abs(k - c[2])}) != r) continue;
          for (const int t : bin(i, j, k))
            if (region < 0 || surface_.region[static_cast<std::size_t>(t)] == region) consider(x, t, best);
        }
    if (best.triangle >= 0 && best.distance <= r * h_) break;
  }
  return best;
}

SurfaceWall::Nearest SurfaceWall::nearest(const Point& x, int region) const {
  bool in_grid = true;
  for (int d = 0; d < 3; ++d) in_grid = in_grid && x[d] >= lo_[d] && x[d] < lo_[d] + n_[d] * h_;
  if (!in_grid) return nearest_by_shells(x, region);
  Nearest best;
  for (const int t : candidates(bin_index(x.x(), 0), bin_index(x.y(), 1), bin_index(x.z(), 2), region))
    consider(x, t, best);
  return best;
}

Point SurfaceWall::pseudo_normal(const Nearest& n) const {
  const auto t = static_cast<std::size_t>(n.triangle);
  if (n.feature < 3) return vertex_normal_[static_cast<std::size_t>(surface_.triangles[t][static_cast<std::size_t>(n.feature)])];
  if (n.feature < 6) return edge_normal_[t][static_cast<std::size_t>(n.feature - 3)];
  return face_normal_[t];
}

double SurfaceWall::signed_distance(const Point& x) const {
  const Nearest n = nearest(x, -1);
  return (x - n.point).dot(pseudo_normal(n)) > 0 ? n.distance : -n.distance;
}

Point SurfaceWall::outward_normal(const Point& x) const {
  const Nearest n = nearest(x, -1);
  const Point away = x - n.point, pseudo = pseudo_normal(n);
  if (!(n.distance > 1e-12 * h_)) return pseudo.normalized();
  return away.dot(pseudo) > 0 ? Point(away / n.distance) : Point(-away / n.distance);
}

double SurfaceWall::wall_hit(const Point& x, const Point& u) const {
  // Through the bins the ray crosses, in order (Amanatides & Woo, Eurographics 1987): the first
  // hit within the bin being crossed is the first of all.
  int c[3], step[3];
  double t_next[3], t_delta[3];
  for (int d = 0; d < 3; ++d) {
    c[d] = bin_index(x[d], d);
    step[d] = u[d] > 0 ? 1 : -1;
    const double edge = lo_[d] + (c[d] + (u[d] > 0 ? 1 : 0)) * h_;
    t_next[d] = u[d] != 0 ? std::max(0.0, (edge - x[d]) / u[d]) : kInfinity;
    t_delta[d] = u[d] != 0 ? h_ / std::abs(u[d]) : kInfinity;
  }
  double best = kInfinity;
  while (true) {
    for (const int t : bin(c[0], c[1], c[2])) {
      if (surface_.region[static_cast<std::size_t>(t)] != wall_region_) continue;
      const auto& v = surface_.triangles[static_cast<std::size_t>(t)];
      best = std::min(best, ray_triangle(x, u, surface_.points[static_cast<std::size_t>(v[0])],
                                         surface_.points[static_cast<std::size_t>(v[1])],
                                         surface_.points[static_cast<std::size_t>(v[2])], 1e-9 * h_));
    }
    const int d = static_cast<int>(std::min_element(t_next, t_next + 3) - t_next);
    if (best <= t_next[d]) return best;
    c[d] += step[d];
    if (c[d] < 0 || c[d] >= n_[d]) return best;
    t_next[d] += t_delta[d];
  }
}

VesselWall::Section SurfaceWall::section_at(const Point& x) const {
  const Nearest n = nearest(x, wall_region_);
  if (n.triangle < 0) return {kNaN, kNaN, kNaN};
  // Away from the nearest wall point, across the vessel. A feeder's point stands on the inlet's
  // plane (FeederLayout::in_vessel_frame), where this is the inlet disc's diameter through it.
  const Point u = n.distance > 1e-12 * h_ ? Point((x - n.point) / n.distance) : Point(-pseudo_normal(n).normalized());
  const double d1 = n.distance, d2 = wall_hit(x, u);
  if (!std::isfinite(d2)) return {kNaN, kNaN, kNaN};  // no wall across: no section
  return {(d1 + d2) / 2, std::abs(d2 - d1) / 2, kNaN};
}

std::vector<WallTriangle> wall_facing_in(const Surface& s) {
  const int wall = s.region_index(surface_region::wall);
  std::vector<WallTriangle> out;
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    if (s.region[t] != wall) continue;
    const auto& [a, b, c] = s.triangles[t];
    out.push_back({{s.points[static_cast<std::size_t>(a)], s.points[static_cast<std::size_t>(c)],
                    s.points[static_cast<std::size_t>(b)]}});
  }
  return out;
}

std::vector<WallTriangle> SurfaceWall::dem_wall() const { return wall_facing_in(surface_); }

std::vector<VesselWall::Opening> SurfaceWall::outlets() const {
  std::vector<Opening> out;
  for (int k = 1;; ++k) {
    const int r = surface_.region_index(surface_region::outlet(k));
    if (r < 0) return out;
    const Point area = surface_.area_vector(r);
    out.push_back({surface_.centroid(r), area.normalized(), std::sqrt(area.norm() / units::pi)});
  }
}

}  // namespace hemo

namespace hemo {

VesselWall::Branch SurfaceWall::end_branch(int region, bool inward) const {
  const Point centre = surface_.centroid(region), area = surface_.area_vector(region);
  const Point in = -area.normalized();  // into the vessel
  const double radius = std::sqrt(area.norm() / units::pi), tolerance = kBranchWallTolerance * radius;
  const Point u = in.unitOrthogonal(), v = in.cross(u);
  // The wall runs round the tube's circle s in from the end.
  auto round = [&](double s) {
    constexpr int points = 64;
    for (int k = 0; k < points; ++k) {
      const double phi = 2 * units::pi * k / points;
      if (std::abs(signed_distance(centre + s * in + radius * (std::cos(phi) * u + std::sin(phi) * v))) > tolerance)
        return false;
    }
    return true;
  };
  // Stepping in by a tenth of the radius to the surface's far side, then bisecting.
  double reach = 0;
  for (const Point& p : surface_.points) reach = std::max(reach, (p - centre).dot(in));
  const int steps = static_cast<int>(std::ceil(reach / (radius / 10)));
  double good = 0, bad = -1;
  for (int n = 1; n <= steps; ++n) {
    const double s = std::min(reach, n * radius / 10);
    if (!round(s)) {
      bad = s;
      break;
    }
    good = s;
  }
  if (bad > 0)
    while (bad - good > 1e-3 * radius) {
      const double mid = 0.5 * (good + bad);
      (round(mid) ? good : bad) = mid;
    }
  const Point inner = centre + good * in;
  return inward ? Branch{centre, inner, radius, tolerance} : Branch{inner, centre, radius, tolerance};
}

std::vector<VesselWall::Branch> SurfaceWall::branches() const { return branch_list(); }

const std::vector<VesselWall::Branch>& SurfaceWall::branch_list() const {
  if (branches_) return *branches_;
  std::vector<Branch> out;
  if (const int inlet = surface_.region_index(surface_region::inlet); inlet >= 0) {
    out.push_back(end_branch(inlet, true));
    for (int k = 1;; ++k) {
      const int r = surface_.region_index(surface_region::outlet(k));
      if (r < 0) break;
      out.push_back(end_branch(r, false));
    }
  }
  branches_ = std::move(out);
  return *branches_;
}

int SurfaceWall::branch_at(const Point& x) const {
  const std::vector<Branch>& all = branch_list();
  int best = -1;
  double deepest = kInfinity;
  for (std::size_t b = 0; b < all.size(); ++b) {
    const Point axis = all[b].end - all[b].start;
    const double length = axis.norm();
    if (!(length > 0)) continue;
    const double t = (x - all[b].start).dot(axis) / length;
    if (t < 0 || t > length) continue;
    const double depth = (x - all[b].start - t * axis / length).norm() - all[b].radius;
    if (depth <= all[b].tolerance && depth < deepest) best = static_cast<int>(b), deepest = depth;
  }
  return best;
}

}  // namespace hemo
