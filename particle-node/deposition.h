// From particles to per-cell feedback for the fluid (particle_feedback_t):
//
//   solid fraction   phi_c = (particle volume deposited in c) / V_c
//   drag coefficient K_c   = (sum of dJ/du)_c / (V_c dt)               (dt the interval)
//   explicit source  S_c   = -<sum of F>_c / V_c + K_c u_c             (interval mean)
//
// where <.> is the mean over the coupling interval of what was applied at each DEM step, u_c the
// cell velocity of the fluid state the particles saw and dJ/du a particle's drag response, how
// its interval impulse changes with that velocity (scene coupling.implicit_drag: the exact
// m (1 - exp(-B/m)) of closures/exponential_drag.h, or B, B the interval's integral of beta dt).
// The fluid uses S - K u = source_explicit - drag_coefficient u, which at u = u_c is exactly
// -<sum F>_c / V_c: the fluid gets back every newton the particles got, cell by cell.
//
// How a particle is shared among cells is a SolidFractionModel (scene coupling.solid_fraction;
// solid_fraction.h; for cells narrower than the particles, "gaussian_kernel", gaussian_kernel.h).
// Its volume, its interval impulse (the integral of F dt) and its drag response are all
// shared with the same fractions, so the identity above holds cell by cell whatever the model,
// and sum_c phi_c V_c = sum_p V_p exactly.
//
//   "centre_cell"     everything to the cell holding the centre. phi jumps by V_p / V_c when
//                     the centre crosses a face.
//   "sphere_overlap"  (default) the sphere is shared with the cells it reaches: from the centre's
//                     cell across every face whose plane cuts the sphere, and on from those
//                     (across a cyclic face to the periodic partner). Each such cell gets the
//                     product, over its own faces that are not walls, of the part of the sphere
//                     on its side of the face's plane (1 minus the spherical cap h^2 (3r - h) /
//                     (4 r^3) beyond it, h the cap height), and the products are normalised to
//                     sum to 1. Exact for a sphere cutting one face, the tensor product of the 1-D
//                     splits near edges and corners of a box mesh, and continuous in the particle
//                     position (on the calibration O-grid at most 0.0033 per 0.01 um of travel):
//                     a cell's product depends on the position and that cell's own planes only,
//                     whichever cell holds the centre, and is 0 where the cell enters the set
//                     across a shared plane (a centre on a face shares
//                     1/2 - 1/2). Nothing goes behind a wall: that part stays with the cells along it.
//                     (Sharing by the centre cell's planes alone jumped by up to a quarter of a
//                     particle when its centre crossed a face of the O-grid, whose neighbouring
//                     cells' planes are not parallel; d(alpha)/dt turned each jump into a kick
//                     of the plasma of jump / interval: tests/particles/test_deposition_vessel.cpp.)
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "fluid_sampler.h"
#include "solid_fraction.h"

#include <vec.h>
#include <hemo/particle_feedback_t.hpp>

#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace hemo::particles {

class CentreCellFraction final : public SolidFractionModel {
 public:
  static constexpr std::string_view kName = "centre_cell";
  std::string name() const override { return std::string(kName); }
  using SolidFractionModel::share;
  void share(int cell, const Vec3&, double, std::vector<CellShare>& out) const override { out.assign(1, {cell, 1.0}); }
};

class SphereOverlapFraction final : public SolidFractionModel {
 public:
  explicit SphereOverlapFraction(const CellLocator& locator) : locator_(&locator) {}
  static constexpr std::string_view kName = "sphere_overlap";
  std::string name() const override { return std::string(kName); }
  using SolidFractionModel::share;
  void share(int cell, const Vec3& x, double radius, std::vector<CellShare>& out) const override;

 private:
  const CellLocator* locator_;
};

// The model of that name (model/solid_fraction_names.h; "gaussian_kernel" with the kernel's width
// in particle diameters, coupling.kernel_width_diameters); throws std::invalid_argument otherwise.
std::unique_ptr<SolidFractionModel> make_solid_fraction_model(const std::string& name, const CellLocator& locator,
                                                              double kernel_width_diameters = 1.0);

class Deposition {
 public:
  explicit Deposition(const CellLocator& locator,
                      std::unique_ptr<SolidFractionModel> model = std::make_unique<CentreCellFraction>());

  // Forgets everything deposited (start of a deposition).
  void clear();
  // Start of a coupling interval: forget the drag accumulated so far (volumes stay).
  void clear_drag();
  // Before re-depositing volumes at the current positions (drag stays).
  void clear_volume();

  // One particle of radius r (m) centred at x (wrapped) in `cell`: its volume (m^3), and over
  // the interval the integral of its fluid force (N s) and its drag response dJ/du (kg), shared
  // among cells with the model's fractions; of a particle straddling an open end, the share
  // `inside` of each (SolidFractionModel::inside_share; x may then lie past the end, `cell` the
  // one it reads the plasma in).
  void add_particle(int cell, const Vec3& x, double radius, double volume, const Vec3& impulse, double drag_response,
                    double inside = 1.0) {
    model_->share(cell, x, radius, shares_);
    for (const CellShare& share : shares_) {
      double* a = &acc_[static_cast<std::size_t>(share.cell) * kStride];
      const double w = share.fraction * inside;
      a[0] += w * impulse.x();
      a[1] += w * impulse.y();
      a[2] += w * impulse.z();
      a[3] += w * drag_response;
      a[kVolume] += w * volume;
    }
  }
  // A force F (N, on the particle) with coefficient beta (N s/m) held for `duration` s (drag
  // response beta duration), all in `cell`.
  void add_drag(int cell, const Vec3& force, double beta, double duration) {
    add_particle(cell, locator_->centre(cell), 0.0, 0.0, force * duration, beta * duration);
  }

  // Raw accumulators (n_cells x kStride doubles) for summing across MPI ranks in place.
  double* data() { return acc_.data(); }
  const double* data() const { return acc_.data(); }
  int size() const { return static_cast<int>(acc_.size()); }

  // Fills the per-cell arrays and total_particle_force of `out` for an interval of length
  // `interval` (s); `fluid` gives the cell velocities the particles saw (nullptr or no state:
  // zero). mesh_hash and the envelope are left to the caller.
  void finish(double interval, const FluidSampler* fluid, particle_feedback_t& out) const;

  // Interval-mean sum of the forces on all particles (N).
  Vec3 total_force(double interval) const;

  // Sum over cells of the deposited solid volume (m^3).
  double total_volume() const;
  // The solid volume deposited in one cell (m^3).
  double solid_volume(int cell) const { return acc_[static_cast<std::size_t>(cell) * kStride + kVolume]; }

  const SolidFractionModel& model() const { return *model_; }

  static constexpr int kStride = 5;  // F dt (3), drag response, solid volume
  static constexpr int kVolume = 4;

 private:
  const CellLocator* locator_;
  std::unique_ptr<SolidFractionModel> model_;
  std::vector<double> acc_;
  std::vector<CellShare> shares_;  // add_particle's, kept to spare an allocation per particle
};

}  // namespace hemo::particles
