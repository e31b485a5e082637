// SPDX-License-Identifier: GPL-3.0-or-later
#include "placement.h"

#include "driving.h"
#include "spatial_hash.h"

#include <units.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>

namespace hemo::particles {

namespace {

const char* species_name(int species) { return species == kRbc ? "RBC" : "platelet"; }

// Uniform in [0, 1) from 53 random bits.
double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

}  // namespace

long rbc_count(const Scene& s) {
  if (!s.rbc.present || !(s.rbc.volume > 0)) return 0;
  return std::lround(s.rbc.hematocrit * vessel_volume(s.vessel) / s.rbc.volume);
}

long platelet_count(const Scene& s) {
  if (!s.platelet.present) return 0;
  return std::lround(s.platelet.number_density * vessel_volume(s.vessel));
}

std::vector<PlacementRequest> placement_requests(const Scene& s) {
  std::vector<PlacementRequest> r;
  if (long n = rbc_count(s); n > 0) r.push_back({kRbc, s.rbc.diameter, n});
  if (long n = platelet_count(s); n > 0) r.push_back({kPlatelet, s.platelet.diameter, n});
  return r;
}

namespace {

// The particles placed so far, with a spatial hash to test a new one against them.
class Packing {
 public:
  Packing(const VesselGeometry& vessel, double z0, double reach, double gap_fraction)
      : vessel_(vessel),
        radius_(vessel.nominal_radius()),
        length_(vessel.length()),
        z0_(z0),
        reach_(reach),
        gap_fraction_(gap_fraction),
        grid_(radius_, length_, z0, reach) {}

  // Whether a sphere of diameter d at x keeps d/2 + gap from the wall. Candidates are drawn
  // within r_max of the widest radius, which is all a straight tube asks (no test: the same
  // random draws as before shapes); a shape that narrows asks its signed distance.
  bool clear_of_wall(const Vec3& x, double d) const {
    return vessel_.uniform() ||
           vessel_.signed_distance(Vec3(x.x(), x.y(), x.z() - z0_)) <= -(d / 2 + gap_fraction_ * d);
  }

  // Whether a sphere of diameter d at x keeps r_i + r_j + gap from every placed one (across the
  // periodic ends too).
  bool fits(const Vec3& x, double d) const {
    return !grid_.any_near(x, [&](int id) {
      const auto& q = placed_[static_cast<std::size_t>(id)];
      Vec3 dx = q.position - x;
      dx.z() -= length_ * std::round(dx.z() / length_);
      const double reach = (d + q.diameter) / 2 + gap_fraction_ * std::min(d, q.diameter);
      return dx.squaredNorm() < reach * reach;
    });
  }
  void add(int species, double d, const Vec3& x) {
    grid_.insert(x, static_cast<int>(placed_.size()));
    placed_.push_back({species, d, x});
    solid_ += units::pi / 6 * d * d * d;
  }
  // Forgets the particles from index `first` on (a species to be placed again another way).
  void truncate(std::size_t first) {
    std::vector<PlacedParticle> kept(placed_.begin(), placed_.begin() + static_cast<std::ptrdiff_t>(first));
    placed_.clear();
    solid_ = 0;
    grid_ = SpatialHash(radius_, length_, z0_, reach_);
    for (const auto& p : kept) add(p.species, p.diameter, p.position);
  }
  double volume_fraction() const { return solid_ / vessel_.volume(); }
  std::vector<PlacedParticle>& placed() { return placed_; }

