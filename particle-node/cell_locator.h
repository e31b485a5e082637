// Exact point location in the fluid mesh (docs/design.md: "the particle node locates particles in
// cells exactly, not by nearest centre").
//
// Every cell is taken as a convex polyhedron: a point is inside a cell iff it lies on the inner
// side (within a tiny tolerance) of the plane of every face of the cell. Face planes go through
// the area-weighted face centroid with the face's area normal, oriented away from the cell
// centre, so two cells sharing a face share exactly the same plane: no gaps, no overlaps.
//
// Search order for a point: the caller's hint (e.g. the particle's cell at the previous DEM
// step), a short walk across the most violated face, then the candidates of a uniform bin grid.
// Each bin lists every cell whose bounding box touches it, so the bin search is complete: a
// point in no candidate cell is outside the mesh (-1), without any brute-force fallback.
//
// The mesh is periodic along z with period vessel_length_m starting at the lowest mesh point;
// points are wrapped into [z0, z0 + L) before they are located. An open vessel fed by a feeder
// (model/vessel_ends.h, FeederLayout) is two regions of one mesh: the vessel over [0, L] and the
// feeder beside it over the whole period, the feeder's length, which is then the period.
//
// The wall gap: the fluid mesh's wall is a polygon of flat faces (chords) inside the round
// vessel the DEM wall bounds, so a particle touching the DEM wall can have its centre in the
// thin gap between a wall face and the circle (up to R (1 - cos(pi / n)) deep for n faces
// around). locate() says -1 there, exactly; locate_in_wall_gap() then finds the wall cell
// whose wall face the point is behind, within that face's own gap, and inside the vessel
// radius. Only wall faces whose corners lie on the vessel's wall (chords) have a gap.
//
// The vessel's wall is the shape's, r = R(z) (model/geometry.h): the mesh's z origin is the
// shape's, its period the shape's length. A straight tube's answers are those of the fixed radius
// the locator used before shapes, to the bit. The feeder's wall is measured where each of its
// points stands for, in the vessel frame (the inlet plane, FeederLayout::in_vessel_frame): one
// wall, one set of rules for chords, gaps and the radius; without a feeder the frame is the
// identity and the answers are those of before feeders, to the bit.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <vec.h>

#include <geometry.h>
#include <vessel_ends.h>
#include <hemo/mesh_t.hpp>

#include <memory>
#include <optional>
#include <vector>

namespace hemo::particles {

// What a moving point remembers between searches: its cell, where it was last located and the
// distance from there to the nearest face of that cell. While the point stays within that
// distance of the anchor it is still inside the same cell (each face plane is at least that far),
// so most DEM steps need one distance instead of a plane test per face.
struct LocateCache {
  Vec3 anchor = Vec3::Zero();
  double clearance = -1;  // < 0: nothing cached
  int cell = -1;
};

class CellLocator {
 public:
  // Throws std::invalid_argument when the mesh is inconsistent (sizes, indices, empty cells, a
  // z extent other than the period). `wall` is the vessel's (make_vessel_wall: an axisymmetric
  // shape, or a surface vessel's); none: the straight tube of the mesh's diameter and length.
  // `feeder`: the mesh is an open vessel's with its feeder (feeder_layout(scene)); its period is
  // the feeder's length.
  explicit CellLocator(const mesh_t& mesh, std::shared_ptr<const VesselWall> wall = nullptr,
                       std::optional<FeederLayout> feeder = std::nullopt);

  // The cell containing x (any z; wrapped first), or -1 when x is outside the mesh.
  // `hint` is a cell to try first (-1: none).
  int locate(const Vec3& x, int hint = -1) const;

