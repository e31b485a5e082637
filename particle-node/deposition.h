// From particles to per-cell feedback for the fluid (particle_feedback_t):
//
//   solid fraction   phi_c = (particle volume deposited in c) / V_c
//   drag coefficient K_c   = <sum of beta>_c / V_c                   (interval mean)
//   explicit source  S_c   = -<sum of F>_c / V_c + K_c u_c             (interval mean)
//
// where <.> is the mean over the coupling interval of what was applied at each DEM step and
// u_c the cell velocity of the fluid state the particles saw. The fluid uses
// S - K u = source_explicit - drag_coefficient u, which at u = u_c is exactly
// -<sum F>_c / V_c: the fluid gets back every newton the particles got, cell by cell.
//
// How a particle's volume spreads over cells is a SolidFractionModel; the default puts the whole
// volume into the cell holding the centre. Smoother kernels can be added beside it.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "fluid_sampler.h"
#include "vec.h"

#include <hemo/particle_feedback_t.hpp>

#include <memory>
#include <string>
#include <vector>

namespace hemo::particles {

class SolidFractionModel {
 public:
  virtual ~SolidFractionModel() = default;
  virtual std::string name() const = 0;
  // Adds the particle's volume (m^3) to solid[c] of the cells it covers; `cell` holds x.
  virtual void deposit(int cell, const Vec3& x, double volume, double* solid, int stride) const = 0;
};

// The whole particle volume goes to the cell that holds its centre.
class CentreCellFraction final : public SolidFractionModel {
 public:
  std::string name() const override { return "centre_cell"; }
  void deposit(int cell, const Vec3&, double volume, double* solid, int stride) const override {
    solid[static_cast<long>(cell) * stride] += volume;
  }
};

class Deposition {
 public:
  explicit Deposition(const CellLocator& locator,
                      std::unique_ptr<SolidFractionModel> model = std::make_unique<CentreCellFraction>());

  // Start of a coupling interval: forget the drag accumulated so far.
  void clear_drag();
  // Before re-depositing volumes at the current positions.
  void clear_volume();

  // A force F (N, on the particle, from the fluid) with coefficient beta (N s/m) applied for
  // `duration` seconds to a particle in `cell`.
  void add_drag(int cell, const Vec3& force, double beta, double duration) {
    double* a = &acc_[static_cast<std::size_t>(cell) * kStride];
    a[0] += force.x() * duration;
    a[1] += force.y() * duration;
    a[2] += force.z() * duration;
    a[3] += beta * duration;
  }
  // A particle of volume (m^3) with its centre x in `cell`.
  void add_volume(int cell, const Vec3& x, double volume) {
    model_->deposit(cell, x, volume, &acc_[kVolume], kStride);
  }

  // Raw accumulators (n_cells x kStride doubles) for summing across MPI ranks in place.
  double* data() { return acc_.data(); }
  int size() const { return static_cast<int>(acc_.size()); }

  // Fills the per-cell arrays and total_particle_force of `out` for an interval of length
  // `interval` (s); `fluid` gives the cell velocities the particles saw (nullptr or no state:
  // zero). mesh_hash and the envelope are left to the caller.
  void finish(double interval, const FluidSampler* fluid, particle_feedback_t& out) const;

  // Interval-mean sum of the forces on all particles (N).
  Vec3 total_force(double interval) const;

  // Sum over cells of the deposited solid volume (m^3).
  double total_volume() const;

  static constexpr int kStride = 5;  // F dt (3), beta dt, solid volume
  static constexpr int kVolume = 4;

 private:
  const CellLocator* locator_;
  std::unique_ptr<SolidFractionModel> model_;
  std::vector<double> acc_;
};

}  // namespace hemo::particles