 private:
  const VesselGeometry& vessel_;
  double radius_, length_, z0_, reach_, gap_fraction_;
  SpatialHash grid_;
  std::vector<PlacedParticle> placed_;
  double solid_ = 0;
};

// Random sequential addition: each particle at uniformly random spots until one is free.
// Returns how many of the request it placed (all, unless it jammed).
long place_randomly(Packing& packing, const PlacementRequest& req, double r_max, double length, double z0,
                    long max_attempts, std::mt19937_64& rng) {
  for (long n = 0; n < req.count; ++n) {
    bool ok = false;
    for (long attempt = 0; attempt < max_attempts && !ok; ++attempt) {
      const double rr = r_max * std::sqrt(uniform01(rng));
      const double th = 2 * units::pi * uniform01(rng);
      const Vec3 x(rr * std::cos(th), rr * std::sin(th), z0 + length * uniform01(rng));
      if ((ok = packing.clear_of_wall(x, req.diameter) && packing.fits(x, req.diameter)))
        packing.add(req.species, req.diameter, x);
    }
    if (!ok) return n;
  }
  return req.count;
}

// The sites of a close-packed (fcc, ABC-stacked hexagonal layers) lattice of spacing a inside
// r <= r_max, z in [z0, z0 + length), periodic along z: the number of layers is a multiple of
// three, stretched to fill the length exactly, so the layers across the periodic end stack
// like the others. The layers are turned and shifted at random (seeded).
std::vector<Vec3> lattice_sites(double a, double r_max, double length, double z0, std::mt19937_64& rng) {
  const double h = a * std::sqrt(2.0 / 3.0);
  int layers = 3 * static_cast<int>(std::floor(length / (3 * h)));
  int stacking = 3;
  if (layers == 0) {  // shorter than three layers: identical layers, a apart
    layers = static_cast<int>(std::floor(length / a));
    stacking = 1;
  }
  std::vector<Vec3> sites;
  if (layers == 0) return sites;
  const double dz = length / layers, turn = 2 * units::pi * uniform01(rng);
  const Vec3 shift(a * uniform01(rng), a * uniform01(rng), dz * uniform01(rng));
  const double c = std::cos(turn), s = std::sin(turn);
  const int n = static_cast<int>(std::ceil(2 * r_max / a)) + 3;
  for (int k = 0; k < layers; ++k) {
    const int abc = k % stacking;  // offsets of the A, B, C layers
    const double ox = shift.x() + abc * a / 2, oy = shift.y() + abc * a / (2 * std::sqrt(3.0));
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i) {
        const double lx = ox + (i + 0.5 * j) * a, ly = oy + j * a * std::sqrt(3.0) / 2;
        const double x = c * lx - s * ly, y = s * lx + c * ly;
        if (x * x + y * y <= r_max * r_max) sites.emplace_back(x, y, z0 + std::fmod(shift.z() + k * dz, length));
      }
  }
  return sites;
}

// A species too dense for random addition: a random subset of the lattice's sites (in random
// order, each taken if it keeps clear of the particles already there).
long place_on_lattice(Packing& packing, const PlacementRequest& req, double r_max, double length, double z0,
                      double gap_fraction, std::mt19937_64& rng) {
  // The spacing is exactly what fits() requires, plus 1e-9 so that round-off in the turned
  // coordinates never makes two neighbouring sites clash.
  auto sites = lattice_sites(req.diameter * (1 + gap_fraction) * (1 + 1e-9), r_max, length, z0, rng);
  for (std::size_t i = sites.size(); i > 1; --i)  // Fisher-Yates with our own uniform mapping
    std::swap(sites[i - 1], sites[static_cast<std::size_t>(uniform01(rng) * static_cast<double>(i))]);
  long n = 0;
  for (const Vec3& x : sites) {
    if (n == req.count) break;
    if (packing.clear_of_wall(x, req.diameter) && packing.fits(x, req.diameter)) {
      packing.add(req.species, req.diameter, x);
      ++n;
    }
  }
  return n;
}

}  // namespace

std::vector<PlacedParticle> place_open_vessel_particles(const Scene& scene, const VesselWall& vessel,
                                                        const FeederLayout& feeder, double z0, unsigned long long seed,
                                                        const PlacementOptions& options) {
  Scene tube = scene;
  tube.vessel = Vessel{};
  tube.vessel.diameter = 2 * feeder.radius;
  tube.vessel.length = feeder.period;
  return fill_open_vessel(place_particles(feeder.radius, feeder.period, z0, placement_requests(tube), seed, options),
                          vessel, feeder, z0, options);
}