  // The same answer as locate(x, cache.cell), using and updating the cache.
  int locate(const Vec3& x, LocateCache& cache) const {
    if (cache.clearance > 0 && (x - cache.anchor).squaredNorm() < cache.clearance * cache.clearance) {
      ++stats_.cache_hits;
      return cache.cell;
    }
    const int c = locate(x, cache.cell);
    cache.cell = c;
    cache.anchor = x;
    cache.clearance = c >= 0 ? clearance(c, wrap(x)) : -1;
    return c;
  }

  // Distance from a point inside `cell` to the nearest of its face planes (<= 0 outside).
  double clearance(int cell, const Vec3& x) const;

  // For a point that locate() found in no cell: the wall cell it lies behind, when it is in
  // the wall gap (inside the radius of its tube, the vessel's or the feeder's, at most
  // wall_gap() behind the cell's wall face and inside all its other faces); else -1.
  int locate_in_wall_gap(const Vec3& x) const;

  // Calls f(signed distance of x from the face plane (< 0 on the cell's side), the cell beyond
  // the face, the face's outward unit normal) for each face of `cell`; beyond is the neighbour,
  // the periodic partner across a cyclic face, or -1 beyond a wall. x already wrapped.
  template <class F>
  void for_each_face(int cell, const Vec3& x, F&& f) const {
    for_each_face_kind(cell, x, [&](double d, int beyond, const Vec3& normal, bool, bool) { f(d, beyond, normal); });
  }
  // The same, also telling whether the face is a wall (beyond = -1) or cyclic (beyond is the
  // periodic partner, one vessel length away along the normal's z): f(d, beyond, normal, wall,
  // cyclic).
  template <class F>
  void for_each_face_kind(int cell, const Vec3& x, F&& f) const {
    for (int k = plane_start_[cell]; k < plane_start_[cell + 1]; ++k) {
      const Plane& p = planes_[k];
      f(signed_distance(p, x), p.beyond, p.normal, p.wall, p.across < 0 && !p.wall);
    }
  }
  // The cell beyond the face of `cell` whose outward normal is closest to `direction` (unit), if
  // that face turns toward it by less than ~45 degrees; else -1 (also beyond a wall).
  int cell_toward(int cell, const Vec3& direction) const {
    double best = 0.7;
    int beyond = -1;
    for (int k = plane_start_[cell]; k < plane_start_[cell + 1]; ++k) {
      const double c = planes_[k].normal.dot(direction);
      if (c > best) {
        best = c;
        beyond = planes_[k].beyond;
      }
    }
    return beyond;
  }

  // True when the (already wrapped) point is inside `cell` up to the tolerance.
  bool inside(int cell, const Vec3& x) const;

  // Deepest wall gap of the mesh (m): max over wall chords of how far the round wall reaches
  // behind the face plane.
  double wall_gap() const { return wall_gap_; }

  // x with z wrapped into [z0, z0 + L).
  Vec3 wrap(const Vec3& x) const;

  int n_cells() const { return static_cast<int>(volume_.size()); }
  const Vec3& centre(int cell) const { return centre_[cell]; }
  double volume(int cell) const { return volume_[cell]; }
  const std::vector<double>& volumes() const { return volume_; }
  double z0() const { return z0_; }
  double length() const { return length_; }
  double radius() const { return radius_; }  // R0, the nominal radius (the widest a shape gets)
  // The section of the tube x is in (the vessel's there, or the feeder's): its wall radius, x's
  // distance from its centre line, its centre-line speed (model/vessel_wall.h).
  VesselWall::Section section(const Vec3& x) const { return wall_->section_at(in_vessel_frame(x)); }
  const VesselWall& wall() const { return *wall_; }
  // The wall's DEM facets (VesselWall::dem_wall), made on first use and kept: a surface vessel's
  // come from marching tetrahedra, which the locator, the DEM's set-up and the overlap diagnostic
  // would otherwise each run again.
  const std::vector<WallTriangle>& dem_wall() const;
  // The vessel's shape r = R(z) when it is axisymmetric; nullptr for a surface vessel's wall.
  const VesselGeometry* axisymmetric() const { return axisymmetric_; }
  // x where it stands for in the vessel: a feeder point moved onto the vessel's inlet plane (at
  // its offset from the feeder's axis), any other point as it is. Not wrapped. Radial distances
  // and the shape's R(z), centre-line speeds and diameters of a point are those of this point.
  Vec3 in_vessel_frame(const Vec3& x) const { return feeder_ ? feeder_->in_vessel_frame(x) : x; }
  const std::optional<FeederLayout>& feeder() const { return feeder_; }

