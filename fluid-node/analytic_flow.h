// Analytic plasma flows in the straight vessel, for the analytic-flow fluid node
// (hemocosim-analytic-fluid) and for tests: steady Poiseuille flow from the imposed pressure
// drop, and linear shear. Plain C++, no OpenFOAM.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "fluid_case.h"
#include "vessel_mesh.h"

#include <array>
#include <string>

namespace hemo {

class fluid_state_t;

struct AnalyticFlow {
  enum class Kind { poiseuille, shear };
  Kind kind = Kind::poiseuille;
  // Poiseuille: u_z = a (R^2 - x^2 - y^2), a = dP / (4 mu l).
  double a = 0;       // 1/(m s)
  double radius = 0;  // m
  // Shear: u_z = u0 + rate x (a uniform gradient d u_z / d x; not zero at the wall).
  double rate = 0;  // 1/s
  double u0 = 0;    // m/s
  // Poiseuille: the imposed pressure gradient dP/dz = -dP / l (Pa/m); in Stokes flow the
  // viscous force per volume mu lap u equals it (shear: both zero).
  double dpdz = 0;

  Vec3 velocity(const Vec3& x) const;
  // G[i][j] = d u_j / d x_i, row-major (fluid_state_t's order).
  std::array<double, 9> gradient(const Vec3& x) const;
  // Wall shear stress the flow exerts (Poiseuille: d dP / (4 l)); mu times |du_z/dn| at r = R.
  double wall_shear_rate() const;
  // grad P (the imposed drop) and mu lap u, N/m^3: uniform in both flows.
  Vec3 pressure_gradient() const { return {0, 0, dpdz}; }
  Vec3 viscous_force() const { return {0, 0, dpdz}; }
};

// Poiseuille flow of the scene's pressure drop.
AnalyticFlow poiseuille_flow(const FluidSettings& fluid, const Vessel& vessel);
// Linear shear u_z = u0 + rate x.
AnalyticFlow shear_flow(double rate, double u0);

// Fills the state's per-cell velocity and gradient with the flow's values at the cell centres
// (for a linear field they are also its cell averages; for Poiseuille the cell average is
// smaller by a times the cell's polar second moment about its centre over its area); and,
// when the scene's momentum form asks for them, its pressure gradient and viscous force.
void fill_state(const AnalyticFlow& flow, const MeshGeometry& geometry, const std::string& mesh_hash, double time_s,
                fluid_state_t& state, bool pressure_gradient = false, bool viscous_force = false);

}  // namespace hemo
