// SPDX-License-Identifier: GPL-3.0-or-later
#include "deposition.h"

namespace hemo::particles {

Deposition::Deposition(const CellLocator& locator, std::unique_ptr<SolidFractionModel> model)
    : locator_(&locator), model_(std::move(model)), acc_(static_cast<std::size_t>(locator.n_cells()) * kStride, 0.0) {}

void Deposition::clear_drag() {
  for (std::size_t i = 0; i < acc_.size(); i += kStride)
    for (int k = 0; k < 4; ++k) acc_[i + k] = 0.0;
}

void Deposition::clear_volume() {
  for (std::size_t i = kVolume; i < acc_.size(); i += kStride) acc_[i] = 0.0;
}

void Deposition::finish(double interval, const FluidSampler* fluid, particle_feedback_t& out) const {
  const int n = locator_->n_cells();
  const double inv_t = interval > 0 ? 1.0 / interval : 0.0;
  const bool have_u = fluid != nullptr && fluid->has_state();
  out.n_cells = n;
  out.solid_fraction.assign(n, 0.0);
  out.source_explicit.assign(n, std::vector<double>(3, 0.0));
  out.drag_coefficient.assign(n, 0.0);
  Vec3 total = Vec3::Zero();
  for (int c = 0; c < n; ++c) {
    const double* a = &acc_[static_cast<std::size_t>(c) * kStride];
    const double v = locator_->volume(c);
    const Vec3 force(a[0] * inv_t, a[1] * inv_t, a[2] * inv_t);  // interval mean, N
    const double k = a[3] * inv_t / v;                           // N s/m^4
    const Vec3 u = have_u ? fluid->cell_velocity(c) : Vec3::Zero();
    const Vec3 s = -force / v + k * u;
    out.solid_fraction[c] = a[kVolume] / v;
    out.drag_coefficient[c] = k;
    for (int d = 0; d < 3; ++d) out.source_explicit[c][d] = s[d];
    total += force;
  }
  for (int d = 0; d < 3; ++d) out.total_particle_force[d] = total[d];
}

Vec3 Deposition::total_force(double interval) const {
  // The same arithmetic as finish(), so that both give the same bits.
  Vec3 total = Vec3::Zero();
  if (!(interval > 0)) return total;
  const double inv_t = 1.0 / interval;
  for (std::size_t i = 0; i < acc_.size(); i += kStride)
    total += Vec3(acc_[i] * inv_t, acc_[i + 1] * inv_t, acc_[i + 2] * inv_t);
  return total;
}

double Deposition::total_volume() const {
  double v = 0;
  for (std::size_t i = kVolume; i < acc_.size(); i += kStride) v += acc_[i];
  return v;
}

}  // namespace hemo::particles
