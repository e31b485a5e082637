// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_locator.h"

#include <facet_distance.h>

#include <scene.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace hemo::particles {

namespace {

struct FaceGeometry {
  Vec3 centroid;
  Vec3 area;  // area vector, direction from the point ordering (right-hand rule)
};

FaceGeometry face_geometry(const std::vector<Vec3>& pts) {
  Vec3 mean = Vec3::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  if (pts.size() == 3) return {mean, 0.5 * (pts[1] - pts[0]).cross(pts[2] - pts[0])};
  // Fan of triangles around the mean point; centroid weighted by triangle areas.
  Vec3 area = Vec3::Zero();
  Vec3 weighted = Vec3::Zero();
  double total = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Vec3& a = pts[i];
    const Vec3& b = pts[(i + 1) % pts.size()];
    Vec3 tri = 0.5 * (a - mean).cross(b - mean);
    double mag = tri.norm();
    area += tri;
    weighted += mag * (a + b + mean) / 3.0;
    total += mag;
  }
  return {total > 0 ? Vec3(weighted / total) : mean, area};
}

[[noreturn]] void bad_mesh(const std::string& what) { throw std::invalid_argument("mesh_t is inconsistent: " + what); }

// The end of face f's run in face_points.
int face_end(const mesh_t& mesh, int f) { return f + 1 < mesh.n_faces ? mesh.face_offsets[f + 1] : mesh.n_face_points; }

void check_counts(const mesh_t& mesh) {
  if (mesh.n_points <= 0 || mesh.n_faces <= 0 || mesh.n_cells <= 0) bad_mesh("no points, faces or cells");
  if (static_cast<int>(mesh.points.size()) != mesh.n_points ||
      static_cast<int>(mesh.face_offsets.size()) != mesh.n_faces ||
      static_cast<int>(mesh.face_points.size()) != mesh.n_face_points ||
      static_cast<int>(mesh.owner.size()) != mesh.n_faces ||
      static_cast<int>(mesh.neighbour.size()) != mesh.n_internal_faces || mesh.n_internal_faces > mesh.n_faces ||
      static_cast<int>(mesh.cell_centres.size()) != mesh.n_cells ||
      static_cast<int>(mesh.cell_volumes.size()) != mesh.n_cells)
    bad_mesh("array sizes do not match their counts");
}

std::vector<Vec3> read_points(const mesh_t& mesh) {
  std::vector<Vec3> points(mesh.n_points);
  for (int i = 0; i < mesh.n_points; ++i) {
    if (mesh.points[i].size() != 3) bad_mesh("a point without 3 coordinates");
    points[i] = Vec3(mesh.points[i][0], mesh.points[i][1], mesh.points[i][2]);
  }
  return points;
}

// Wall faces: boundary faces of patches that are not cyclic (all boundary faces when the
// mesh names no patches).
std::vector<char> wall_faces(const mesh_t& mesh) {
  const int n_faces = mesh.n_faces, n_internal = mesh.n_internal_faces;
  std::vector<char> wall_face(n_faces, 0);
  if (mesh.n_patches > 0 && static_cast<int>(mesh.patch_types.size()) == mesh.n_patches &&
      static_cast<int>(mesh.patch_start.size()) == mesh.n_patches &&
      static_cast<int>(mesh.patch_size.size()) == mesh.n_patches) {
    for (int p = 0; p < mesh.n_patches; ++p) {
      if (mesh.patch_types[p] == "cyclic") continue;
      for (int f = mesh.patch_start[p]; f < mesh.patch_start[p] + mesh.patch_size[p]; ++f)
        if (f >= n_internal && f < n_faces) wall_face[f] = 1;
    }
  } else {
    for (int f = n_internal; f < n_faces; ++f) wall_face[f] = 1;
  }
  return wall_face;
}

