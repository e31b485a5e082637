// The O-grid vessel mesh (see vessel_mesh.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "vessel_mesh.h"

#include <geometry.h>
#include <vessel_ends.h>
#include <hemo/mesh_t.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

namespace hemo {
namespace {

constexpr double kPi = 3.14159265358979323846;

using Vec2 = std::array<double, 2>;

Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 operator-(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 operator*(double s, const Vec3& a) { return {s * a[0], s * a[1], s * a[2]}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

// The cross-section: nodes in the xy plane and quads listed counter-clockwise seen from +z.
struct Section {
  std::vector<Vec2> nodes;
  std::vector<std::array<int, 4>> quads;
};

// Point of the core's boundary on the ray at angle `theta`: the square of half-width s blended
// toward the circle through its corners.
Vec2 core_edge_point(double theta, double s, double rounding) {
  const double c = std::cos(theta), sn = std::sin(theta);
  const double r_square = s / std::max(std::abs(c), std::abs(sn));
  const double r = (1 - rounding) * r_square + rounding * s * std::sqrt(2.0);
  return {r * c, r * sn};
}

// `radius` sizes the core; the wall's nodes sit at `wall_radius` (MeshSpec::wall_polygon).
Section make_section(double radius, double wall_radius, int nc, int nr, const OGridShape& shape) {
  Section sec;
  const double s = shape.core_half_width * radius;
  const double w = shape.core_rounding;
  const double deg = kPi / 180;
  auto edge = [&](double theta_deg) { return core_edge_point(theta_deg * deg, s, w); };

  // Core nodes (i, j), i along x, j along y, by transfinite interpolation of its four edges,
  // whose nodes sit at equal angles so that the ring's radial lines continue them.
  auto core_id = [&](int i, int j) { return i + j * (nc + 1); };
  sec.nodes.resize(static_cast<std::size_t>((nc + 1) * (nc + 1)));
  const Vec2 p00 = edge(225), p10 = edge(315), p01 = edge(135), p11 = edge(45);
  for (int j = 0; j <= nc; ++j) {
    for (int i = 0; i <= nc; ++i) {
      const double xi = double(i) / nc, eta = double(j) / nc;
      const Vec2 b = edge(225 + 90 * xi), t = edge(135 - 90 * xi);
      const Vec2 l = edge(225 - 90 * eta), r = edge(-45 + 90 * eta);
      Vec2 p;
      for (int d = 0; d < 2; ++d) {
        p[d] = (1 - eta) * b[d] + eta * t[d] + (1 - xi) * l[d] + xi * r[d] -
               ((1 - xi) * (1 - eta) * p00[d] + xi * (1 - eta) * p10[d] + (1 - xi) * eta * p01[d] + xi * eta * p11[d]);
      }
      sec.nodes[static_cast<std::size_t>(core_id(i, j))] = p;
    }
  }
  // Core boundary node of side k (0 east, 1 north, 2 west, 3 south) at position m, counted
  // counter-clockwise around the axis.
  auto side_id = [&](int k, int m) {
    switch (k) {
      case 0:
        return core_id(nc, m);
      case 1:
        return core_id(nc - m, nc);
      case 2:
        return core_id(0, nc - m);
      default:
        return core_id(m, 0);
    }
  };
  // Ring nodes: side k, position m (0..nc, m = nc is the next side's m = 0), layer l (0 core edge,
  // nr wall), on the radial line through the core edge node.
  const int ring_base = static_cast<int>(sec.nodes.size());
  auto ring_id = [&](int k, int m, int l) {
    if (m == nc) {
      k = (k + 1) % 4;
      m = 0;
    }
    if (l == 0) return side_id(k, m);
    return ring_base + (k * nc + m) * nr + (l - 1);
  };
  sec.nodes.resize(static_cast<std::size_t>(ring_base + 4 * nc * nr));
  for (int k = 0; k < 4; ++k) {
    for (int m = 0; m < nc; ++m) {
      const double theta = (-45 + 90 * k + 90.0 * m / nc) * deg;
      const Vec2 inner = sec.nodes[static_cast<std::size_t>(side_id(k, m))];
      const Vec2 outer{wall_radius * std::cos(theta), wall_radius * std::sin(theta)};
      for (int l = 1; l <= nr; ++l) {
        const double f = double(l) / nr;
        Vec2 p{inner[0] + f * (outer[0] - inner[0]), inner[1] + f * (outer[1] - inner[1])};
        if (l == nr) p = outer;
        sec.nodes[static_cast<std::size_t>(ring_id(k, m, l))] = p;
      }
    }
  }
  // Quads: the core (i along x, j along y), then the ring blocks (radius, then angle: a
  // right-handed pair like x, y), all counter-clockwise.
  for (int j = 0; j < nc; ++j)
    for (int i = 0; i < nc; ++i)
      sec.quads.push_back({core_id(i, j), core_id(i + 1, j), core_id(i + 1, j + 1), core_id(i, j + 1)});
  for (int k = 0; k < 4; ++k)
    for (int m = 0; m < nc; ++m)
      for (int l = 0; l < nr; ++l)
        sec.quads.push_back({ring_id(k, m, l), ring_id(k, m, l + 1), ring_id(k, m + 1, l + 1), ring_id(k, m + 1, l)});
  return sec;
}

// FNV-1a, 64 bit.
struct Fnv1a {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= c[i];
      h *= 1099511628211ull;
    }
  }
  template <class T>
  void value(const T& v) {
    bytes(&v, sizeof v);
  }
  void text(const std::string& s) {
    value(static_cast<std::uint64_t>(s.size()));
    bytes(s.data(), s.size());
  }
};

std::string foam_header(const char* cls, const char* object, const std::string& note = {}) {
  std::string h =
      "/*--------------------------------*- C++ -*----------------------------------*\\\n"
      "  hemocosim vessel mesh (generated; do not edit)\n"
      "\\*---------------------------------------------------------------------------*/\n"
      "FoamFile\n{\n    version     2.0;\n    format      ascii;\n    class       ";
  h += cls;
  h += ";\n";
  if (!note.empty()) h += "    note        \"" + note + "\";\n";
  h += "    location    \"constant/polyMesh\";\n    object      ";
  h += object;
  h += ";\n}\n\n";
  return h;
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::string fmt_double(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

const PatchInfo& PolyMesh::patch(const std::string& name) const {
  for (const auto& p : patches)
    if (p.name == name) return p;
  throw std::out_of_range("mesh has no patch " + name);
}

namespace {

void check_mesh_request(const Vessel& vessel, const MeshSpec& spec, const OGridShape& shape) {
  if (!(vessel.diameter > 0) || !(vessel.length > 0))
    throw std::invalid_argument("vessel diameter and length must be positive");
  if (spec.core_cells < 1 || spec.ring_cells < 1 || spec.axial_cells < 1)
    throw std::invalid_argument("mesh core_cells, ring_cells and axial_cells must be at least 1");
  if (!(shape.core_half_width > 0 && shape.core_half_width < 1 / std::sqrt(2.0)) ||
      !(shape.core_rounding >= 0 && shape.core_rounding <= 1))
    throw std::invalid_argument("O-grid core half-width must be in (0, 1/sqrt 2) R, rounding in [0, 1]");
}

// The section's nodes repeated on nz + 1 layers along the vessel, each layer's scaled by the
// local radius over the nominal one, R(z) / R0 (exactly 1 on a straight tube: the same points to
// the bit); point (node, layer) is layer * nodes + node.
void extrude_points(const Section& sec, const VesselGeometry& geometry, int nz, PolyMesh& mesh) {
  const double length = geometry.length();
  mesh.points.reserve(sec.nodes.size() * static_cast<std::size_t>(nz + 1));
  for (int k = 0; k <= nz; ++k) {
    const double z = (k == nz) ? length : length * k / nz;
    const double scale = geometry.radius_at(z) / geometry.nominal_radius();
    for (const auto& n : sec.nodes) mesh.points.push_back({scale * n[0], scale * n[1], z});
  }
}

// An edge (a, b) of the section in the counter-clockwise order of the quad it is taken from.
using QuadEdge = std::pair<int, std::pair<int, int>>;  // (quad, (a, b))

// How the section's quads meet: per quad, the higher-numbered quads across an edge (with the
// edge in this quad's order); and the wall edges, sorted.
struct SectionEdges {
  std::vector<std::vector<QuadEdge>> upper;
  std::vector<QuadEdge> wall;
};

SectionEdges section_edges(const Section& sec) {
  const int nq = static_cast<int>(sec.quads.size());
  struct EdgeUse {
    int quad, a, b;
  };
  std::map<std::pair<int, int>, std::vector<EdgeUse>> edges;
  for (int q = 0; q < nq; ++q) {
    for (int e = 0; e < 4; ++e) {
      const int a = sec.quads[q][e], b = sec.quads[q][(e + 1) % 4];
      edges[{std::min(a, b), std::max(a, b)}].push_back({q, a, b});
    }
  }
  SectionEdges out;
  out.upper.resize(static_cast<std::size_t>(nq));
  for (const auto& [key, uses] : edges) {
    if (uses.size() == 1) {
      out.wall.push_back({uses[0].quad, {uses[0].a, uses[0].b}});
    } else if (uses.size() == 2) {
      const EdgeUse& lo = uses[0].quad < uses[1].quad ? uses[0] : uses[1];
      const EdgeUse& hi = uses[0].quad < uses[1].quad ? uses[1] : uses[0];
      out.upper[static_cast<std::size_t>(lo.quad)].push_back({hi.quad, {lo.a, lo.b}});
    } else {
      throw std::logic_error("O-grid edge shared by more than two cells");
    }
  }
  std::sort(out.wall.begin(), out.wall.end());
  return out;
}

// Point and cell numbering of the extruded section.
struct Layers {
  int nodes, quads;
  int point(int node, int layer) const { return layer * nodes + node; }
  int cell(int q, int layer) const { return layer * quads + q; }
};

// Internal faces, upper-triangular: cell by cell, neighbours in increasing order.
void add_internal_faces(const Section& sec, const SectionEdges& edges, const Layers& at, int nz, PolyMesh& mesh) {
  auto P = [&](int node, int layer) { return at.point(node, layer); };
  for (int k = 0; k < nz; ++k) {
    for (int q = 0; q < at.quads; ++q) {
      std::vector<std::pair<int, std::vector<int>>> faces;  // (neighbour, points)
      for (const auto& [q2, ab] : edges.upper[static_cast<std::size_t>(q)]) {
        const auto [a, b] = ab;
        faces.push_back({at.cell(q2, k), {P(a, k), P(b, k), P(b, k + 1), P(a, k + 1)}});
      }
      if (k + 1 < nz) {
        const auto& n = sec.quads[static_cast<std::size_t>(q)];
        faces.push_back({at.cell(q, k + 1), {P(n[0], k + 1), P(n[1], k + 1), P(n[2], k + 1), P(n[3], k + 1)}});
      }
      std::sort(faces.begin(), faces.end());
      for (auto& [nb, pts] : faces) {
        mesh.faces.push_back(std::move(pts));
        mesh.owner.push_back(at.cell(q, k));
        mesh.neighbour.push_back(nb);
      }
    }
  }
}

// Boundary: the wall, then the cyclic pair. Face i of inlet (z = 0) and face i of outlet
// (z = length) are the same quad: same first point, opposite orientation.
void add_boundary_faces(const Section& sec, const SectionEdges& edges, const Layers& at, int nz, double length,
                        PolyMesh& mesh) {
  auto P = [&](int node, int layer) { return at.point(node, layer); };
  const int nq = at.quads;
  const double L = length;
  PatchInfo wall{patch_name::wall, "wall", mesh.n_faces(), 0, {}, {0, 0, 0}};
  for (int k = 0; k < nz; ++k) {
    for (const auto& [q, ab] : edges.wall) {
      const auto [a, b] = ab;
      mesh.faces.push_back({P(a, k), P(b, k), P(b, k + 1), P(a, k + 1)});
      mesh.owner.push_back(at.cell(q, k));
    }
  }
  wall.size = mesh.n_faces() - wall.start;
  PatchInfo inlet{patch_name::inlet, "cyclic", mesh.n_faces(), nq, patch_name::outlet, {0, 0, L}};
  for (int q = 0; q < nq; ++q) {
    const auto& n = sec.quads[static_cast<std::size_t>(q)];
    mesh.faces.push_back({P(n[0], 0), P(n[3], 0), P(n[2], 0), P(n[1], 0)});
    mesh.owner.push_back(at.cell(q, 0));
  }
  PatchInfo outlet{patch_name::outlet, "cyclic", mesh.n_faces(), nq, patch_name::inlet, {0, 0, -L}};
  for (int q = 0; q < nq; ++q) {
    const auto& n = sec.quads[static_cast<std::size_t>(q)];
    mesh.faces.push_back({P(n[0], nz), P(n[1], nz), P(n[2], nz), P(n[3], nz)});
    mesh.owner.push_back(at.cell(q, nz - 1));
  }
  mesh.patches = {wall, inlet, outlet};
}

// One periodic vessel region: the section of radius `vessel`'s R0 extruded over nz layers along
// its shape, its ends a cyclic pair.
PolyMesh vessel_region(const Vessel& vessel, const MeshSpec& spec, const OGridShape& shape, int nz) {
  const Section sec = make_section(vessel.radius(), vessel.radius() * spec.wall_corner_radius(), spec.core_cells,
                                   spec.ring_cells, shape);
  const Layers at{static_cast<int>(sec.nodes.size()), static_cast<int>(sec.quads.size())};
  PolyMesh mesh;
  mesh.n_cells = at.quads * nz;
  extrude_points(sec, *make_vessel_geometry(vessel), nz, mesh);
  const SectionEdges edges = section_edges(sec);
  add_internal_faces(sec, edges, at, nz, mesh);
  add_boundary_faces(sec, edges, at, nz, vessel.length, mesh);
  return mesh;
}

// `b` appended to `a` as a disconnected region, moved by `shift`: a's internal faces, b's, a's
// boundary faces, b's (OpenFOAM's order: internal faces upper-triangular, then patch by patch);
// b's patches named by `rename`, its cells the zone `zone`.
PolyMesh append_region(const PolyMesh& a, const PolyMesh& b, const Vec3& shift,
                       const std::map<std::string, std::string>& rename, const std::string& zone) {
  PolyMesh m;
  const int pa = static_cast<int>(a.points.size()), ca = a.n_cells;
  const int ai = a.n_internal_faces(), bi = b.n_internal_faces();
  m.points = a.points;
  for (const auto& p : b.points) m.points.push_back(p + shift);
  auto add_faces = [&](const PolyMesh& from, int begin, int end, int point_offset, int cell_offset) {
    for (int f = begin; f < end; ++f) {
      std::vector<int> face = from.faces[static_cast<std::size_t>(f)];
      for (int& p : face) p += point_offset;
      m.faces.push_back(std::move(face));
      m.owner.push_back(from.owner[static_cast<std::size_t>(f)] + cell_offset);
      if (f < from.n_internal_faces()) m.neighbour.push_back(from.neighbour[static_cast<std::size_t>(f)] + cell_offset);
    }
  };
  add_faces(a, 0, ai, 0, 0);
  add_faces(b, 0, bi, pa, ca);
  add_faces(a, ai, a.n_faces(), 0, 0);
  add_faces(b, bi, b.n_faces(), pa, ca);
  for (PatchInfo p : a.patches) {
    p.start += bi;
    m.patches.push_back(p);
  }
  for (PatchInfo p : b.patches) {
    p.start += a.n_faces();
    p.name = rename.at(p.name);
    if (!p.neighbour.empty()) p.neighbour = rename.at(p.neighbour);
    m.patches.push_back(p);
  }
  m.cell_zones = a.cell_zones;
  m.cell_zones.push_back({zone, ca, b.n_cells});
  m.n_cells = ca + b.n_cells;
  return m;
}

// An open vessel's ends: the inlet takes what vessel.inlet says, the outlet is a plain patch.
void open_the_ends(const Vessel& vessel, const MeshSpec& spec, const OGridShape& shape, PolyMesh& mesh) {
  for (PatchInfo& p : mesh.patches) {
    if (p.type != "cyclic") continue;
    p.type = "patch";
    p.neighbour.clear();
    p.separation = {0, 0, 0};
  }
  if (!fed_by_feeder(vessel)) return;
  append_feeder(mesh, feeder_layout(vessel, spec.axial_cells), spec, shape);
}

}  // namespace

void append_feeder(PolyMesh& mesh, const FeederLayout& layout, const MeshSpec& spec, const OGridShape& shape,
                   FeederSampling sampling) {
  if (!(layout.radius > 0) || !(layout.period > 0) || layout.layers < 1)
    throw std::invalid_argument("the feeder needs a positive radius and length and at least one layer");
  const auto inlet = std::find_if(mesh.patches.begin(), mesh.patches.end(),
                                  [](const PatchInfo& p) { return p.name == patch_name::inlet; });
  if (inlet == mesh.patches.end()) throw std::invalid_argument("the mesh has no inlet patch to feed");
  const Vessel feeder{2 * layout.radius, layout.period};
  const PolyMesh region = vessel_region(feeder, spec, shape, layout.layers);
  const Vec3 shift{layout.axis_x, layout.inlet_y, layout.inlet_z};
  mesh = append_region(mesh, region, shift,
                       {{patch_name::wall, patch_name::feeder_wall},
                        {patch_name::inlet, patch_name::feeder_inlet},
                        {patch_name::outlet, patch_name::feeder_outlet}},
                       feeder_zone);
  for (PatchInfo& p : mesh.patches)
    if (p.name == patch_name::inlet) {
      p.type = "mappedPatch";
      if (sampling == FeederSampling::cell_above_face) {
        p.sample_offset = {layout.axis_x - layout.inlet_x, 0, feeder.length * (1 - 0.5 / layout.layers)};
      } else {
        p.sample_patch = patch_name::feeder_inlet;
        p.sample_offset = {layout.inlet_x - layout.axis_x, 0, 0};
      }
    }
}

PolyMesh make_vessel_mesh(const Vessel& vessel, const MeshSpec& spec, const OGridShape& shape) {
  check_mesh_request(vessel, spec, shape);
  PolyMesh mesh = vessel_region(vessel, spec, shape, spec.axial_cells);
  if (open_ends(vessel)) open_the_ends(vessel, spec, shape, mesh);
  return mesh;
}

MeshGeometry compute_geometry(const PolyMesh& mesh) {
  MeshGeometry g;
  const std::size_t nf = mesh.faces.size();
  g.face_centres.resize(nf);
  g.face_areas.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& face = mesh.faces[f];
    const std::size_t np = face.size();
    Vec3 avg{0, 0, 0};
    for (int p : face) avg = avg + mesh.points[static_cast<std::size_t>(p)];
    avg = (1.0 / double(np)) * avg;
    Vec3 sum_n{0, 0, 0}, sum_ac{0, 0, 0};
    double sum_a = 0;
    for (std::size_t i = 0; i < np; ++i) {
      const Vec3& a = mesh.points[static_cast<std::size_t>(face[i])];
      const Vec3& b = mesh.points[static_cast<std::size_t>(face[(i + 1) % np])];
      const Vec3 c = a + b + avg;
      const Vec3 n = cross(b - a, avg - a);
      const double area = norm(n);
      sum_n = sum_n + n;
      sum_a += area;
      sum_ac = sum_ac + area * c;
    }
    g.face_centres[f] = sum_a > 1e-300 ? (1.0 / (3.0 * sum_a)) * sum_ac : avg;
    g.face_areas[f] = 0.5 * sum_n;
  }
  const std::size_t nc = static_cast<std::size_t>(mesh.n_cells);
  std::vector<Vec3> estimate(nc, Vec3{0, 0, 0});
  std::vector<int> count(nc, 0);
  const std::size_t ni = mesh.neighbour.size();
  for (std::size_t f = 0; f < nf; ++f) {
    const auto o = static_cast<std::size_t>(mesh.owner[f]);
    estimate[o] = estimate[o] + g.face_centres[f];
    ++count[o];
    if (f < ni) {
      const auto n = static_cast<std::size_t>(mesh.neighbour[f]);
      estimate[n] = estimate[n] + g.face_centres[f];
      ++count[n];
    }
  }
  for (std::size_t c = 0; c < nc; ++c) estimate[c] = (1.0 / std::max(count[c], 1)) * estimate[c];
  g.cell_centres.assign(nc, Vec3{0, 0, 0});
  g.cell_volumes.assign(nc, 0.0);
  auto add_pyramid = [&](std::size_t c, std::size_t f, double sign) {
    const double v3 = sign * dot(g.face_areas[f], g.face_centres[f] - estimate[c]);
    const Vec3 pc = 0.75 * g.face_centres[f] + 0.25 * estimate[c];
    g.cell_centres[c] = g.cell_centres[c] + v3 * pc;
    g.cell_volumes[c] += v3;
  };
  for (std::size_t f = 0; f < nf; ++f) {
    add_pyramid(static_cast<std::size_t>(mesh.owner[f]), f, 1.0);
    if (f < ni) add_pyramid(static_cast<std::size_t>(mesh.neighbour[f]), f, -1.0);
  }
  for (std::size_t c = 0; c < nc; ++c) {
    if (std::abs(g.cell_volumes[c]) > 1e-300)
      g.cell_centres[c] = (1.0 / g.cell_volumes[c]) * g.cell_centres[c];
    else
      g.cell_centres[c] = estimate[c];
    g.cell_volumes[c] /= 3.0;
  }
  return g;
}

double min_edge_length(const PolyMesh& mesh) {
  double m = std::numeric_limits<double>::infinity();
  for (const auto& face : mesh.faces)
    for (std::size_t i = 0; i < face.size(); ++i)
      m = std::min(m, norm(mesh.points[static_cast<std::size_t>(face[(i + 1) % face.size()])] -
                           mesh.points[static_cast<std::size_t>(face[i])]));
  return m;
}

std::string mesh_hash(const PolyMesh& mesh) {
  Fnv1a h;
  h.value(static_cast<std::int64_t>(mesh.n_cells));
  h.value(static_cast<std::int64_t>(mesh.points.size()));
  for (const auto& p : mesh.points) h.bytes(p.data(), sizeof(double) * 3);
  h.value(static_cast<std::int64_t>(mesh.faces.size()));
  for (const auto& f : mesh.faces) {
    h.value(static_cast<std::int32_t>(f.size()));
    for (int p : f) h.value(static_cast<std::int32_t>(p));
  }
  for (int o : mesh.owner) h.value(static_cast<std::int32_t>(o));
  for (int n : mesh.neighbour) h.value(static_cast<std::int32_t>(n));
  for (const auto& p : mesh.patches) {
    h.text(p.name);
    h.text(p.type);
    h.value(static_cast<std::int32_t>(p.start));
    h.value(static_cast<std::int32_t>(p.size));
    if (p.type == "mappedPatch") h.bytes(p.sample_offset.data(), sizeof(double) * 3);
    if (!p.sample_patch.empty()) h.text(p.sample_patch);  // (none in an O-grid: its hash as it was)
  }
  // (Only a mesh with zones hashes them: a periodic vessel's hash is what it always was.)
  for (const auto& z : mesh.cell_zones) {
    h.text(z.name);
    h.value(static_cast<std::int32_t>(z.first));
    h.value(static_cast<std::int32_t>(z.size));
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h.h));
  return buf;
}

void write_polymesh(const PolyMesh& mesh, const std::string& case_dir) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(case_dir) / "constant" / "polyMesh";
  fs::create_directories(dir);
  const std::string note =
      "nPoints:" + std::to_string(mesh.points.size()) + "  nCells:" + std::to_string(mesh.n_cells) +
      "  nFaces:" + std::to_string(mesh.faces.size()) + "  nInternalFaces:" + std::to_string(mesh.neighbour.size());
  {
    std::string s = foam_header("vectorField", "points");
    s += std::to_string(mesh.points.size()) + "\n(\n";
    for (const auto& p : mesh.points)
      s += "(" + fmt_double(p[0]) + " " + fmt_double(p[1]) + " " + fmt_double(p[2]) + ")\n";
    s += ")\n";
    write_file(dir / "points", s);
  }
  {
    std::string s = foam_header("faceList", "faces");
    s += std::to_string(mesh.faces.size()) + "\n(\n";
    for (const auto& f : mesh.faces) {
      s += std::to_string(f.size()) + "(";
      for (std::size_t i = 0; i < f.size(); ++i) s += (i ? " " : "") + std::to_string(f[i]);
      s += ")\n";
    }
    s += ")\n";
    write_file(dir / "faces", s);
  }
  auto label_list = [&](const char* object, const std::vector<int>& v) {
    std::string s = foam_header("labelList", object, note);
    s += std::to_string(v.size()) + "\n(\n";
    for (int x : v) s += std::to_string(x) + "\n";
    s += ")\n";
    write_file(dir / object, s);
  };
  label_list("owner", mesh.owner);
  label_list("neighbour", mesh.neighbour);
  {
    std::string s = foam_header("polyBoundaryMesh", "boundary");
    s += std::to_string(mesh.patches.size()) + "\n(\n";
    for (const auto& p : mesh.patches) {
      s += "    " + p.name + "\n    {\n";
      s += "        type            " + p.type + ";\n";
      if (p.type == "wall") s += "        inGroups        1(wall);\n";
      if (p.type == "cyclic") s += "        inGroups        1(cyclic);\n";
      s += "        nFaces          " + std::to_string(p.size) + ";\n";
      s += "        startFace       " + std::to_string(p.start) + ";\n";
      if (p.type == "mappedPatch" && !p.sample_patch.empty()) {
        // The sample patch's faces face the way the inlet's do (both out of their regions along
        // -z): AMI wants them facing each other, hence flipNormals.
        s += "        sampleMode      nearestPatchFaceAMI;\n";
        s += "        samplePatch     " + p.sample_patch + ";\n";
        s += "        flipNormals     true;\n";
        s += "        offsetMode      uniform;\n";
        s += "        offset          (" + fmt_double(p.sample_offset[0]) + " " + fmt_double(p.sample_offset[1]) + " " +
             fmt_double(p.sample_offset[2]) + ");\n";
      } else if (p.type == "mappedPatch") {
        // nearestCell: the value of the cell holding face centre + offset (no interpolation).
        s += "        sampleMode      nearestCell;\n";
        s += "        offsetMode      uniform;\n";
        s += "        offset          (" + fmt_double(p.sample_offset[0]) + " " + fmt_double(p.sample_offset[1]) + " " +
             fmt_double(p.sample_offset[2]) + ");\n";
      }
      if (p.type == "cyclic") {
        s += "        matchTolerance  0.0001;\n";
        s += "        transform       translational;\n";
        s += "        neighbourPatch  " + p.neighbour + ";\n";
        s += "        separationVector (" + fmt_double(p.separation[0]) + " " + fmt_double(p.separation[1]) + " " +
             fmt_double(p.separation[2]) + ");\n";
      }
      s += "    }\n";
    }
    s += ")\n";
    write_file(dir / "boundary", s);
  }
  if (mesh.cell_zones.empty()) {
    fs::remove(dir / "cellZones");
    return;
  }
  std::string s = foam_header("regIOobject", "cellZones");
  s += std::to_string(mesh.cell_zones.size()) + "\n(\n";
  for (const auto& z : mesh.cell_zones) {
    s += z.name + "\n{\n    type            cellZone;\n    cellLabels      List<label> " + std::to_string(z.size) +
         "\n(\n";
    for (int c = z.first; c < z.first + z.size; ++c) s += std::to_string(c) + "\n";
    s += ")\n;\n}\n";
  }
  s += ")\n";
  write_file(dir / "cellZones", s);
}

void fill_mesh_message(const PolyMesh& mesh, const MeshGeometry& geometry, const Vessel& vessel, mesh_t& msg) {
  msg.mesh_hash = mesh_hash(mesh);
  msg.vessel_diameter_m = vessel.diameter;
  msg.vessel_length_m = vessel.length;
  msg.n_points = static_cast<int32_t>(mesh.points.size());
  msg.points.clear();
  for (const auto& p : mesh.points) msg.points.push_back({p[0], p[1], p[2]});
  msg.n_faces = mesh.n_faces();
  msg.face_offsets.clear();
  msg.face_points.clear();
  for (const auto& f : mesh.faces) {
    msg.face_offsets.push_back(static_cast<int32_t>(msg.face_points.size()));
    msg.face_points.insert(msg.face_points.end(), f.begin(), f.end());
  }
  msg.n_face_points = static_cast<int32_t>(msg.face_points.size());
  msg.owner.assign(mesh.owner.begin(), mesh.owner.end());
  msg.n_internal_faces = mesh.n_internal_faces();
  msg.neighbour.assign(mesh.neighbour.begin(), mesh.neighbour.end());
  msg.n_cells = mesh.n_cells;
  msg.cell_centres.clear();
  for (const auto& c : geometry.cell_centres) msg.cell_centres.push_back({c[0], c[1], c[2]});
  msg.cell_volumes = geometry.cell_volumes;
  msg.n_patches = static_cast<int32_t>(mesh.patches.size());
  msg.patch_names.clear();
  msg.patch_types.clear();
  msg.patch_start.clear();
  msg.patch_size.clear();
  for (const auto& p : mesh.patches) {
    msg.patch_names.push_back(p.name);
    msg.patch_types.push_back(p.type);
    msg.patch_start.push_back(p.start);
    msg.patch_size.push_back(p.size);
  }
}

}  // namespace hemo
