// Synthetic cases without a fluid node: hand-made meshes and fluid states, for the particle
// node's tests and its DEM bench (hemocosim-dem-bench).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <scene.h>
#include <hemo/fluid_state_t.hpp>
#include <hemo/mesh_t.hpp>

#include <array>
#include <functional>

namespace hemo::particles::synthetic {

// A box [x0,x1] x [y0,y1] x [0,length] of nx x ny x nz hexahedra, OpenFOAM-ordered: internal
// faces first (owner < neighbour, area vector out of the owner), then the patches
// x-min, x-max, y-min, y-max (walls) and z-min, z-max (cyclic). vessel_diameter_m is set to
// `diameter`, vessel_length_m to `length`.
mesh_t box_mesh(int nx, int ny, int nz, double x0, double x1, double y0, double y1, double length, double diameter,
                const std::string& hash = "box");

// A polygonal vessel: n_around triangular prisms (axis, ring point i, ring point i+1) per layer,
// nz layers over [0, length]; ring points on the circle of radius `radius`, so the wall faces
// are chords (wall gap R (1 - cos(pi / n_around))). Patches "wall" and the two cyclic ends.
mesh_t wedge_mesh(int n_around, int nz, double radius, double length, const std::string& hash = "wedge");

// A fluid state on `mesh` with u and grad u (G[i][j] = d u_j / d x_i) given at each cell centre.
using FieldAt =
    std::function<void(const std::array<double, 3>& x, std::array<double, 3>& u, std::array<double, 9>& grad)>;
fluid_state_t fluid_state(const mesh_t& mesh, const FieldAt& field, double time = 0);
// The state with the pressure gradient and viscous force a steady Poiseuille flow of the scene's
// driving has, in every cell, where the scene's momentum form asks for them: grad P = -dP/l e_z
// (the imposed drop) and mu lap u = -dP/l e_z (mu lap u = -4 mu U_max / R^2 with U_max the
// profile's, the wall stress balancing the drop), so F_p + F_v = 0 on every particle.
fluid_state_t with_poiseuille_stress(fluid_state_t state, const Scene& scene);

// A scene with docs/model.md's default RBCs and platelets (Stokes drag) in a vessel of the given
// size, hematocrit and wall shear rate, in the momentum form "plasma_driven" (its fluid states
// carry no pressure gradient or viscous force).
Scene blood_scene(double diameter, double length, double hematocrit = 0.15, double wall_shear_rate = 799);

// The paper's closures on a scene (what a scene file gets by default): RBC rbc_fit + rbc_lift,
// platelets oblate drag, lift and torque with semi-axes 2.06 and 0.52 um, sphere_overlap.
void use_paper_closures(Scene& scene);

// Poiseuille flow u_z = u_max (1 - r^2/R^2) (zero outside r > R) and its exact gradient.
FieldAt poiseuille(double radius, double u_max);

}  // namespace hemo::particles::synthetic