// A wall face leaves a gap to the round vessel only when its corners lie on the vessel's
// wall, r = R(z) (a chord); other wall faces are taken as the vessel's true boundary. A feeder's
// corners are measured where they stand for in the vessel frame, so its chords are those on the
// feeder's circle.
std::vector<char> chords(const mesh_t& mesh, const std::vector<Vec3>& points, const std::vector<char>& wall_face,
                         const VesselGeometry& geometry, const std::optional<FeederLayout>& feeder) {
  std::vector<char> on_circle(mesh.n_faces, 0);
  for (int f = mesh.n_internal_faces; f < mesh.n_faces; ++f) {
    if (!wall_face[f]) continue;
    const int end = face_end(mesh, f);
    bool all = true;
    for (int k = mesh.face_offsets[f]; k < end && all; ++k) {
      const Vec3 p = feeder ? feeder->in_vessel_frame(points[mesh.face_points[k]]) : points[mesh.face_points[k]];
      const double radius = geometry.radius_at(p.z());
      all = radius > 0 && std::abs(std::hypot(p.x(), p.y()) - radius) <= 1e-6 * radius;
    }
    on_circle[f] = all;
  }
  return on_circle;
}

}  // namespace

// Every face's geometry, each cell's faces, and the bounding boxes of the cells and the mesh.
struct CellLocator::Faces {
  std::vector<FaceGeometry> geometry;
  std::vector<std::vector<int>> of_cell;
  std::vector<Vec3> cell_lo, cell_hi;
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::max());
  Vec3 hi = Vec3::Constant(std::numeric_limits<double>::lowest());
};

CellLocator::CellLocator(const mesh_t& mesh, std::shared_ptr<const VesselWall> wall, std::optional<FeederLayout> feeder)
    : feeder_(std::move(feeder)) {
  check_counts(mesh);
  const std::vector<Vec3> points = read_points(mesh);
  read_cells(mesh);
  Faces faces = read_faces(mesh, points);
  const std::vector<char> wall_face = wall_faces(mesh);
  radius_ = mesh.vessel_diameter_m / 2;
  if (wall == nullptr) {
    Vessel straight;
    straight.diameter = mesh.vessel_diameter_m;
    straight.length = mesh.vessel_length_m > 0 ? mesh.vessel_length_m : faces.hi.z() - faces.lo.z();
    // A mesh without a vessel (a unit test's box): no round wall, no gap.
    if (straight.diameter > 0 && straight.length > 0) wall = make_vessel_geometry(straight);
  }
  wall_ = std::move(wall);
  axisymmetric_ = dynamic_cast<const VesselGeometry*>(wall_.get());
  if (axisymmetric_ && axisymmetric_->nominal_radius() != radius_)
    bad_mesh("its vessel diameter differs from the vessel shape's");
  if (wall_ && !axisymmetric_) facets_outside_ = furthest_outside(*wall_, dem_wall());
  std::vector<char> wall_cell;
  const std::vector<char> on_wall =
      axisymmetric_ ? chords(mesh, points, wall_face, *axisymmetric_, feeder_) : std::vector<char>(mesh.n_faces, 0);
  const std::vector<Vec3> plane_point = build_planes(mesh, faces, wall_face, on_wall, wall_cell);
  set_period(mesh, faces.lo, faces.hi);
  reach_into_wall_gap(wall_cell, faces);
  build_bins(faces);
  find_periodic_partners(plane_point);
}

void CellLocator::read_cells(const mesh_t& mesh) {
  centre_.resize(mesh.n_cells);
  volume_.resize(mesh.n_cells);
  for (int c = 0; c < mesh.n_cells; ++c) {
    if (mesh.cell_centres[c].size() != 3) bad_mesh("a cell centre without 3 coordinates");
    centre_[c] = Vec3(mesh.cell_centres[c][0], mesh.cell_centres[c][1], mesh.cell_centres[c][2]);
    volume_[c] = mesh.cell_volumes[c];
    if (!(volume_[c] > 0)) bad_mesh("cell " + std::to_string(c) + " has no positive volume");
  }
}

