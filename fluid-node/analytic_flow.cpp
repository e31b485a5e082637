// Analytic plasma flows (see analytic_flow.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "analytic_flow.h"

#include "cell_fields.h"

#include <algorithm>
#include <cmath>

namespace hemo {

Vec3 AnalyticFlow::velocity(const Vec3& x) const {
  if (kind == Kind::poiseuille) return {0, 0, a * (radius * radius - x[0] * x[0] - x[1] * x[1])};
  return {0, 0, u0 + rate * x[0]};
}

std::array<double, 9> AnalyticFlow::gradient(const Vec3& x) const {
  std::array<double, 9> g{};
  if (kind == Kind::poiseuille) {
    g[0 * 3 + 2] = -2 * a * x[0];  // d u_z / d x
    g[1 * 3 + 2] = -2 * a * x[1];  // d u_z / d y
  } else {
    g[0 * 3 + 2] = rate;
  }
  return g;
}

double AnalyticFlow::wall_shear_rate() const { return kind == Kind::poiseuille ? 2 * a * radius : std::abs(rate); }

AnalyticFlow poiseuille_flow(const FluidSettings& fluid, const Vessel& vessel) {
  AnalyticFlow f;
  f.kind = AnalyticFlow::Kind::poiseuille;
  f.a = fluid.pressure_drop / (4 * fluid.viscosity * vessel.length);
  f.radius = vessel.radius();
  f.dpdz = -fluid.pressure_drop / vessel.length;
  return f;
}

AnalyticFlow shear_flow(double rate, double u0) {
  AnalyticFlow f;
  f.kind = AnalyticFlow::Kind::shear;
  f.rate = rate;
  f.u0 = u0;
  return f;
}

void fill_state(const AnalyticFlow& flow, const MeshGeometry& geometry, const std::string& mesh_hash, double time_s,
                fluid_state_t& state, bool pressure_gradient, bool viscous_force) {
  const auto n = geometry.cell_centres.size();
  state.mesh_hash = mesh_hash;
  state.time_s = time_s;
  resize_cells(state, static_cast<int>(n), pressure_gradient, viscous_force);
  const Vec3 grad_p = flow.pressure_gradient();
  const Vec3 viscous = flow.viscous_force();
  for (std::size_t c = 0; c < n; ++c) {
    const Vec3 u = flow.velocity(geometry.cell_centres[c]);
    std::copy(u.begin(), u.end(), velocity_of(state, c));
    const auto g = flow.gradient(geometry.cell_centres[c]);
    std::copy(g.begin(), g.end(), gradient_of(state, c));
    if (pressure_gradient) std::copy(grad_p.begin(), grad_p.end(), pressure_gradient_of(state, c));
    if (viscous_force) std::copy(viscous.begin(), viscous.end(), viscous_force_of(state, c));
  }
}

}  // namespace hemo
