// SPDX-License-Identifier: GPL-3.0-or-later
#include "deposition.h"

#include "cell_fields.h"

#include <algorithm>

#include <stdexcept>

namespace hemo::particles {

int SphereOverlapFraction::share(int cell, const Vec3& x, double radius, CellShare* out) const {
  out[0] = {cell, 1.0};
  if (!(radius > 0)) return 1;
  // The faces whose plane cuts the sphere, grouped into directions.
  struct Cut {
    double fraction;
    int beyond;
    Vec3 normal;
  };
  struct Direction {
    Cut side[2];
    int n = 0;
  };
  constexpr int kMaxDirections = 6;
  Direction dirs[kMaxDirections];
  int n_dirs = 0;
  const double inv_r3 = 1 / (4 * radius * radius * radius);
  locator_->for_each_face(cell, x, [&](double signed_distance, int beyond, const Vec3& normal) {
    const double inside = std::max(0.0, -signed_distance);
    if (inside >= radius) return;
    const double h = radius - inside;  // cap height beyond the plane
    const Cut cut{h * h * (3 * radius - h) * inv_r3, beyond, normal};
    for (int k = 0; k < n_dirs; ++k)
      if (dirs[k].n == 1 && dirs[k].side[0].normal.dot(normal) < -0.5) {
        dirs[k].side[dirs[k].n++] = cut;
        return;
      }
    if (n_dirs == kMaxDirections) return;  // more cut faces than a cell of ours has: keep them
    Direction& d = dirs[n_dirs++];
    d.side[0] = cut;
    d.n = 1;
  });
  if (n_dirs == 0) return 1;
  // Opposite caps cannot overlap, but keep each direction's split a distribution.
  for (int k = 0; k < n_dirs; ++k) {
    const double total = dirs[k].side[0].fraction + (dirs[k].n > 1 ? dirs[k].side[1].fraction : 0);
    if (total > 1)
      for (int j = 0; j < dirs[k].n; ++j) dirs[k].side[j].fraction /= total;
  }
  // Every combination of (stay, cross side 0, cross side 1) over the directions.
  int n = 0;
  int choice[kMaxDirections] = {0};
  while (true) {
    double w = 1;
    int target = cell;
    for (int k = 0; k < n_dirs && w > 0; ++k) {
      const Direction& d = dirs[k];
      if (choice[k] == 0) {
        w *= 1 - d.side[0].fraction - (d.n > 1 ? d.side[1].fraction : 0);
        continue;
      }
      const Cut& c = d.side[choice[k] - 1];
      w *= c.fraction;
      // From the centre's cell straight across the face; from a neighbour, across its face
      // that looks the same way. Behind a wall: stay.
      const int next = target == cell ? c.beyond : locator_->cell_toward(target, c.normal);
      if (next >= 0) target = next;
    }
    if (w > 0) {
      int k = 0;
      while (k < n && out[k].cell != target) ++k;
      if (k < n)
        out[k].fraction += w;
      else if (n < kMaxShares)
        out[n++] = {target, w};
      else
        out[0].fraction += w;  // no room: the centre's cell keeps it
    }
    int k = 0;  // next combination
    while (k < n_dirs && ++choice[k] > dirs[k].n) choice[k++] = 0;
    if (k == n_dirs) break;
  }
  if (n == 0 || out[0].cell != cell) {  // keep the documented order: the centre's cell first
    int k = 0;
    while (k < n && out[k].cell != cell) ++k;
    if (k == n && n < kMaxShares) out[n++] = {cell, 0.0};
    if (k < n) std::swap(out[0], out[k]);
  }
  return n;
}

std::unique_ptr<SolidFractionModel> make_solid_fraction_model(const std::string& name, const CellLocator& locator) {
  if (name == "centre_cell") return std::make_unique<CentreCellFraction>();
  if (name == "sphere_overlap") return std::make_unique<SphereOverlapFraction>(locator);
  throw std::invalid_argument("unknown solid fraction model '" + name + "' (known: centre_cell, sphere_overlap)");
}

Deposition::Deposition(const CellLocator& locator, std::unique_ptr<SolidFractionModel> model)
    : locator_(&locator), model_(std::move(model)), acc_(static_cast<std::size_t>(locator.n_cells()) * kStride, 0.0) {}

void Deposition::clear() { std::fill(acc_.begin(), acc_.end(), 0.0); }

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
  resize_cells(out, n);
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
    Eigen::Map<Vec3>(source_of(out, c)) = s;
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