CellLocator::Faces CellLocator::read_faces(const mesh_t& mesh, const std::vector<Vec3>& points) {
  const int n_faces = mesh.n_faces, n_cells = mesh.n_cells, n_internal = mesh.n_internal_faces;
  Faces faces;
  faces.geometry.resize(n_faces);
  faces.of_cell.resize(n_cells);
  faces.cell_lo.assign(n_cells, faces.lo);
  faces.cell_hi.assign(n_cells, faces.hi);
  std::vector<Vec3> pts;
  for (int f = 0; f < n_faces; ++f) {
    const int start = mesh.face_offsets[f];
    const int end = face_end(mesh, f);
    if (start < 0 || end > mesh.n_face_points || end - start < 3)
      bad_mesh("face " + std::to_string(f) + " has fewer than 3 points or bad offsets");
    pts.clear();
    for (int k = start; k < end; ++k) {
      const int p = mesh.face_points[k];
      if (p < 0 || p >= mesh.n_points) bad_mesh("face " + std::to_string(f) + " names a missing point");
      pts.push_back(points[p]);
    }
    faces.geometry[f] = face_geometry(pts);
    if (!(faces.geometry[f].area.norm() > 0)) bad_mesh("face " + std::to_string(f) + " has zero area");
    const int own = mesh.owner[f];
    const int nei = f < n_internal ? mesh.neighbour[f] : -1;
    if (own < 0 || own >= n_cells || (f < n_internal && (nei < 0 || nei >= n_cells)))
      bad_mesh("face " + std::to_string(f) + " names a missing cell");
    for (int c : {own, nei}) {
      if (c < 0) continue;
      faces.of_cell[c].push_back(f);
      for (const auto& p : pts) {
        faces.cell_lo[c] = faces.cell_lo[c].cwiseMin(p);
        faces.cell_hi[c] = faces.cell_hi[c].cwiseMax(p);
      }
    }
    for (const auto& p : pts) {
      faces.lo = faces.lo.cwiseMin(p);
      faces.hi = faces.hi.cwiseMax(p);
    }
  }
  return faces;
}

std::vector<Vec3> CellLocator::build_planes(const mesh_t& mesh, const Faces& faces, const std::vector<char>& wall_face,
                                            const std::vector<char>& on_circle, std::vector<char>& wall_cell) {
  const int n_cells = mesh.n_cells, n_internal = mesh.n_internal_faces;
  plane_start_.assign(n_cells + 1, 0);
  std::vector<Vec3> plane_point;  // a point on each plane (the face centroid)
  wall_cell.assign(n_cells, 0);
  tolerance_.resize(n_cells);
  for (int c = 0; c < n_cells; ++c) {
    if (faces.of_cell[c].size() < 4) bad_mesh("cell " + std::to_string(c) + " has fewer than 4 faces");
    const double h = std::cbrt(volume_[c]);
    tolerance_[c] = 1e-10 * h;
    for (int f : faces.of_cell[c]) {
      const FaceGeometry& face = faces.geometry[f];
      const Vec3 n = face.area.normalized();
      const double side = n.dot(centre_[c] - face.centroid);
      // Outward normal: away from the cell centre. If the centre lies (numerically) on the face
      // plane the cell is degenerate; fall back on OpenFOAM's orientation (out of the owner).
      double sign;
      if (std::abs(side) > 1e-12 * h)
        sign = side < 0 ? 1.0 : -1.0;
      else
        sign = mesh.owner[f] == c ? 1.0 : -1.0;
      Plane plane;
      plane.normal = sign * n;
      plane.offset = plane.normal.dot(face.centroid);
      plane.across = f < n_internal ? (mesh.owner[f] == c ? mesh.neighbour[f] : mesh.owner[f]) : -1;
      plane.wall = wall_face[f] != 0;
      plane.beyond = plane.across;
      plane.gap = 0;
      if (on_circle[f] && std::abs(plane.normal.z()) < 0.5) {  // a side wall of the vessel or the feeder
        // In the vessel frame: a feeder face moved by its axis, so that the feeder's reach
        // R |n_xy| + n_x axis_x less the face's offset is the vessel's R(0) |n_xy| less the moved
        // face's (the same to rounding: the feeder's side faces have n_z = 0). Elsewhere the frame
        // is the identity and the offset is plane.offset, computed alike.
        const double z_lo = in_vessel_frame(faces.cell_lo[c]).z(), z_hi = in_vessel_frame(faces.cell_hi[c]).z();
        const double offset = plane.normal.dot(in_vessel_frame(face.centroid));
        plane.gap = std::max(0.0, wall_reach(plane.normal, z_lo, z_hi) - offset);
      }
      // A surface vessel's wall is snapped onto the surface the DEM collides with, not chords of
      // a circle: every cell on it may leave a gap (locate_near_surface).
      if (plane.gap > 0 || (wall_ && !axisymmetric_ && plane.wall)) wall_cell[c] = 1;
      planes_.push_back(plane);
      plane_point.push_back(face.centroid);
    }
    plane_start_[c + 1] = static_cast<int>(planes_.size());
  }
  return plane_point;
}

