// A uniform bin grid over the vessel's bounding box [-R, R]^2 x [z0, z0 + L), periodic in z,
// for neighbour searches among spheres (placement, overlap checks).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "vec.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace hemo::particles {

class SpatialHash {
 public:
  // `reach`: the largest centre distance that a query must see.
  SpatialHash(double radius, double length, double z0, double reach) : r_(radius), z0_(z0) {
    nxy_ = std::max(1, static_cast<int>(std::floor(2 * radius / reach)));
    nz_ = std::max(1, static_cast<int>(std::floor(length / reach)));
    hxy_ = 2 * radius / nxy_;
    hz_ = length / nz_;
    bins_.resize(static_cast<std::size_t>(nxy_) * nxy_ * nz_);
  }

  void insert(const Vec3& x, int id) { bins_[bin(ix(x.x()), ix(x.y()), iz(x.z()))].push_back(id); }

  // Calls f(id) for every entry in the bins around x (each bin once) until f returns true;
  // returns whether it did.
  template <class F>
  bool any_near(const Vec3& x, F&& f) const {
    const int i0 = ix(x.x()), j0 = ix(x.y()), k0 = iz(x.z());
    int ks[3], nk = 0;
    for (int dk = -1; dk <= 1; ++dk) {
      const int k = ((k0 + dk) % nz_ + nz_) % nz_;
      if (std::find(ks, ks + nk, k) == ks + nk) ks[nk++] = k;
    }
    for (int i = std::max(0, i0 - 1); i <= std::min(nxy_ - 1, i0 + 1); ++i)
      for (int j = std::max(0, j0 - 1); j <= std::min(nxy_ - 1, j0 + 1); ++j)
        for (int a = 0; a < nk; ++a)
          for (int id : bins_[bin(i, j, ks[a])])
            if (f(id)) return true;
    return false;
  }

 private:
  int ix(double v) const { return std::clamp(static_cast<int>(std::floor((v + r_) / hxy_)), 0, nxy_ - 1); }
  int iz(double z) const {
    const int k = static_cast<int>(std::floor((z - z0_) / hz_));
    return ((k % nz_) + nz_) % nz_;
  }
  std::size_t bin(int i, int j, int k) const { return (static_cast<std::size_t>(k) * nxy_ + j) * nxy_ + i; }

  double r_, z0_, hxy_, hz_;
  int nxy_, nz_;
  std::vector<std::vector<int>> bins_;
};

}  // namespace hemo::particles
