// SPDX-License-Identifier: GPL-3.0-or-later
#include "bifurcation.h"

#include "surface_wall.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <unordered_map>

namespace hemo {

using Point = Eigen::Vector3d;

double murray_daughter_diameter(double parent_diameter) { return parent_diameter / std::cbrt(2.0); }

BifurcationSpec resolved(const BifurcationSpec& spec) {
  BifurcationSpec s = spec;
  for (double& d : s.daughter_diameter)
    if (d == 0) d = murray_daughter_diameter(s.parent_diameter);
  if (s.daughter_length == 0) s.daughter_length = s.parent_length;
  if (s.step == 0) s.step = std::min({s.parent_diameter, s.daughter_diameter[0], s.daughter_diameter[1]}) / 10;
  return s;
}

Point daughter_direction(const BifurcationSpec& spec, int i) {
  const double half = spec.angle / 2;
  return {(i == 0 ? 1 : -1) * std::sin(half), 0, std::cos(half)};
}

void check_bifurcation(const BifurcationSpec& spec) {
  const BifurcationSpec s = resolved(spec);
  auto um = [](double m) { return m * 1e6; };
  if (!(s.parent_diameter > 0) || !(s.parent_length > 0))
    throw SurfaceError("a bifurcation needs a positive parent diameter and length");
  if (!(s.daughter_length > 0)) throw SurfaceError("a bifurcation needs a positive daughter length");
  if (!(s.angle > 0 && s.angle < 3.14159265358979323846))
    throw SurfaceError(fmt::format("a bifurcation's angle between its daughters must be in (0, 180) degrees, not {:g}",
                                   s.angle * 180 / 3.14159265358979323846));
  if (!(s.step > 0)) throw SurfaceError("a bifurcation's sampling step must be positive");
  for (int i = 0; i < 2; ++i) {
    const double d = s.daughter_diameter[i];
    if (!(d >= kMinDaughterDiameter))
      throw SurfaceError(
          fmt::format("daughter {} of the bifurcation is {:.3g} um across, narrower than a red cell "
                      "({:g} um): widen it or the parent",
                      i + 1, um(d), um(kMinDaughterDiameter)));
    if (!(d <= s.parent_diameter))
      throw SurfaceError(fmt::format("daughter {} of the bifurcation ({:.3g} um) is wider than the parent ({:.3g} um)",
                                     i + 1, um(d), um(s.parent_diameter)));
  }
  const double rp = s.parent_diameter / 2, r1 = s.daughter_diameter[0] / 2, r2 = s.daughter_diameter[1] / 2;
  // The parent's round end (a sphere of its radius about the junction) must leave the inlet cap
  // whole, and each outlet cap must lie clear of it.
  if (!(s.parent_length > rp))
    throw SurfaceError(fmt::format("the bifurcation's parent ({:.3g} um) must be longer than its radius ({:.3g} um)",
                                   um(s.parent_length), um(rp)));
  if (!(s.daughter_length > rp + std::max(r1, r2)))
    throw SurfaceError(
        fmt::format("the bifurcation's daughters ({:.3g} um) must be longer than the parent's radius "
                    "and their own ({:.3g} um)",
                    um(s.daughter_length), um(rp + std::max(r1, r2))));
  // The sampling grid spans the tubes' box: a vessel very long for its narrowest diameter would
  // need more samples than memory holds.
  const double half = s.angle / 2;
  const double wide = 2 * (s.daughter_length * std::sin(half) + rp) + 4 * s.step;
  const double high = s.parent_length + s.daughter_length + 2 * rp + 4 * s.step;
  const double samples = (wide / s.step + 4) * (2 * rp / s.step + 8) * (high / s.step + 4);
  if (!(samples <= kMaxBifurcationSamples))
    throw SurfaceError(
        fmt::format("the bifurcation's sampling grid would have {:.3g} points (at most {:.3g}): it is "
                    "too long or wide for its narrowest diameter (or its sampling step)",
                    samples, kMaxBifurcationSamples));
  const double apart = 2 * s.daughter_length * std::sin(s.angle / 2);
  if (!(apart > r1 + r2))
    throw SurfaceError(
        fmt::format("the bifurcation's outlets overlap: their centres are {:.3g} um apart, less than "
                    "their radii's sum {:.3g} um (widen the angle or lengthen the daughters)",
                    um(apart), um(r1 + r2)));
}

namespace {

// A capsule: the points within r of the segment from a to b.
struct Capsule {
  Point a, b;
  double r;
  double value(const Point& x) const {
    const Point u = (b - a).normalized();
    const double t = std::clamp((x - a).dot(u), 0.0, (b - a).norm());
    return (x - (a + t * u)).norm() - r;
  }
};

// A flat end: its centre, outward normal (along its tube), radius and region.
struct Cap {
  Point centre, normal;
  double radius;
  int region;
};

// Cuts the surface of a tube that runs on through `cap`'s plane: every triangle near the tube's
// axis (its points within the cap's radius and `margin` of the axis, and not more than `margin`
// before the plane) loses what lies beyond the plane, and the cut's loop is closed by a fan of
// triangles about the cap's centre. A triangle crossing the plane keeps the polygon of its part
// before it; each crossing point is made once per edge, so the triangles on either side of an edge
// share it, and the loop the kept triangles leave open is traversed once the other way by the fan.
void cut_and_cap(Surface& s, const Cap& cap, double margin) {
  const auto n_points = s.points.size();
  std::vector<double> d(n_points);
  std::vector<char> near(n_points);
  for (std::size_t v = 0; v < n_points; ++v) {
    const Point rel = s.points[v] - cap.centre;
    d[v] = rel.dot(cap.normal);
    near[v] = (rel - d[v] * cap.normal).norm() < cap.radius + margin && d[v] > -margin;
  }
  const int centre = static_cast<int>(s.points.size());
  s.points.push_back(cap.centre);
  std::map<std::pair<int, int>, int> crossing;
  auto cross = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    if (const auto it = crossing.find(key); it != crossing.end()) return it->second;
    const double da = d[static_cast<std::size_t>(a)], db = d[static_cast<std::size_t>(b)];
    const Point& pa = s.points[static_cast<std::size_t>(a)];
    const Point p = pa + da / (da - db) * (s.points[static_cast<std::size_t>(b)] - pa);
    s.points.push_back(p - (p - cap.centre).dot(cap.normal) * cap.normal);  // exactly on the plane
    crossing.emplace(key, static_cast<int>(s.points.size()) - 1);
    return static_cast<int>(s.points.size()) - 1;
  };
  std::vector<std::array<int, 3>> kept;
  std::vector<int> kept_region;
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    const auto& tri = s.triangles[t];
    bool all_near = true;
    int beyond = 0;
    for (int v : tri) {
      all_near = all_near && near[static_cast<std::size_t>(v)];
      beyond += d[static_cast<std::size_t>(v)] > 0;
    }
    if (!all_near || beyond == 0) {
      kept.push_back(tri);
      kept_region.push_back(s.region[t]);
      continue;
    }
    if (beyond == 3) continue;
    // The part before the plane, in the triangle's order; the crossing where it leaves the part
    // (exit) and where it comes back (entry).
    std::vector<int> poly;
    int exit = -1, entry = -1;
    for (int k = 0; k < 3; ++k) {
      const int a = tri[static_cast<std::size_t>(k)], b = tri[static_cast<std::size_t>((k + 1) % 3)];
      const bool a_in = !(d[static_cast<std::size_t>(a)] > 0), b_in = !(d[static_cast<std::size_t>(b)] > 0);
      if (a_in) poly.push_back(a);
      if (a_in != b_in) {
        const int x = cross(a, b);
        poly.push_back(x);
        (a_in ? exit : entry) = x;
      }
    }
    for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
      kept.push_back({poly[0], poly[k], poly[k + 1]});
      kept_region.push_back(s.region[t]);
    }
    // The kept part runs exit -> entry along the plane; the cap runs it back.
    kept.push_back({entry, exit, centre});
    kept_region.push_back(cap.region);
  }
  s.triangles = std::move(kept);
  s.region = std::move(kept_region);
}

}  // namespace