double CellLocator::wall_reach(const Vec3& normal, double z_lo, double z_hi) const {
  // How far along `normal` the round wall reaches: R |n_xy| on a straight tube (the same
  // operations as before shapes); on a shape, the most of R(z) |n_xy| + n_z z at the cell's ends
  // and middle (the gap is a search margin: a little more than the true reach costs nothing).
  const double across = std::hypot(normal.x(), normal.y());
  if (axisymmetric_->uniform()) return radius_ * across;
  double reach = std::numeric_limits<double>::lowest();
  for (double z : {z_lo, (z_lo + z_hi) / 2, z_hi})
    reach = std::max(reach, axisymmetric_->radius_at(z) * across + normal.z() * z);
  return reach;
}

void CellLocator::set_period(const mesh_t& mesh, const Vec3& lo, const Vec3& hi) {
  z0_ = lo.z();
  if (feeder_) {
    // The feeder spans the period, the vessel only its own length within it.
    length_ = feeder_->period;
    if (!(length_ > 0) || std::abs((hi.z() - lo.z()) - length_) > 1e-6 * length_)
      bad_mesh("its z extent " + std::to_string(hi.z() - lo.z()) + " m differs from the feeder's period " +
               std::to_string(length_) + " m");
    // A surface vessel's mesh names the parent's length (the scene's), the layout its z extent.
    if (axisymmetric_ && std::abs(mesh.vessel_length_m - feeder_->vessel_length) > 1e-6 * length_)
      bad_mesh("its vessel_length_m " + std::to_string(mesh.vessel_length_m) +
               " m differs from the feeder layout's vessel length " + std::to_string(feeder_->vessel_length) + " m");
    return;
  }
  length_ = mesh.vessel_length_m > 0 ? mesh.vessel_length_m : hi.z() - lo.z();
  if (std::abs((hi.z() - lo.z()) - length_) > 1e-6 * length_)
    bad_mesh("its z extent " + std::to_string(hi.z() - lo.z()) + " m differs from vessel_length_m " +
             std::to_string(length_) + " m");
}

void CellLocator::reach_into_wall_gap(const std::vector<char>& wall_cell, Faces& faces) {
  // The wall gap: how far a point inside the vessel radius can lie behind a wall face; a surface
  // vessel's, half the largest wall cell's size, in every direction (its wall is not along z).
  for (const Plane& p : planes_) wall_gap_ = std::max(wall_gap_, p.gap);
  if (wall_ && !axisymmetric_) {
    for (int c = 0; c < n_cells(); ++c)
      if (wall_cell[c]) wall_gap_ = std::max(wall_gap_, 0.5 * std::cbrt(volume_[c]));
    for (int c = 0; c < n_cells(); ++c)
      if (wall_cell[c]) {
        faces.cell_lo[c] -= Vec3::Constant(wall_gap_);
        faces.cell_hi[c] += Vec3::Constant(wall_gap_);
      }
    faces.lo -= Vec3::Constant(wall_gap_);
    faces.hi += Vec3::Constant(wall_gap_);
    return;
  }
  // Wall cells reach out to the vessel radius for the gap search.
  for (int c = 0; c < n_cells(); ++c)
    if (wall_cell[c]) {
      faces.cell_lo[c].head<2>() -= Vec3::Constant(wall_gap_).head<2>();
      faces.cell_hi[c].head<2>() += Vec3::Constant(wall_gap_).head<2>();
    }
  faces.lo.head<2>() -= Vec3::Constant(wall_gap_).head<2>();
  faces.hi.head<2>() += Vec3::Constant(wall_gap_).head<2>();
}

