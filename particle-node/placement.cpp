// SPDX-License-Identifier: GPL-3.0-or-later
#include "placement.h"

#include "spatial_hash.h"

#include <units.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>

namespace hemo::particles {

namespace {

double vessel_volume(const Scene& s) { return units::pi * s.vessel.radius() * s.vessel.radius() * s.vessel.length; }

const char* species_name(int species) { return species == kRbc ? "RBC" : "platelet"; }

// Uniform in [0, 1) from 53 random bits.
double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

}  // namespace

long rbc_count(const Scene& s) {
  if (!s.rbc.present || !(s.rbc.volume > 0)) return 0;
  return std::lround(s.rbc.hematocrit * vessel_volume(s) / s.rbc.volume);
}

long platelet_count(const Scene& s) {
  if (!s.platelet.present) return 0;
  return std::lround(s.platelet.number_density * vessel_volume(s));
}

std::vector<PlacementRequest> placement_requests(const Scene& s) {
  std::vector<PlacementRequest> r;
  if (long n = rbc_count(s); n > 0) r.push_back({kRbc, s.rbc.diameter, n});
  if (long n = platelet_count(s); n > 0) r.push_back({kPlatelet, s.platelet.diameter, n});
  return r;
}

std::vector<PlacedParticle> place_particles(double radius, double length, double z0,
                                            const std::vector<PlacementRequest>& requests,
                                            unsigned long long seed, const PlacementOptions& opt) {
  std::vector<PlacedParticle> placed;
  if (requests.empty()) return placed;
  if (!(radius > 0) || !(length > 0)) throw PlacementError("placement needs a vessel with positive radius and length");

  double d_max = 0;
  long total = 0;
  for (const auto& r : requests) {
    if (!(r.diameter > 0) || r.count < 0) throw PlacementError("placement: a species has no positive diameter");
    d_max = std::max(d_max, r.diameter);
    total += r.count;
  }
  placed.reserve(static_cast<std::size_t>(total));
  // Largest first: they are the hardest to fit.
  std::vector<std::size_t> order(requests.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return requests[a].diameter > requests[b].diameter; });

  SpatialHash grid(radius, length, z0, d_max * (1 + opt.gap_fraction));
  std::mt19937_64 rng(seed);
  double solid = 0;
  const double vessel = units::pi * radius * radius * length;

  for (std::size_t o : order) {
    const auto& req = requests[o];
    const double r_p = req.diameter / 2;
    const double r_max = radius - r_p - opt.gap_fraction * req.diameter;
    if (!(r_max > 0)) {
      std::ostringstream msg;
      msg << "cannot place any " << species_name(req.species) << ": diameter " << req.diameter
          << " m does not fit in a vessel of radius " << radius << " m";
      throw PlacementError(msg.str());
    }
    for (long n = 0; n < req.count; ++n) {
      bool ok = false;
      for (long attempt = 0; attempt < opt.max_attempts && !ok; ++attempt) {
        const double rr = r_max * std::sqrt(uniform01(rng));
        const double th = 2 * units::pi * uniform01(rng);
        const Vec3 x(rr * std::cos(th), rr * std::sin(th), z0 + length * uniform01(rng));
        const bool clash = grid.any_near(x, [&](int id) {
          const auto& q = placed[static_cast<std::size_t>(id)];
          Vec3 d = q.position - x;
          d.z() -= length * std::round(d.z() / length);
          const double reach = r_p + q.diameter / 2 + opt.gap_fraction * std::min(req.diameter, q.diameter);
          return d.squaredNorm() < reach * reach;
        });
        if (!clash) {
          grid.insert(x, static_cast<int>(placed.size()));
          placed.push_back({req.species, req.diameter, x});
          solid += units::pi / 6 * req.diameter * req.diameter * req.diameter;
          ok = true;
        }
      }
      if (!ok) {
        std::ostringstream msg;
        msg << "cannot place " << species_name(req.species) << " " << n + 1 << " of " << req.count << " (particle "
            << placed.size() + 1 << " placed in all) after " << opt.max_attempts
            << " random attempts: the vessel is too full (sphere volume fraction " << solid / vessel
            << " so far); lower the hematocrit or the platelet density, or use a longer vessel";
        throw PlacementError(msg.str());
      }
    }
  }
  return placed;
}

}  // namespace hemo::particles