double network_flow_fraction(const BifurcationSpec& spec, int i) {
  const BifurcationSpec s = resolved(spec);
  const double r1 = s.daughter_diameter[0], r2 = s.daughter_diameter[1];
  const double c1 = r1 * r1 * r1 * r1, c2 = r2 * r2 * r2 * r2;
  return (i == 0 ? c1 : c2) / (c1 + c2);
}

BifurcationWall::BifurcationWall(const BifurcationSpec& spec) : spec_(resolved(spec)) {
  check_bifurcation(spec);
  const Point junction(0, 0, spec_.parent_length);
  start_[0] = Point::Zero();
  end_[0] = junction;
  radius_[0] = spec_.parent_diameter / 2;
  speed_scale_[0] = 1;
  for (int i = 0; i < 2; ++i) {
    start_[i + 1] = junction;
    end_[i + 1] = junction + spec_.daughter_length * daughter_direction(spec_, i);
    radius_[i + 1] = spec_.daughter_diameter[i] / 2;
    speed_scale_[i + 1] = std::sqrt(network_flow_fraction(spec_, i)) * radius_[0] / radius_[i + 1];
  }
}

double BifurcationWall::axis_distance(int b, const Point& x) const {
  const Point axis = end_[b] - start_[b];
  const double t = std::clamp((x - start_[b]).dot(axis) / axis.squaredNorm(), 0.0, 1.0);
  return (x - (start_[b] + t * axis)).norm();
}

