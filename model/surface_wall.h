// An imported surface's wall as the particle side asks it (model/vessel_wall.h): a closed,
// outward-oriented triangulated surface (surface.h, check_surface) whose shape nothing else is
// known of — no axis or flow split; its branches are found from its open ends (below).
//
// - Signed distance: to the nearest triangle of the whole surface (a point beyond a cap is outside
//   the vessel), its sign from the angle-weighted pseudo-normal of the feature (face, edge or
//   vertex) the nearest point lies on: on a closed, consistently oriented surface the point is
//   outside exactly when it lies on the pseudo-normal's side (Baerentzen & Aanaes, IEEE TVCG 11,
//   2005), where a face normal alone misjudges points nearest an edge or a vertex.
// - Section through a point: the chord along the wall's normal. From x the nearest wall point is
//   d1 away; the ray from x away from it meets the wall again d2 further. In a tube of circular
//   section that line passes through the axis, so the radius is (d1 + d2) / 2 and the point's
//   distance from the centre line |d2 - d1| / 2, exact for a cylinder or a torus, and within the
//   slope's cosine of the section where the tube narrows. The wall region alone: the caps are no
//   wall of a section. Where the ray meets no wall (a point outside, beyond an end) there is no
//   section: every field NaN.
// - Branches: one per open end, the inlet's first and then outlet_1, outlet_2, ... (each a
//   tube of the end's equivalent radius sqrt(A / pi) about the line through the end's centroid
//   along its normal), reaching in from the end as far as the wall runs round that tube: every
//   one of 64 points of the tube's circle within kBranchWallTolerance of the radius of the
//   surface (bisected to 1e-3 of the radius). A branch so ends where the vessel bends, narrows,
//   widens or meets another branch by more than that; the analysis measures the cell-free layer
//   of each branch over that straight stretch (postprocess/analysis, BranchAccumulator). A point
//   is in the branch whose tube it is deepest in among those whose stretch it lies across, and in
//   none elsewhere (the junction, a bend).
// - No centre-line speed: it would need the vessel's flow split, which an imported surface does
//   not say. section_at's speed_scale is NaN and defines_centreline_speed() false; the particle
//   node refuses a closure that needs it (the spherical surrogate's shear lift).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "surface.h"
#include "vessel_wall.h"

#include <limits>
#include <optional>
#include <vector>

namespace hemo {

// The wall region of a surface (regions as make_vessel_surface names them), each facet turned to
// face into the vessel: the DEM's wall of a surface vessel.
std::vector<WallTriangle> wall_facing_in(const Surface& surface);

class SurfaceWall : public VesselWall {
 public:
  // `surface`: regions named as make_vessel_surface names them ("wall", "inlet", "outlet_1", ...),
  // checked (check_surface) here. Throws SurfaceError with one line.
  explicit SurfaceWall(Surface surface);

  double signed_distance(const Point& x) const override;
  // From the nearest surface point towards x (away from it inside), or the feature's
  // pseudo-normal when x is on the surface.
  Point outward_normal(const Point& x) const override;
  Section section_at(const Point& x) const override;
  bool defines_centreline_speed() const override { return false; }
  // The wall region, each facet turned to face into the vessel.
  std::vector<WallTriangle> dem_wall() const override;
  // Each outlet region's area-weighted centroid and its outward area vector's direction.
  std::vector<Opening> outlets() const override;
  // The open ends' straight stretches (above); made on the first call.
  std::vector<Branch> branches() const override;
  int branch_at(const Point& x) const override;

  // How far the wall may lie from a branch's tube, as a fraction of its radius: wide enough for
  // the facets of a ring of 23 or more segments (1 - cos(pi / 23) = 0.0093) and a rim's rounding,
  // narrow enough that a bend of the centre line by a twentieth of the radius ends the branch.
  static constexpr double kBranchWallTolerance = 0.05;

  const Surface& surface() const { return surface_; }

 private:
  struct Nearest {
    double distance = std::numeric_limits<double>::infinity();
    Point point = Point::Zero();
    int triangle = -1;
    int feature = 0;  // vertex 0-2, edge 3 + k (vertex k to k + 1), face 6
  };
  // The nearest point of the triangles `region` selects (-1: all, else the wall's): from the
  // candidates of x's bin, or by shells of bins for a point outside the grid.
  Nearest nearest(const Point& x, int region) const;
  Nearest nearest_by_shells(const Point& x, int region) const;
  void consider(const Point& x, int triangle, Nearest& best) const;
  // The pseudo-normal of the feature the nearest point is on (not normalised).
  Point pseudo_normal(const Nearest& n) const;
  // The first wall triangle the ray x + t u (t > 0) meets; +infinity when none.
  double wall_hit(const Point& x, const Point& u) const;
  int bin_index(double v, int d) const;
  const std::vector<int>& bin(int i, int j, int k) const;

  Surface surface_;
  int wall_region_ = 0;
  std::vector<Point> face_normal_;                    // unit, outward
  std::vector<Point> vertex_normal_;                  // angle-weighted sums of face normals
  std::vector<std::array<Point, 3>> edge_normal_;     // per triangle, edge k from vertex k to k + 1
  Point lo_ = Point::Zero();
  double h_ = 0;
  int n_[3] = {1, 1, 1};
  std::vector<std::vector<int>> bins_;                // the triangles whose box meets each bin
  // Per bin, the triangles that can be nearest to a point in it, of all regions [0] and of the
  // wall [1]: those within the nearest one's distance from its centre plus its diagonal. Made on
  // a bin's first query (the particles visit a few of them), so a wall is cheap to make; not
  // thread safe, as nothing in a node queries one wall from two threads.
  const std::vector<int>& candidates(int i, int j, int k, int region) const;
  // The branch that starts (inward = true) or ends at the open end `region`.
  Branch end_branch(int region, bool inward) const;
  const std::vector<Branch>& branch_list() const;
  mutable std::optional<std::vector<Branch>> branches_;
  mutable std::vector<std::vector<int>> candidates_[2];
  mutable std::vector<char> candidates_made_[2];
};

}  // namespace hemo
