// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_sampler.h"

#include "cell_fields.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hemo::particles {
namespace {

// The length fields and arrays against n_cells: empty when they fit, else one line.
std::string sizes_problem(const fluid_state_t& s) {
  std::string why = flat_size_problem("velocity", s.n_velocity_values, s.velocity, kVectorValues, s.n_cells);
  if (why.empty())
    why = flat_size_problem("velocity gradient", s.n_gradient_values, s.velocity_gradient, kTensorValues, s.n_cells);
  // The pressure gradient is optional: none, or 3 per cell.
  if (why.empty() && (s.n_pressure_gradient_values != 0 || !s.pressure_gradient.empty()))
    why = flat_size_problem("pressure gradient", s.n_pressure_gradient_values, s.pressure_gradient, kVectorValues,
                            s.n_cells);
  if (why.empty() && (s.n_viscous_values != 0 || !s.viscous_force.empty()))
    why = flat_size_problem("viscous force", s.n_viscous_values, s.viscous_force, kVectorValues, s.n_cells);
  return why.empty() ? why : "fluid state: " + why;
}

// An optional per-cell vector field of a fluid state (none, or 3 values per cell; the sizes are
// checked before): as vectors, refusing a value that is not finite with the cell it is in.
std::vector<Vec3> optional_vectors(const std::vector<double>& values, int n, const char* what) {
  std::vector<Vec3> out;
  if (values.empty()) return out;
  out.resize(n);
  for (int c = 0; c < n; ++c) {
    const double* v = values.data() + kVectorValues * c;
    out[c] = Vec3(v[0], v[1], v[2]);
    if (!out[c].allFinite())
      throw std::invalid_argument(std::string("fluid ") + what + " is not finite in cell " + std::to_string(c));
  }
  return out;
}

// gamma_dot = sqrt(2 S:S), S = (G + G^T)/2
double shear_rate_of(const Mat3& g) {
  const Mat3 strain = 0.5 * (g + g.transpose());
  return std::sqrt(2.0 * (strain.array() * strain.array()).sum());
}

// Vectors as the flat array of 3 values per cell a fluid state carries.
std::vector<double> flat(const std::vector<Vec3>& vectors) {
  std::vector<double> out;
  out.reserve(3 * vectors.size());
  for (const Vec3& v : vectors) out.insert(out.end(), {v.x(), v.y(), v.z()});
  return out;
}

}  // namespace

std::string FluidSampler::check(const fluid_state_t& s, int n_cells, const std::string& mesh_hash) {
  if (s.mesh_hash != mesh_hash)
    return "fluid state is for mesh '" + s.mesh_hash + "', not the mesh received ('" + mesh_hash + "')";
  if (s.n_cells != n_cells)
    return "fluid state has " + std::to_string(s.n_cells) + " cells, the mesh has " + std::to_string(n_cells);
  if (std::string why = sizes_problem(s); !why.empty()) return why;
  if (!std::isfinite(s.time_s)) return "fluid state time is not finite";
  for (int c = 0; c < n_cells; ++c) {
    for (int k = 0; k < kVectorValues; ++k)
      if (!std::isfinite(velocity_of(s, c)[k])) return "fluid velocity is not finite in cell " + std::to_string(c);
    for (int k = 0; k < kTensorValues; ++k)
      if (!std::isfinite(gradient_of(s, c)[k]))
        return "fluid velocity gradient is not finite in cell " + std::to_string(c);
  }
  for (double g : s.pressure_gradient)
    if (!std::isfinite(g)) return "fluid pressure gradient is not finite";
  for (double f : s.viscous_force)
    if (!std::isfinite(f)) return "fluid viscous force is not finite";
  return {};
}

