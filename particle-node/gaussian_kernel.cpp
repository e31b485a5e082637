// SPDX-License-Identifier: GPL-3.0-or-later
#include "gaussian_kernel.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hemo::particles {

GaussianKernelFraction::GaussianKernelFraction(const CellLocator& locator, double width_diameters)
    : locator_(&locator), width_(width_diameters), stamp_(static_cast<std::size_t>(locator.n_cells()), 0u) {
  if (!(width_diameters > 0))
    throw std::invalid_argument("the Gaussian kernel's width must be positive (coupling.kernel_width_diameters)");
}

void GaussianKernelFraction::share(int cell, const Vec3& x, double radius, std::vector<CellShare>& out) const {
  out.assign(1, {cell, 1.0});
  if (!(radius > 0)) return;  // a point force (Deposition::add_drag): its cell alone
  const double s = sigma(radius);
  const double reach = kKernelReachSigmas * s;
  const double reach2 = reach * reach;
  const double inv_2s2 = 1.0 / (2 * s * s);
  const double floor = std::exp(-reach2 * inv_2s2);
  if (++visit_ == 0) {  // the stamps wrapped round: start them again
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    visit_ = 1;
  }
  stamp_[cell] = visit_;
  double total = 0;
  for (std::size_t k = 0; k < out.size(); ++k) {
    const int c = out[k].cell;
    const double dz = out[k].dz;
    const Vec3 xc(x.x(), x.y(), x.z() + dz);
    const double r2 = (locator_->centre(c) - xc).squaredNorm();
    const double w = r2 < reach2 ? locator_->volume(c) * (std::exp(-r2 * inv_2s2) - floor) : 0.0;
    out[k].fraction = w;
    total += w;
    locator_->for_each_face_kind(c, xc, [&](double d, int beyond, const Vec3& normal, bool wall, bool cyclic) {
      if (wall || beyond < 0 || d <= -reach || stamp_[beyond] == visit_) return;
      stamp_[beyond] = visit_;
      out.push_back({beyond, 0.0, cyclic ? dz - std::copysign(locator_->length(), normal.z()) : dz});
    });
  }
  if (!(total > 0)) {  // no cell centre within reach (cells far wider than the kernel): the cell
    out.assign(1, {cell, 1.0});
    return;
  }
  // The particle's own cell stays first, whatever it gets; cells that get nothing are dropped.
  out[0].fraction /= total;
  std::size_t kept = 1;
  for (std::size_t k = 1; k < out.size(); ++k)
    if (out[k].fraction > 0) {
      out[kept] = out[k];
      out[kept++].fraction /= total;
    }
  out.resize(kept);
}

double GaussianKernelFraction::inside_share(double beyond, double radius) const {
  // The kernel (exp(-r^2 / 2 s^2) - f) over the ball of radius R = 3 s, f = exp(-R^2 / 2 s^2),
  // integrated over the slices t (along the plane's normal, from the centre) below the plane,
  // t < -beyond. A slice's integral over its disc of radius sqrt(R^2 - t^2) is
  // 2 pi [s^2 (exp(-t^2 / 2 s^2) - f) - f (R^2 - t^2) / 2], whose integral over t is G below.
  if (!(radius > 0)) return beyond > 0 ? 0.0 : 1.0;
  const double s = sigma(radius);
  const double reach = kKernelReachSigmas * s;
  if (beyond <= -reach) return 1.0;
  if (beyond >= reach) return 0.0;
  const double floor = std::exp(-0.5 * kKernelReachSigmas * kKernelReachSigmas);
  auto G = [&](double t) {
    return s * s * s * std::sqrt(M_PI / 2) * std::erf(t / (s * std::sqrt(2.0))) - floor * (s * s + 0.5 * reach * reach) * t +
           floor * t * t * t / 6;
  };
  return (G(-beyond) - G(-reach)) / (G(reach) - G(-reach));
}

}  // namespace hemo::particles