  // Statistics of the searches so far (not thread safe; for diagnostics and tests).
  struct Stats {
    long cache_hits = 0;
    long hint_hits = 0;
    long walk_hits = 0;
    long bin_searches = 0;
    long outside = 0;
  };
  const Stats& stats() const { return stats_; }

 private:
  struct Plane {
    Vec3 normal;    // unit, pointing out of the cell
    double offset;  // normal . (point on the face)
    int across;     // the cell on the other side, -1 for a boundary face
    int beyond;     // across, or the periodic partner of a cyclic face (-1: wall)
    bool wall;      // a face of a wall patch (any boundary patch that is not cyclic)
    double gap;     // wall chord on the vessel circle: how far behind it the circle reaches (m)
  };

  double signed_distance(const Plane& p, const Vec3& x) const { return p.normal.dot(x) - p.offset; }

  // The constructor's steps, in order.
  struct Faces;
  void read_cells(const mesh_t& mesh);
  static Faces read_faces(const mesh_t& mesh, const std::vector<Vec3>& points);
  // The face planes of each cell, their tolerances, which cells have a wall gap; returns a point
  // on each plane.
  std::vector<Vec3> build_planes(const mesh_t& mesh, const Faces& faces, const std::vector<char>& wall_face,
                                 const std::vector<char>& on_circle, std::vector<char>& wall_cell);
  void set_period(const mesh_t& mesh, const Vec3& lo, const Vec3& hi);
  // How far along the unit `normal` the vessel's wall reaches over z in [z_lo, z_hi], in the
  // vessel frame.
  double wall_reach(const Vec3& normal, double z_lo, double z_hi) const;
  // The deepest wall gap, and the wall cells' boxes widened by it for the bins.
  void reach_into_wall_gap(const std::vector<char>& wall_cell, Faces& faces);
  void build_bins(const Faces& faces);
  void find_periodic_partners(const std::vector<Vec3>& plane_point);
  int bin_of(const Vec3& x) const;
  int search_bins(const Vec3& x) const;

  std::vector<int> plane_start_;  // CSR: planes of cell c are plane_start_[c] .. plane_start_[c+1]
  std::vector<Plane> planes_;
  std::vector<Vec3> centre_;
  std::vector<double> volume_;
  std::vector<double> tolerance_;  // per cell, absolute (m)

  double z0_ = 0, length_ = 0, radius_ = 0, wall_gap_ = 0;
  std::shared_ptr<const VesselWall> wall_;
  const VesselGeometry* axisymmetric_ = nullptr;  // wall_'s, when it is r = R(z)
  // A surface vessel's wall gap: the cell whose planes x violates least, by at most half its size,
  // for a point not farther outside the analytic wall than the DEM's facets reach (the mesh is
  // snapped to those facets, which bevel the analytic shape's ridges: facet_distance.h).
  int locate_near_surface(const Vec3& w) const;
  double facets_outside_ = 0;  // m, furthest_outside of the DEM's wall, for a surface vessel
  mutable std::optional<std::vector<WallTriangle>> dem_wall_;
  std::optional<FeederLayout> feeder_;
  Vec3 bin_lo_, bin_size_;
  int nbin_[3] = {1, 1, 1};
  std::vector<int> bin_start_;  // CSR: candidate cells per bin
  std::vector<int> bin_cells_;

  int max_walk_steps_ = 8;
  mutable Stats stats_;
};

}  // namespace hemo::particles