void CellLocator::build_bins(const Faces& faces) {
  // Uniform bins over the mesh's bounding box, about one cell per bin; each bin lists every
  // cell whose bounding box touches it.
  const int n_cells = this->n_cells();
  const Vec3 extent = (faces.hi - faces.lo).cwiseMax(Vec3::Constant(1e-300));
  const double h = std::cbrt(extent.prod() / n_cells);
  for (int d = 0; d < 3; ++d) nbin_[d] = std::max(1, static_cast<int>(std::lround(extent[d] / h)));
  bin_lo_ = faces.lo;
  bin_size_ = Vec3(extent.x() / nbin_[0], extent.y() / nbin_[1], extent.z() / nbin_[2]);
  const int total_bins = nbin_[0] * nbin_[1] * nbin_[2];
  std::vector<std::vector<int>> lists(total_bins);
  auto index = [&](double v, int d) {
    int i = static_cast<int>(std::floor((v - bin_lo_[d]) / bin_size_[d]));
    return std::clamp(i, 0, nbin_[d] - 1);
  };
  for (int c = 0; c < n_cells; ++c) {
    int a[3], b[3];
    for (int d = 0; d < 3; ++d) {
      a[d] = index(faces.cell_lo[c][d] - tolerance_[c], d);
      b[d] = index(faces.cell_hi[c][d] + tolerance_[c], d);
    }
    for (int i = a[0]; i <= b[0]; ++i)
      for (int j = a[1]; j <= b[1]; ++j)
        for (int k = a[2]; k <= b[2]; ++k) lists[(k * nbin_[1] + j) * nbin_[0] + i].push_back(c);
  }
  bin_start_.assign(total_bins + 1, 0);
  for (int b = 0; b < total_bins; ++b) bin_start_[b + 1] = bin_start_[b] + static_cast<int>(lists[b].size());
  bin_cells_.reserve(bin_start_.back());
  for (auto& l : lists) bin_cells_.insert(bin_cells_.end(), l.begin(), l.end());
}

void CellLocator::find_periodic_partners(const std::vector<Vec3>& plane_point) {
  // The periodic partner beyond each cyclic face: the cell just across it, after wrapping.
  for (int c = 0; c < n_cells(); ++c)
    for (int k = plane_start_[c]; k < plane_start_[c + 1]; ++k) {
      Plane& p = planes_[k];
      if (p.across >= 0 || p.wall) continue;
      const double step = 1e-6 * std::cbrt(volume_[c]);
      const int partner = locate(plane_point[k] + step * p.normal);
      p.beyond = partner;  // may be c itself with one axial layer
    }
}

Vec3 CellLocator::wrap(const Vec3& x) const {
  Vec3 w = x;
  double z = x.z() - z0_;
  if (z >= 0 && z < length_) return w;  // the common case
  z = std::fmod(z, length_);
  if (z < 0) z += length_;
  if (z >= length_) z = 0;  // rounding of a tiny negative value
  w.z() = z0_ + z;
  return w;
}

double CellLocator::clearance(int cell, const Vec3& x) const {
  double d = std::numeric_limits<double>::max();
  for (int k = plane_start_[cell]; k < plane_start_[cell + 1]; ++k) d = std::min(d, -signed_distance(planes_[k], x));
  return d;
}

bool CellLocator::inside(int cell, const Vec3& x) const {
  const double tol = tolerance_[cell];
  for (int k = plane_start_[cell]; k < plane_start_[cell + 1]; ++k)
    if (signed_distance(planes_[k], x) > tol) return false;
  return true;
}