std::vector<PlacedParticle> fill_open_vessel(std::vector<PlacedParticle> placed, const VesselWall& vessel,
                                             const FeederLayout& feeder, double z0, const PlacementOptions& options) {
  const std::size_t fed = placed.size();
  for (std::size_t k = 0; k < fed; ++k) {
    // Placed about the z axis: the feeder's cell on the feeder's axis, its copy on the inlet's.
    PlacedParticle copy = placed[k];
    placed[k].position.x() += feeder.axis_x;
    placed[k].position.y() += feeder.inlet_y;
    copy.position.x() += feeder.inlet_x;
    copy.position.y() += feeder.inlet_y;
    const Vec3 in_shape(copy.position.x(), copy.position.y(), copy.position.z() - z0);
    const double d = copy.diameter;
    if (in_shape.z() < feeder.vessel_length && vessel.signed_distance(in_shape) <= -(d / 2 + options.gap_fraction * d))
      placed.push_back(copy);
  }
  return placed;
}

std::vector<PlacedParticle> place_scene_particles(const Scene& scene, const VesselWall& vessel, double z0) {
  if (fed_by_feeder(scene.vessel))
    return place_open_vessel_particles(scene, vessel, feeder_layout(scene), z0, scene.run.seed);
  const auto* shape = dynamic_cast<const VesselGeometry*>(&vessel);
  if (shape == nullptr)
    throw PlacementError("a surface vessel's cells come in through its feeder: set vessel.inlet = \"feeder\"");
  return place_particles(*shape, z0, placement_requests(scene), scene.run.seed);
}

std::vector<PlacedParticle> place_particles(double radius, double length, double z0,
                                            const std::vector<PlacementRequest>& requests, unsigned long long seed,
                                            const PlacementOptions& opt) {
  if (requests.empty()) return {};
  if (!(radius > 0) || !(length > 0)) throw PlacementError("placement needs a vessel with positive radius and length");
  Vessel straight;
  straight.diameter = 2 * radius;
  straight.length = length;
  return place_particles(*make_vessel_geometry(straight), z0, requests, seed, opt);
}

std::vector<PlacedParticle> place_particles(const VesselGeometry& vessel, double z0,
                                            const std::vector<PlacementRequest>& requests, unsigned long long seed,
                                            const PlacementOptions& opt) {
  if (requests.empty()) return {};
  const double radius = vessel.nominal_radius(), length = vessel.length();

  double d_max = 0;
  for (const auto& r : requests) {
    if (!(r.diameter > 0) || r.count < 0) throw PlacementError("placement: a species has no positive diameter");
    d_max = std::max(d_max, r.diameter);
  }
  // Largest first: they are the hardest to fit.
  std::vector<std::size_t> order(requests.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return requests[a].diameter > requests[b].diameter; });

  Packing packing(vessel, z0, d_max * (1 + opt.gap_fraction), opt.gap_fraction);
  std::mt19937_64 rng(seed);
  for (std::size_t o : order) {
    const auto& req = requests[o];
    const double r_max = radius - req.diameter / 2 - opt.gap_fraction * req.diameter;
    if (!(r_max > 0)) {
      std::ostringstream msg;
      msg << "cannot place any " << species_name(req.species) << ": diameter " << req.diameter
          << " m does not fit in a vessel of radius " << radius << " m";
      throw PlacementError(msg.str(), req.species, req.count, 0, packing.volume_fraction());
    }
    // Random sequential addition jams near a sphere volume fraction of 0.3 in a vessel; a
    // species it cannot place is placed again on lattice sites (0.70 in bulk; 0.51 in the
    // bench's 50 um vessel, after the wall gap).
    const std::size_t first = packing.placed().size();
    long n = place_randomly(packing, req, r_max, length, z0, opt.max_attempts, rng);
    if (n < req.count) {
      packing.truncate(first);
      n = place_on_lattice(packing, req, r_max, length, z0, opt.gap_fraction, rng);
    }
    if (n < req.count) {
      std::ostringstream msg;
      msg << "cannot place " << species_name(req.species) << " " << n + 1 << " of " << req.count << " (particle "
          << packing.placed().size() + 1 << " placed in all) by random addition (" << opt.max_attempts
          << " attempts each) nor on a close-packed lattice: the vessel is too full (sphere volume fraction "
          << packing.volume_fraction() << " so far); lower the hematocrit or the platelet density, or use a longer "
          << "vessel";
      throw PlacementError(msg.str(), req.species, req.count, n, packing.volume_fraction());
    }
  }
  return std::move(packing.placed());
}

}  // namespace hemo::particles