int BifurcationWall::branch_at(const Point& x) const {
  // The tube x is deepest in: by the nearest axis alone, a point inside the parent's wall just
  // before the junction can be nearer a narrower daughter's axis, and outside that daughter.
  int best = 0;
  double deepest = axis_distance(0, x) - radius_[0];
  for (int b = 1; b < 3; ++b)
    if (const double d = axis_distance(b, x) - radius_[b]; d < deepest) best = b, deepest = d;
  return best;
}

std::vector<VesselWall::Branch> BifurcationWall::branches() const {
  return {{start_[0], end_[0], radius_[0]}, {start_[1], end_[1], radius_[1]}, {start_[2], end_[2], radius_[2]}};
}

double BifurcationWall::signed_distance(const Point& x) const { return bifurcation_function(spec_, x); }

Point BifurcationWall::outward_normal(const Point& x) const {
  const double h = 1e-3 * std::min({radius_[0], radius_[1], radius_[2]});
  Point g;
  for (int d = 0; d < 3; ++d) {
    Point a = x, b = x;
    a[d] += h;
    b[d] -= h;
    g[d] = signed_distance(a) - signed_distance(b);
  }
  return g.normalized();
}

VesselWall::Section BifurcationWall::section_at(const Point& x) const {
  const int b = branch_at(x);
  return {radius_[b], axis_distance(b, x), speed_scale_[b]};
}

std::vector<VesselWall::Opening> BifurcationWall::outlets() const {
  return {{end_[1], daughter_direction(spec_, 0), radius_[1]}, {end_[2], daughter_direction(spec_, 1), radius_[2]}};
}

std::vector<WallTriangle> BifurcationWall::dem_wall() const { return wall_facing_in(make_bifurcation(spec_)); }

double bifurcation_function(const BifurcationSpec& spec, const Point& x) {
  const BifurcationSpec s = resolved(spec);
  const Point junction(0, 0, s.parent_length);
  double f = std::max(Capsule{Point::Zero(), junction, s.parent_diameter / 2}.value(x), -x.z());
  for (int i = 0; i < 2; ++i) {
    const Point d = daughter_direction(s, i);
    const Point end = junction + s.daughter_length * d;
    f = std::min(f, std::max(Capsule{junction, end, s.daughter_diameter[i] / 2}.value(x), (x - end).dot(d)));
  }
  return f;
}

