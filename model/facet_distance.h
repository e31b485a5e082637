// How far a point is from a wall given as facets (a surface vessel's DEM wall, VesselWall::
// dem_wall): the distance to the nearest facet within a reach. The DEM collides with these facets,
// not with the analytic shape they approximate: marching tetrahedra bevel a bifurcation's divider
// ridge by about half a sampling step, and a cell resting on the bevel lies microns inside the
// analytic wall while touching no facet. So the overlap that says whether contacts are resolved is
// measured here, as LIGGGHTS's mesh contact measures it: a radius less the distance to the nearest
// facet, whichever side of it the centre is. (Which side is the cell locator's business: a centre
// behind the wall is in no fluid cell. A facet's normal cannot tell it: marching tetrahedra fold
// slivers over near the ridge, and a red cell there read 4.6 um behind the wall by its nearest
// facet's normal.)
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "vessel_wall.h"

#include <Eigen/Dense>

#include <vector>

namespace hemo {

// The point of triangle (a, b, c) nearest x.
Eigen::Vector3d nearest_on_triangle(const Eigen::Vector3d& x, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                    const Eigen::Vector3d& c);

// How far outside the wall's analytic shape its facets reach, m (0 if nowhere): the most of the
// wall's signed distance over each facet's vertices, edge midpoints and centroid. A point farther
// outside the analytic shape than this is outside the DEM's wall too.
double furthest_outside(const VesselWall& wall, const std::vector<WallTriangle>& facets);

class FacetDistance {
 public:
  // `reach`, m: the largest distance a query needs (a particle's radius); facets farther away are
  // not seen.
  FacetDistance(std::vector<WallTriangle> facets, double reach);

  // The distance from x to the nearest facet, m, or +infinity when none is within reach.
  double distance(const Eigen::Vector3d& x) const;

  std::size_t facets() const { return facets_.size(); }

 private:
  std::vector<WallTriangle> facets_;
  double reach_;
  Eigen::Vector3d lo_;
  double h_;
  int n_[3];
  std::vector<std::vector<int>> bins_;  // facets within reach of each bin
};

}  // namespace hemo
