// Initial positions: random, non-overlapping spheres inside the periodic vessel, r < R(z)
// (model/geometry.h; the straight tube x^2 + y^2 < R^2), z in [z0, z0 + L). Every centre keeps
// radius + gap from the wall (its signed distance, on a shape that narrows); every pair
// keeps r_i + r_j + gap. Random sequential addition, species by species; a species it cannot
// place (it jams near a volume fraction of 0.3) is placed instead on a random subset of the
// sites of a randomly turned close-packed lattice (0.51 in a 50 um vessel). Reproducible from
// the seed (own uniform mapping of mt19937_64, so the result does not depend on the standard
// library's distributions).
// Pure geometry, in hemocommon: the particle node places its particles with it at step 0, and
// `hemocosim check` / `run` run the very same placement beforehand to refuse a scene whose
// particles cannot be placed (model/scene.h, SceneCheck::placement).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "vec.h"

#include <geometry.h>
#include <scene.h>
#include <vessel_ends.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hemo::particles {

struct PlacementRequest {
  int species = 0;      // SpeciesIndex
  double diameter = 0;  // m
  long count = 0;
};

struct PlacedParticle {
  int species = 0;
  double diameter = 0;
  Vec3 position;
  // A placed particle starts at rest and unturned; one taken from a developed feeder
  // (model/feeder_develop.h) carries its motion: velocity (m/s), angular velocity (rad/s),
  // orientation (quaternion w, x, y, z; platelets whose closures track it) and angular momentum
  // (kg m^2/s, at the DEM's mass).
  struct Motion {
    Vec3 velocity = Vec3::Zero(), angular_velocity = Vec3::Zero(), angular_momentum = Vec3::Zero();
    Eigen::Vector4d orientation{1, 0, 0, 0};
  };
  std::optional<Motion> motion;
};

struct PlacementOptions {
  double gap_fraction = 0.02;  // gap = this x the smaller diameter involved
  long max_attempts = 20000;   // per particle, before giving up
};

class PlacementError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
  // A species that found no room: `placed` of its `requested` particles fitted (on the lattice,
  // the last way tried), and the spheres placed by then, of every species, fill
  // `volume_fraction` of the vessel.
  PlacementError(const std::string& what, int species, long requested, long placed, double volume_fraction)
      : std::runtime_error(what),
        species(species),
        requested(requested),
        placed(placed),
        volume_fraction(volume_fraction) {}
  int species = -1;  // SpeciesIndex; -1: no species to blame (a vessel or request that is no such)
  long requested = 0, placed = 0;
  double volume_fraction = 0;
};

// Number of RBCs: hematocrit x vessel volume / V_RBC (rounded); platelets: number density x
// vessel volume (rounded); 0 for an absent species.
long rbc_count(const Scene& scene);
long platelet_count(const Scene& scene);

// The requests a scene implies (RBCs first, then platelets).
std::vector<PlacementRequest> placement_requests(const Scene& scene);

// Places the particles, largest first; throws PlacementError naming the species, how many were
// placed and the volume fraction when neither way finds room for a species.
// The vessel's z origin is the shape's, shifted to z0. On a straight tube the same particles,
// to the bit, as the overload of a radius and length.
std::vector<PlacedParticle> place_particles(const VesselGeometry& vessel, double z0,
                                            const std::vector<PlacementRequest>& requests, unsigned long long seed,
                                            const PlacementOptions& options = {});
// An open vessel's particles (model/vessel_ends.h): its feeder's, placed at the scene's hematocrit
// and platelet density as in a straight periodic vessel of the feeder's radius and length from z0
// and moved onto its axis; then the vessel's, copies of the feeder's over the vessel's length that
// keep clear of the vessel's own wall (all of them in a straight vessel). So the cells the feeder
// hands over at the inlet continue the suspension already there, as they do at every later step.
// Independent placements would put the first copies onto the vessel's cells at the inlet.
std::vector<PlacedParticle> place_open_vessel_particles(const Scene& scene, const VesselWall& vessel,
                                                        const FeederLayout& feeder, double z0, unsigned long long seed,
                                                        const PlacementOptions& options = {});

// The particles a scene starts with, in its vessel of this shape from z0: place_particles, or in
// The same from the feeder's cells as they are, about the z axis over [z0, z0 + period) (placed
// there, or taken from a developed feeder, model/feeder_develop.h): moved onto the feeder's axis,
// then their copies in the vessel, each with its source's motion.
std::vector<PlacedParticle> fill_open_vessel(std::vector<PlacedParticle> feeder_cells, const VesselWall& vessel,
                                             const FeederLayout& feeder, double z0, const PlacementOptions& options = {});

// a vessel fed by a feeder place_open_vessel_particles (the particle node's placement, and
// `hemocosim check`'s).
std::vector<PlacedParticle> place_scene_particles(const Scene& scene, const VesselWall& vessel, double z0);

// In the straight tube of this radius and length.
std::vector<PlacedParticle> place_particles(double radius, double length, double z0,
                                            const std::vector<PlacementRequest>& requests, unsigned long long seed,
                                            const PlacementOptions& options = {});

}  // namespace hemo::particles