Surface make_bifurcation(const BifurcationSpec& spec) {
  check_bifurcation(spec);
  const BifurcationSpec s = resolved(spec);
  const double h = s.step;
  // The tubes run on 3 steps beyond their ends, which cut_and_cap then cuts off flat: the grid
  // never samples a cap's sharp rim, which marching tetrahedra would bevel by about a step.
  const double run_on = 3 * h;
  const Point junction(0, 0, s.parent_length);
  std::vector<Capsule> tubes = {{Point(0, 0, -run_on), junction, s.parent_diameter / 2}};
  Surface out;
  out.region_names = {surface_region::wall, surface_region::inlet, surface_region::outlet(1),
                      surface_region::outlet(2)};
  std::vector<Cap> caps = {{Point::Zero(), Point(0, 0, -1), s.parent_diameter / 2, 1}};
  for (int i = 0; i < 2; ++i) {
    const Point d = daughter_direction(s, i);
    const Point end = junction + s.daughter_length * d;
    tubes.push_back({junction, end + run_on * d, s.daughter_diameter[i] / 2});
    caps.push_back({end, d, s.daughter_diameter[i] / 2, 2 + i});
  }
  auto F = [&](const Point& x) {
    double f = std::numeric_limits<double>::infinity();
    for (const Capsule& t : tubes) f = std::min(f, t.value(x));
    return f;
  };

  // The grid: the tubes' boxes with a margin, its origin off any round coordinate.
  Point lo = Point::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Capsule& t : tubes) {
    lo = lo.cwiseMin(t.a.cwiseMin(t.b) - Point::Constant(t.r));
    hi = hi.cwiseMax(t.a.cwiseMax(t.b) + Point::Constant(t.r));
  }
  lo -= Point::Constant(1.6137 * h);
  const int nx = static_cast<int>(std::ceil((hi.x() - lo.x()) / h)) + 3;
  const int ny = static_cast<int>(std::ceil((hi.y() - lo.y()) / h)) + 3;
  const int nz = static_cast<int>(std::ceil((hi.z() - lo.z()) / h)) + 3;
  auto id = [&](int i, int j, int k) {
    return static_cast<std::int64_t>(i) + nx * (static_cast<std::int64_t>(j) + static_cast<std::int64_t>(ny) * k);
  };
  auto at = [&](std::int64_t n) {
    const auto i = n % nx, j = (n / nx) % ny, k = n / (static_cast<std::int64_t>(nx) * ny);
    return Point(lo.x() + static_cast<double>(i) * h, lo.y() + static_cast<double>(j) * h,
                 lo.z() + static_cast<double>(k) * h);
  };
  std::vector<double> f(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz));
  for (std::size_t n = 0; n < f.size(); ++n) {
    f[n] = F(at(static_cast<std::int64_t>(n)));
    if (f[n] == 0) f[n] = std::numeric_limits<double>::min();  // a zero sample counts as outside
  }

  // One crossing point per grid edge, shared by every triangle through it.
  std::unordered_map<std::uint64_t, int> crossing;
  auto point_on = [&](std::int64_t a, std::int64_t b) {
    if (a > b) std::swap(a, b);
    const std::uint64_t key =
        static_cast<std::uint64_t>(a) * static_cast<std::uint64_t>(f.size()) + static_cast<std::uint64_t>(b);
    if (const auto it = crossing.find(key); it != crossing.end()) return it->second;
    const double fa = f[static_cast<std::size_t>(a)], fb = f[static_cast<std::size_t>(b)];
    // Kept off the edge's ends, so that no two crossing points start at one grid point; the
    // projection below puts them on the surface.
    const double t = std::clamp(fa / (fa - fb), 0.02, 0.98);
    out.points.push_back(at(a) + t * (at(b) - at(a)));
    crossing.emplace(key, static_cast<int>(out.points.size()) - 1);
    return static_cast<int>(out.points.size()) - 1;
  };
  auto emit = [&](int p, int q, int r, const Point& towards_outside) {
    const Point n = (out.points[static_cast<std::size_t>(q)] - out.points[static_cast<std::size_t>(p)])
                        .cross(out.points[static_cast<std::size_t>(r)] - out.points[static_cast<std::size_t>(p)]);
    if (n.dot(towards_outside) >= 0)
      out.triangles.push_back({p, q, r});
    else
      out.triangles.push_back({p, r, q});
  };
  // The six tetrahedra of a cube around its diagonal from corner 0 to corner 7 (corner bits: x 1,
  // y 2, z 4): one per order in which the path 0 -> 7 steps along the axes.
  static constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                                      {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        std::int64_t corner[8];
        for (int c = 0; c < 8; ++c) corner[c] = id(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
        for (const auto& tet : kTets) {
          std::int64_t in[4], outside[4];
          int n_in = 0, n_out = 0;
          for (int v : tet) {
            const std::int64_t g = corner[v];
            if (f[static_cast<std::size_t>(g)] < 0)
              in[n_in++] = g;
            else
              outside[n_out++] = g;
          }
          if (n_in == 0 || n_out == 0) continue;
          Point towards = Point::Zero();
          for (int q = 0; q < n_out; ++q) towards += at(outside[q]) / n_out;
          for (int q = 0; q < n_in; ++q) towards -= at(in[q]) / n_in;
          if (n_in == 1)
            emit(point_on(in[0], outside[0]), point_on(in[0], outside[1]), point_on(in[0], outside[2]), towards);
          else if (n_out == 1)
            emit(point_on(in[0], outside[0]), point_on(in[1], outside[0]), point_on(in[2], outside[0]), towards);
          else {  // two in, two out: the quad of the four crossings, in their cyclic order
            const int ac = point_on(in[0], outside[0]), ad = point_on(in[0], outside[1]),
                      bd = point_on(in[1], outside[1]), bc = point_on(in[1], outside[0]);
            emit(ac, ad, bd, towards);
            emit(ac, bd, bc, towards);
          }
        }
      }

  // Onto the exact zero level: Newton steps along the central-difference gradient.
  const double delta = 1e-4 * h;
  for (Point& p : out.points) {
    for (int it = 0; it < 30; ++it) {
      const double v = F(p);
      if (std::abs(v) < 1e-12 * h) break;
      Point g;
      for (int c = 0; c < 3; ++c) {
        Point e = Point::Zero();
        e[c] = delta;
        g[c] = (F(p + e) - F(p - e)) / (2 * delta);
      }
      const double g2 = g.squaredNorm();
      if (!(g2 > 0)) break;
      p -= v * g / g2;
    }
  }
  out.region.assign(out.triangles.size(), 0);
  for (const Cap& cap : caps) cut_and_cap(out, cap, 2 * h);
  // Points the cuts left unused (beyond the caps) are dropped, the others renumbered.
  std::vector<int> renumber(out.points.size(), -1);
  std::vector<Point> used;
  for (auto& t : out.triangles)
    for (int& v : t) {
      auto& r = renumber[static_cast<std::size_t>(v)];
      if (r < 0) {
        r = static_cast<int>(used.size());
        used.push_back(out.points[static_cast<std::size_t>(v)]);
      }
      v = r;
    }
  out.points = std::move(used);
  check_surface(out);
  return out;
}

}  // namespace hemo
