// The Y bifurcation a scene may ask for (vessel.shape = "bifurcation"; docs/design.md, "Surface
// vessels"): a parent tube of diameter D_p along +z from its inlet cap at z = 0 to the junction
// at z = L_p, and two daughters of diameters D_1, D_2 and length L_d from the junction, at +theta/2
// (daughter 1, towards +x) and -theta/2 (daughter 2) from the z axis in the x-z plane, each
// ending in a flat outlet cap. Regions: "wall", "inlet", "outlet_1", "outlet_2" (surface.h).
//
// How it is built: the vessel is the union of three capsules (the points within a tube's radius
// of its axis segment), the parent's round end and the daughters' round starts centred on the
// junction point. The union's distance-like function (the least of the capsules' distances minus
// radii, negative inside) is sampled on a grid and its zero level extracted by marching
// tetrahedra: every cube of the grid split into the same six tetrahedra around its main diagonal,
// so neighbouring cubes cut their shared faces alike and each crossing point, made once per grid
// edge, is shared by every triangle through it. That makes the surface closed by construction,
// whatever the angle or the diameters, with no mesh boolean to get right (check_surface verifies
// it). The crossing points are moved onto the exact zero level (Newton along the gradient); the
// tubes run a few steps beyond their ends, and each end is then cut off by its plane and closed
// by a flat cap (a fan about its centre): marching tetrahedra would bevel a sharp rim by about a
// step, the cut leaves it on the tube. The grid's step sets the accuracy: the wall's points are
// on the exact surface, its facets' chords within about step^2 / (8 r) of it.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "surface.h"
#include "vessel_wall.h"

namespace hemo {

// The narrowest daughter a bifurcation may have, m: a red cell's diameter (8 um). The vessel is
// for blood; a daughter narrower than the cells the scene could carry would be shut to them.
inline constexpr double kMinDaughterDiameter = 8e-6;

// The most grid points the surface is sampled on (8 bytes each, plus the crossings): 2e7, about
// 160 MB of samples, e.g. a 30-um parent and daughters of 24 um about 6 mm long at the default step.
inline constexpr double kMaxBifurcationSamples = 2e7;

struct BifurcationSpec {
  double parent_diameter = 0;                        // m, D_p
  double parent_length = 0;                          // m, L_p: inlet cap to junction
  double daughter_diameter[2] = {0, 0};              // m, D_1, D_2; 0: Murray's law, D_p / 2^(1/3)
  double daughter_length = 0;                        // m, L_d: junction to outlet cap's centre; 0: L_p
  double angle = 60 * 3.14159265358979323846 / 180;  // rad, theta: between the daughters
  double step = 0;                                   // m, the sampling grid's step; 0: the narrowest diameter / 10
};

// Murray's law for two equal daughters: D_p^3 = 2 D_d^3.
double murray_daughter_diameter(double parent_diameter);

// The spec with its defaults filled in (daughter diameters, length, step).
BifurcationSpec resolved(const BifurcationSpec& spec);

// Checks the spec and throws SurfaceError with one line on the first problem: a diameter or
// length that is not positive, a daughter narrower than kMinDaughterDiameter, an angle outside
// (0, 180) degrees, a daughter wider than the parent, daughters whose outlets overlap, or a
// sampling grid of more than kMaxBifurcationSamples points.
void check_bifurcation(const BifurcationSpec& spec);

// The union's function at x: negative inside, zero on the surface (the tubes cut at their ends),
// positive outside; a Euclidean distance away from the junction's creases and the caps' rims.
double bifurcation_function(const BifurcationSpec& spec, const Eigen::Vector3d& x);

// Builds the surface (check_bifurcation first).
Surface make_bifurcation(const BifurcationSpec& spec);

// The unit direction of daughter i (0 or 1).
Eigen::Vector3d daughter_direction(const BifurcationSpec& spec, int i);

// The share of the parent's flow daughter i (0 or 1) takes in the Poiseuille network of the three
// tubes with both outlets at one pressure: its conductance R_i^4 / L_d over the two's sum (the
// daughters are equally long, so R_i^4 / (R_1^4 + R_2^4)). Lubrication theory's reading: the
// junction's own losses are left out (the fluid node's splits are within a few per mille of it for
// the scenes' angles: docs/fluid-verification.md).
double network_flow_fraction(const BifurcationSpec& spec, int i);

// The bifurcation's wall as the particle side asks it (model/vessel_wall.h). The signed distance is
// bifurcation_function's; the section at a point is that of the branch whose tube it is deepest
// in (the least distance from the branch's axis segment less its radius; the parent's segment
// from the inlet to the junction, each daughter's from the junction to its outlet): that branch's
// radius, the distance from its axis segment, and its centre-line speed as
// the network's flow share gives it relative to the parent's, u_i / u_p = (Q_i / Q_p) (R_p / R_i)^2
// (Poiseuille in each branch); the parent's is the vessel's fastest for daughters no wider than it
// (check_bifurcation) unless one takes nearly all the flow.
class BifurcationWall : public VesselWall {
 public:
  explicit BifurcationWall(const BifurcationSpec& spec);  // check_bifurcation first

  double signed_distance(const Point& x) const override;
  // The gradient of the signed distance (central differences over a thousandth of the narrowest
  // radius), normalised.
  Point outward_normal(const Point& x) const override;
  Section section_at(const Point& x) const override;
  // The wall region of make_bifurcation's surface, each facet turned to face into the vessel.
  std::vector<WallTriangle> dem_wall() const override;
  // Daughter i's outlet cap: centred on its axis's end, facing along the daughter.
  std::vector<Opening> outlets() const override;
  // The parent's axis from the inlet to the junction, each daughter's from the junction to its
  // outlet.
  std::vector<Branch> branches() const override;
  // The branch whose tube x is deepest in: 0 the parent, 1 or 2 a daughter.
  int branch_at(const Point& x) const override;
  const BifurcationSpec& spec() const { return spec_; }

 private:
  double axis_distance(int branch, const Point& x) const;
  BifurcationSpec spec_;  // resolved
  Point start_[3], end_[3];
  double radius_[3], speed_scale_[3];
};

}  // namespace hemo