void FluidSampler::set_state(const fluid_state_t& s) {
  const int n = locator_->n_cells();
  if (s.n_cells != n)
    throw std::invalid_argument("fluid state has " + std::to_string(s.n_cells) + " cells, the mesh has " +
                                std::to_string(n));
  if (std::string why = sizes_problem(s); !why.empty()) throw std::invalid_argument(why);
  velocity_.resize(n);
  gradient_.resize(n);
  shear_rate_.resize(n);
  max_speed_ = 0;
  for (int c = 0; c < n; ++c) {
    const double* u = velocity_of(s, c);
    const double* g = gradient_of(s, c);  // row-major G[i][j]
    velocity_[c] = Vec3(u[0], u[1], u[2]);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) gradient_[c](i, j) = g[3 * i + j];
    if (!velocity_[c].allFinite() || !gradient_[c].allFinite())
      throw std::invalid_argument("fluid state is not finite in cell " + std::to_string(c));
    shear_rate_[c] = shear_rate_of(gradient_[c]);
    max_speed_ = std::max(max_speed_, velocity_[c].norm());
  }
  pressure_gradient_ = optional_vectors(s.pressure_gradient, n, "pressure gradient");
  viscous_force_ = optional_vectors(s.viscous_force, n, "viscous force");
}

FluidSampler::Seen FluidSampler::seen(int cell, const Vec3& x, double radius, bool gradient) const {
  Seen s;
  if (kernel_ == nullptr) {
    s.velocity = velocity(cell, x);
    if (gradient) {
      s.gradient = gradient_[cell];
      s.shear_rate = shear_rate_[cell];
    }
    if (has_pressure_gradient()) s.pressure_gradient = pressure_gradient_[cell];
    if (has_viscous_force()) s.viscous_force = viscous_force_[cell];
    return s;
  }
  kernel_->share(cell, x, radius, shares_);
  for (const CellShare& share : shares_) {
    const int c = share.cell;
    const double w = share.fraction;
    s.gradient += w * gradient_[c];
    if (has_pressure_gradient()) s.pressure_gradient += w * pressure_gradient_[c];
    if (has_viscous_force()) s.viscous_force += w * viscous_force_[c];
  }
  // Each cell's value carried to x with the mean of its own and the kernel's gradient: for a
  // quadratic field, u(x) - (1/2) <d>^T H <d>, <d> the offset of the cells' weighted centre from x
  // (0 away from walls), where its own gradient alone would add (1/2) <d^T H d>, which does not
  // vanish: 2 sigma^2 / R^2 of the centre-line speed in Poiseuille flow.
  for (const CellShare& share : shares_) {
    const int c = share.cell;
    if (sampling_ == Sampling::cell) {
      s.velocity += share.fraction * velocity_[c];
      continue;
    }
    const Vec3 offset = Vec3(x.x(), x.y(), x.z() + share.dz) - locator_->centre(c);
    s.velocity += share.fraction * (velocity_[c] + 0.5 * (gradient_[c] + s.gradient).transpose() * offset);
  }
  if (gradient)
    s.shear_rate = shear_rate_of(s.gradient);
  else
    s.gradient = Mat3::Zero();
  return s;
}

std::vector<double> FluidSampler::cell_viscous_forces() const { return flat(viscous_force_); }
std::vector<double> FluidSampler::cell_pressure_gradients() const { return flat(pressure_gradient_); }
std::vector<double> FluidSampler::cell_velocities() const { return flat(velocity_); }

std::vector<double> FluidSampler::cell_gradients() const {
  std::vector<double> out;
  out.reserve(9 * gradient_.size());
  for (const Mat3& g : gradient_)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) out.push_back(g(i, j));
  return out;
}

void FluidSampler::set_state(const std::vector<double>& velocities, const std::vector<double>& gradients,
                             const std::vector<double>& pressure_gradients,
                             const std::vector<double>& viscous_forces) {
  const std::size_t n = static_cast<std::size_t>(locator_->n_cells());
  if (velocities.size() != 3 * n || gradients.size() != 9 * n ||
      !(pressure_gradients.empty() || pressure_gradients.size() == 3 * n) ||
      !(viscous_forces.empty() || viscous_forces.size() == 3 * n))
    throw std::invalid_argument("fluid fields of " + std::to_string(velocities.size() / 3) + " cells, the mesh has " +
                                std::to_string(n));
  fluid_state_t s;
  s.n_cells = static_cast<int>(n);
  s.n_velocity_values = static_cast<int>(velocities.size());
  s.n_gradient_values = static_cast<int>(gradients.size());
  s.velocity = velocities;
  s.velocity_gradient = gradients;
  s.n_pressure_gradient_values = static_cast<int>(pressure_gradients.size());
  s.pressure_gradient = pressure_gradients;
  s.n_viscous_values = static_cast<int>(viscous_forces.size());
  s.viscous_force = viscous_forces;
  set_state(s);
}

}  // namespace hemo::particles