int CellLocator::bin_of(const Vec3& x) const {
  int idx[3];
  for (int d = 0; d < 3; ++d) {
    const double t = (x[d] - bin_lo_[d]) / bin_size_[d];
    if (d < 2 && (t < -1e-9 || t > nbin_[d] + 1e-9)) return -1;  // beyond the mesh's box
    idx[d] = std::clamp(static_cast<int>(std::floor(t)), 0, nbin_[d] - 1);
  }
  return (idx[2] * nbin_[1] + idx[1]) * nbin_[0] + idx[0];
}

int CellLocator::search_bins(const Vec3& x) const {
  ++stats_.bin_searches;
  const int b = bin_of(x);
  if (b >= 0)
    for (int k = bin_start_[b]; k < bin_start_[b + 1]; ++k)
      if (inside(bin_cells_[k], x)) return bin_cells_[k];
  ++stats_.outside;
  return -1;
}

const std::vector<WallTriangle>& CellLocator::dem_wall() const {
  if (!dem_wall_) dem_wall_ = wall_->dem_wall();
  return *dem_wall_;
}

int CellLocator::locate_near_surface(const Vec3& w) const {
  if (wall_->signed_distance(in_vessel_frame(w)) > facets_outside_ + 1e-12 * radius_) return -1;
  const int b = bin_of(w);
  if (b < 0) return -1;
  int best = -1;
  double least = std::numeric_limits<double>::max();
  for (int k = bin_start_[b]; k < bin_start_[b + 1]; ++k) {
    const int c = bin_cells_[k];
    double worst = 0;
    for (int q = plane_start_[c]; q < plane_start_[c + 1]; ++q) worst = std::max(worst, signed_distance(planes_[q], w));
    if (worst <= 0.5 * std::cbrt(volume_[c]) && worst < least) {
      best = c;
      least = worst;
    }
  }
  return best;
}

int CellLocator::locate_in_wall_gap(const Vec3& x) const {
  const Vec3 w = wrap(x);
  if (wall_ && !axisymmetric_) return locate_near_surface(w);
  const Vec3 v = in_vessel_frame(w);
  if (!(wall_gap_ > 0) || std::hypot(v.x(), v.y()) > axisymmetric_->radius_at(v.z()) * (1 + 1e-12)) return -1;
  const int b = bin_of(w);
  if (b < 0) return -1;
  int best = -1;
  double best_depth = std::numeric_limits<double>::max();
  for (int k = bin_start_[b]; k < bin_start_[b + 1]; ++k) {
    const int c = bin_cells_[k];
    const double tol = tolerance_[c];
    double depth = 0;  // how far behind a wall face
    bool ok = true;
    for (int q = plane_start_[c]; q < plane_start_[c + 1] && ok; ++q) {
      const double s = signed_distance(planes_[q], w);
      if (s <= tol) continue;
      if (s <= planes_[q].gap + tol)
        depth = std::max(depth, s);
      else
        ok = false;
    }
    if (ok && depth < best_depth) {
      best = c;
      best_depth = depth;
    }
  }
  return best;
}

int CellLocator::locate(const Vec3& x, int hint) const {
  const Vec3 w = wrap(x);
  if (hint >= 0 && hint < n_cells()) {
    if (inside(hint, w)) {  // fast path: stops at the first violated face
      ++stats_.hint_hits;
      return hint;
    }
    int c = hint;
    for (int step = 0; step <= max_walk_steps_; ++step) {
      // Most violated face of c.
      double worst = -std::numeric_limits<double>::max();
      int across = -1;
      for (int k = plane_start_[c]; k < plane_start_[c + 1]; ++k) {
        const double s = signed_distance(planes_[k], w);
        if (s > worst) {
          worst = s;
          across = planes_[k].across;
        }
      }
      if (worst <= tolerance_[c]) {
        ++stats_.walk_hits;
        return c;
      }
      if (across < 0) break;  // a boundary (wall or cyclic) lies in the way: ask the bins
      c = across;
    }
  }
  return search_bins(w);
}

}  // namespace hemo::particles
