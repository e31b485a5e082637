// SPDX-License-Identifier: GPL-3.0-or-later
#include "deposition.h"

#include "cell_fields.h"
#include "gaussian_kernel.h"

#include <solid_fraction_names.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string_view>

namespace hemo::particles {

namespace {
// The fraction of a sphere of radius r beyond a plane at signed distance d of its centre
// (d < 0: the centre on the near side): the cap h^2 (3r - h) / (4 r^3), h = r + d.
double cap_beyond(double d, double r) {
  if (d <= -r) return 0.0;
  if (d >= r) return 1.0;
  const double h = r + d;
  return h * h * (3 * r - h) / (4 * r * r * r);
}
}  // namespace

double sphere_inside_share(double beyond, double radius) { return 1 - cap_beyond(beyond, radius); }

void SphereOverlapFraction::share(int cell, const Vec3& x, double radius, std::vector<CellShare>& out) const {
  out.assign(1, {cell, 1.0});
  if (!(radius > 0)) return;
  // The cells the sphere reaches: from the centre's cell across every face whose plane cuts
  // the sphere, and on from there (across a cyclic face with the centre moved by the period).
  // Each gets the product over its own non-wall faces of the part of the sphere on its side,
  // and the products are normalised. A cell's product depends only on the position and that
  // cell, and is 0 when it enters or leaves the set (the sphere then touches their shared
  // plane from outside), so the shares are continuous whichever cell holds the centre.
  // Each cell's product is kept in its own fraction until all are known (no vector of weights:
  // this runs for every particle every coupling step).
  double total = 0;
  for (std::size_t k = 0; k < out.size(); ++k) {
    const int c = out[k].cell;
    const Vec3 xc(x.x(), x.y(), x.z() + out[k].dz);
    const double dz = out[k].dz;
    double w = 1;
    locator_->for_each_face_kind(c, xc, [&](double d, int beyond, const Vec3& normal, bool wall, bool cyclic) {
      if (wall) return;  // what is behind a wall stays with the cells along it
      w *= 1 - cap_beyond(d, radius);
      if (d <= -radius || beyond < 0) return;
      for (const CellShare& s : out)
        if (s.cell == beyond) return;
      out.push_back({beyond, 0.0, cyclic ? dz - std::copysign(locator_->length(), normal.z()) : dz});
    });
    out[k].fraction = w;
    total += w;
  }
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k].fraction = total > 0 ? out[k].fraction / total : (k == 0 ? 1.0 : 0.0);
  // Cells that get nothing (reached across a plane the sphere only touches) are dropped.
  std::size_t kept = 1;
  for (std::size_t k = 1; k < out.size(); ++k)
    if (out[k].fraction > 0) out[kept++] = out[k];
  out.resize(kept);
}

namespace {

// Every model by name, in model/solid_fraction_names.h's order (the scene validates names against
// that list, which cannot read this table: the build stops here when the two differ).
using Factory = std::unique_ptr<SolidFractionModel> (*)(const CellLocator&, double);
struct Entry {
  std::string_view name;
  Factory make;
};
constexpr Entry kModels[] = {
    {CentreCellFraction::kName, [](const CellLocator&, double) -> std::unique_ptr<SolidFractionModel> {
       return std::make_unique<CentreCellFraction>();
     }},
    {GaussianKernelFraction::kName, [](const CellLocator& l, double width) -> std::unique_ptr<SolidFractionModel> {
       return std::make_unique<GaussianKernelFraction>(l, width);
     }},
    {SphereOverlapFraction::kName, [](const CellLocator& l, double) -> std::unique_ptr<SolidFractionModel> {
       return std::make_unique<SphereOverlapFraction>(l);
     }},
};

constexpr bool same_names() {
  if (std::size(kModels) != kSolidFractionNames.size()) return false;
  for (std::size_t i = 0; i < std::size(kModels); ++i)
    if (kModels[i].name != kSolidFractionNames[i]) return false;
  return true;
}
static_assert(same_names(), "deposition.cpp's kModels and model/solid_fraction_names.h's kSolidFractionNames differ");

}  // namespace

std::unique_ptr<SolidFractionModel> make_solid_fraction_model(const std::string& name, const CellLocator& locator,
                                                              double kernel_width_diameters) {
  for (const Entry& e : kModels)
    if (e.name == name) return e.make(locator, kernel_width_diameters);
  std::string known;
  for (const Entry& e : kModels) known += (known.empty() ? "" : ", ") + std::string(e.name);
  throw std::invalid_argument("unknown solid fraction model '" + name + "' (known: " + known + ")");
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
