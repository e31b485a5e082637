// The per-cell vector and tensor fields of fluid_state_t and particle_feedback_t are flat
// arrays: k values per cell (3 for a vector, 9 for a row-major tensor), cell c's at
// [k c, k c + k), the array's length in its own field (LCM decodes a [n_cells][k] array as
// one heap vector per cell). These size the arrays together with their length fields, point
// at one cell's values, and check the lengths of a received message.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <hemo/fluid_state_t.hpp>
#include <hemo/particle_feedback_t.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace hemo {

inline constexpr int kVectorValues = 3;  // per cell: x, y, z
inline constexpr int kTensorValues = 9;  // per cell: G[0][0], G[0][1], ..., G[2][2]

// n_cells, the length fields and every per-cell array for n cells, all values zero (the
// pressure gradient and the viscous force only when asked for: they are optional).
inline void resize_cells(fluid_state_t& s, int n, bool pressure_gradient = false, bool viscous_force = false) {
  s.n_cells = n;
  s.n_velocity_values = kVectorValues * n;
  s.n_gradient_values = kTensorValues * n;
  s.n_pressure_gradient_values = pressure_gradient ? kVectorValues * n : 0;
  s.n_viscous_values = viscous_force ? kVectorValues * n : 0;
  s.velocity.assign(static_cast<std::size_t>(s.n_velocity_values), 0.0);
  s.velocity_gradient.assign(static_cast<std::size_t>(s.n_gradient_values), 0.0);
  s.pressure_gradient.assign(static_cast<std::size_t>(s.n_pressure_gradient_values), 0.0);
  s.viscous_force.assign(static_cast<std::size_t>(s.n_viscous_values), 0.0);
}
inline void resize_cells(particle_feedback_t& fb, int n) {
  fb.n_cells = n;
  fb.n_source_values = kVectorValues * n;
  fb.solid_fraction.assign(static_cast<std::size_t>(n), 0.0);
  fb.source_explicit.assign(static_cast<std::size_t>(fb.n_source_values), 0.0);
  fb.drag_coefficient.assign(static_cast<std::size_t>(n), 0.0);
}

// Cell c's values: 3 of the velocity [m/s] and explicit source [N/m^3], 9 of the gradient [1/s].
inline const double* velocity_of(const fluid_state_t& s, std::size_t c) {
  return s.velocity.data() + kVectorValues * c;
}
inline double* velocity_of(fluid_state_t& s, std::size_t c) { return s.velocity.data() + kVectorValues * c; }
inline const double* gradient_of(const fluid_state_t& s, std::size_t c) {
  return s.velocity_gradient.data() + kTensorValues * c;
}
inline double* gradient_of(fluid_state_t& s, std::size_t c) { return s.velocity_gradient.data() + kTensorValues * c; }
inline const double* pressure_gradient_of(const fluid_state_t& s, std::size_t c) {
  return s.pressure_gradient.data() + kVectorValues * c;
}
inline double* pressure_gradient_of(fluid_state_t& s, std::size_t c) {
  return s.pressure_gradient.data() + kVectorValues * c;
}
inline const double* viscous_force_of(const fluid_state_t& s, std::size_t c) {
  return s.viscous_force.data() + kVectorValues * c;
}
inline double* viscous_force_of(fluid_state_t& s, std::size_t c) { return s.viscous_force.data() + kVectorValues * c; }
inline const double* source_of(const particle_feedback_t& fb, std::size_t c) {
  return fb.source_explicit.data() + kVectorValues * c;
}
inline double* source_of(particle_feedback_t& fb, std::size_t c) {
  return fb.source_explicit.data() + kVectorValues * c;
}

// Empty when a flat field's length field and array both hold `per_cell` values for each of
// n_cells cells; else one line, e.g. "velocity has 4605 values, not 3 per cell of 1536 cells".
inline std::string flat_size_problem(const char* field, std::int32_t length, const std::vector<double>& values,
                                     int per_cell, int n_cells) {
  const long want = static_cast<long>(per_cell) * n_cells;
  if (length == want && static_cast<long>(values.size()) == want) return {};
  const long have = length != want ? length : static_cast<long>(values.size());
  return std::string(field) + " has " + std::to_string(have) + " values, not " + std::to_string(per_cell) +
         " per cell of " + std::to_string(n_cells) + " cells";
}

}  // namespace hemo
