// "gaussian_kernel" (scene coupling.solid_fraction): a particle shared over a Gaussian kernel whose
// width is set by the particle, not by the fluid cells, so that cells narrower than a particle
// can carry it (unresolved CFD-DEM with particles comparable to or larger than the cells).
//
// The reading is Capecelatro & Desjardins's (2013, J. Comput. Phys. 238, 1-31) volume filter: a
// particle's volume and momentum exchange are spread by a Gaussian of full width at half maximum
// delta_f around its centre. Here delta_f = coupling.kernel_width_diameters times the particle's
// volume-equivalent diameter (model/solid_fraction_names.h), and the filter is
//
//   w_c = V_c (exp(-|x_c - x|^2 / (2 sigma^2)) - exp(-9/2))   for |x_c - x| < 3 sigma, else 0,
//   fraction_c = w_c / sum w,           sigma = delta_f / (2 sqrt(2 ln 2)),
//
// the Gaussian evaluated at each cell's centre x_c (the midpoint rule over the cell), cut at
// three sigma and lowered to vanish there (ours: a cell enters and leaves the set with nothing,
// so the fractions are continuous in x), and normalised over the cells it reaches, which makes
// sum_c phi_c V_c = V_p to round-off whatever the cells.
//
// The cells reached: from the particle's cell across every face whose plane is within 3 sigma of
// x, and on from those; across a cyclic face to the periodic partner (x seen one period away),
// never across a wall or an open end. So nothing is deposited behind a wall: the part of the
// Gaussian there goes, by the normalisation, to the cells inside (what a diffusion with no flux
// through the wall does in Sun & Xiao's (2015, Int. J. Multiphase Flow 72) coarse graining, in
// one step). The fractions are continuous in x except where the ball of 3 sigma first reaches
// round a wall's edge to cells whose centres it already holds (a bifurcation's carina tip).
//
// At an open end nothing is renormalised: the share of the kernel on the inside of the end's plane
// (inside_share: the continuous kernel's mass there) is what the vessel's cells take of a cell
// straddling it, the fractions spreading that share as they spread a whole particle.
//
// The same fractions read the fluid the particle sees (FluidSampler::seen): the kernel's mean of
// each cell's reconstruction at x (exact for a linear field), of the cells' gradients, pressure
// gradients and viscous forces, so that a particle's drag is not the value of a cell it mostly
// fills.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "solid_fraction.h"

#include <solid_fraction_names.h>

#include <string>
#include <string_view>
#include <vector>

namespace hemo::particles {

class GaussianKernelFraction final : public SolidFractionModel {
 public:
  // width_diameters: delta_f over the particle's diameter (> 0).
  GaussianKernelFraction(const CellLocator& locator, double width_diameters);
  static constexpr std::string_view kName = "gaussian_kernel";
  std::string name() const override { return std::string(kName); }
  using SolidFractionModel::share;
  void share(int cell, const Vec3& x, double radius, std::vector<CellShare>& out) const override;
  bool samples_over_shares() const override { return true; }
  double reach(double radius) const override { return kernel_reach(width_, 2 * radius); }
  double sigma(double radius) const { return kernel_sigma(width_, 2 * radius); }
  // The kernel's mass on the inside of an open end's plane (not renormalised: the rest is the
  // plasma's beyond the end), of the continuous kernel the cells sample.
  double inside_share(double beyond, double radius) const override;

 private:
  const CellLocator* locator_;
  double width_;
  // Which cells this search has queued: stamp_[c] == visit_ (one pass over the cells' flags per
  // particle would cost more than the search).
  mutable std::vector<unsigned> stamp_;
  mutable unsigned visit_ = 0;
};

}  // namespace hemo::particles
