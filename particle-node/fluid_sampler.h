// The plasma as a particle sees it: cell velocity plus the cell's gradient times the offset
// from the cell centre (exact for a linear field), and the local shear rate.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "vec.h"

#include <hemo/fluid_state_t.hpp>

#include <string>
#include <vector>

namespace hemo::particles {

class FluidSampler {
 public:
  explicit FluidSampler(const CellLocator& locator) : locator_(&locator) {}

  // Takes a copy of the fluid state's per-cell fields. Throws std::invalid_argument when the
  // state does not fit the mesh or holds a non-finite value (the message names the cause).
  void set_state(const fluid_state_t& state);
  bool has_state() const { return !velocity_.empty(); }
  // The per-cell fields it holds, as set_state takes them (checkpoints keep them this way).
  std::vector<double> cell_velocities() const;  // 3 per cell
  std::vector<double> cell_gradients() const;   // 9 per cell, row-major G[i][j]
  // set_state from those fields (sizes checked); throws std::invalid_argument.
  void set_state(const std::vector<double>& velocities, const std::vector<double>& gradients);

  // Checks a fluid state against the mesh without keeping it: empty string when fine, else a
  // one-line reason (wrong mesh hash, wrong cell count or array length, non-finite value in cell i).
  static std::string check(const fluid_state_t& state, int n_cells, const std::string& mesh_hash);

  // u(x) = u_c + G^T (x - x_c), with G[i][j] = d u_j / d x_i; x already wrapped into the
  // period of the mesh (CellLocator::wrap) and inside `cell`.
  Vec3 velocity(int cell, const Vec3& x) const {
    return velocity_[cell] + gradient_[cell].transpose() * (x - locator_->centre(cell));
  }
  const Vec3& cell_velocity(int cell) const { return velocity_[cell]; }
  // G[i][j] = d u_j / d x_i
  const Mat3& gradient(int cell) const { return gradient_[cell]; }
  // gamma_dot = sqrt(2 S:S), S = (G + G^T)/2
  double shear_rate(int cell) const { return shear_rate_[cell]; }
  // The largest cell speed |u_c| of the state (the closures' centre-line speed u_max).
  double max_cell_speed() const { return max_speed_; }

  const CellLocator& locator() const { return *locator_; }

 private:
  const CellLocator* locator_;
  std::vector<Vec3> velocity_;
  std::vector<Mat3> gradient_;
  std::vector<double> shear_rate_;
  double max_speed_ = 0;
};

}  // namespace hemo::particles
