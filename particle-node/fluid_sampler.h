// The plasma as a particle sees it: cell velocity plus the cell's gradient times the offset
// from the cell centre (exact for a linear field), or the cell's value alone (CFDEM's default;
// coupling.fluid_velocity), the local shear rate, and the pressure gradient and viscous force
// per volume when the fluid sends them (the momentum forms that put F_p, F_v on the particles).
// With a solid-fraction model that samples over its shares (gaussian_kernel.h), a particle sees
// the means of those over the cells it is shared with (seen()).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "solid_fraction.h"

#include <scene_choices.h>
#include <vec.h>
#include <hemo/fluid_state_t.hpp>

#include <string>
#include <utility>
#include <vector>

namespace hemo::particles {

class FluidSampler {
 public:
  // How velocity(cell, x) reads the plasma at x (scene key coupling.fluid_velocity).
  using Sampling = FluidVelocity;
  explicit FluidSampler(const CellLocator& locator, Sampling sampling = Sampling::reconstructed)
      : locator_(&locator), sampling_(sampling) {}

  // Takes a copy of the fluid state's per-cell fields. Throws std::invalid_argument when the
  // state does not fit the mesh or holds a non-finite value (the message names the cause).
  void set_state(const fluid_state_t& state);
  bool has_state() const { return !velocity_.empty(); }
  // The per-cell fields it holds, as set_state takes them (checkpoints keep them this way).
  std::vector<double> cell_velocities() const;  // 3 per cell
  std::vector<double> cell_gradients() const;   // 9 per cell, row-major G[i][j]
  // set_state from those fields (sizes checked; no pressure gradient or viscous force: an empty
  // vector); throws std::invalid_argument.
  void set_state(const std::vector<double>& velocities, const std::vector<double>& gradients,
                 const std::vector<double>& pressure_gradients = {}, const std::vector<double>& viscous_forces = {});

  // Checks a fluid state against the mesh without keeping it: empty string when fine, else a
  // one-line reason (wrong mesh hash, wrong cell count or array length, non-finite value in cell i).
  static std::string check(const fluid_state_t& state, int n_cells, const std::string& mesh_hash);

  // u(x) = u_c + G^T (x - x_c), with G[i][j] = d u_j / d x_i; x already wrapped into the
  // period of the mesh (CellLocator::wrap) and inside `cell`. Sampling::cell: u_c.
  Vec3 velocity(int cell, const Vec3& x) const {
    if (sampling_ == Sampling::cell) return velocity_[cell];
    return velocity_[cell] + gradient_[cell].transpose() * (x - locator_->centre(cell));
  }
  const Vec3& cell_velocity(int cell) const { return velocity_[cell]; }
  // G[i][j] = d u_j / d x_i
  const Mat3& gradient(int cell) const { return gradient_[cell]; }
  // gamma_dot = sqrt(2 S:S), S = (G + G^T)/2
  double shear_rate(int cell) const { return shear_rate_[cell]; }
  // grad P of the cell, Pa/m, the imposed mean drop included; only when the state carried it.
  bool has_pressure_gradient() const { return !pressure_gradient_.empty(); }
  const Vec3& pressure_gradient(int cell) const { return pressure_gradient_[cell]; }
  std::vector<double> cell_pressure_gradients() const;  // 3 per cell, or none
  // div tau of the cell, N/m^3 (mu lap u with the fluid's discrete Laplacian); only when the
  // state carried it.
  bool has_viscous_force() const { return !viscous_force_.empty(); }
  const Vec3& viscous_force(int cell) const { return viscous_force_[cell]; }
  std::vector<double> cell_viscous_forces() const;  // 3 per cell, or none
  // The largest cell speed |u_c| of the state (the closures' centre-line speed u_max).
  double max_cell_speed() const { return max_speed_; }
  // A rank of the partitioned exchange holds its own cells only: the whole mesh's largest
  // speed is the ranks' largest (ParticleNode::advance), set here.
  void set_max_cell_speed(double speed) { max_speed_ = speed; }
  // The cells whose values this sampler holds (the partitioned exchange: a rank's needed(p) of
  // model/overlap_map.h; the others are zero): per cell, nonzero when held. Empty: all.
  void set_held(std::vector<char> held) { held_ = std::move(held); }
  bool holds(int cell) const { return held_.empty() || held_[static_cast<std::size_t>(cell)] != 0; }

  const CellLocator& locator() const { return *locator_; }

  // Read what a particle sees over the shares of `model` when it samples over them
  // (SolidFractionModel::samples_over_shares; nullptr or another model: at the particle's centre).
  // The model must outlive the sampler.
  void read_over(const SolidFractionModel* model) {
    kernel_ = model != nullptr && model->samples_over_shares() ? model : nullptr;
  }
  // What a particle of radius r centred at x (wrapped, in `cell`) sees: velocity(cell, x) and the
  // cell's values, or with read_over's model their means with its fractions: of the gradient, the
  // pressure gradient and viscous force when the state carries them, and of each cell's velocity
  // carried to x (as seen from that cell) by the mean of its own and the kernel's mean gradient,
  // u_c + (1/2) (G_c + G_mean)^T (x - x_c), exact for a linear field and for a quadratic one where
  // the cells' weighted centre is x (Sampling::cell: the mean of the u_c); the shear rate is the
  // mean gradient's. `gradient`: false leaves the gradient and shear rate zero.
  struct Seen {
    Vec3 velocity = Vec3::Zero();
    Mat3 gradient = Mat3::Zero();
    double shear_rate = 0;
    Vec3 pressure_gradient = Vec3::Zero();  // when has_pressure_gradient()
    Vec3 viscous_force = Vec3::Zero();      // when has_viscous_force()
  };
  Seen seen(int cell, const Vec3& x, double radius, bool gradient) const;

 private:
  const CellLocator* locator_;
  Sampling sampling_;
  std::vector<Vec3> velocity_;
  std::vector<Vec3> pressure_gradient_;  // Pa/m, or empty
  std::vector<Vec3> viscous_force_;      // N/m^3, or empty
  std::vector<Mat3> gradient_;
  std::vector<double> shear_rate_;
  double max_speed_ = 0;
  std::vector<char> held_;
  const SolidFractionModel* kernel_ = nullptr;
  mutable std::vector<CellShare> shares_;  // seen()'s, kept to spare an allocation per particle
};

}  // namespace hemo::particles
