// What the DEM knows of each particle species, set once from the scene: its closures, its
// orientation integrator, its size and DEM mass, and its physical weight.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "fluid_forces.h"
#include "orientation.h"
#include "vec.h"

#include <scene.h>

#include <array>
#include <memory>

namespace hemo::particles {

struct DemSpecies {
  // `dem`: the scene with dem_scene's masses; `physical`: before dem_scene scaled them (the
  // weight stays physical). Throws std::invalid_argument when a species lacks a positive size,
  // mass or volume, an oblate closure lacks its semi-axes, or the scene has no species.
  DemSpecies(const Scene& dem, const Scene& physical);

  // A species the scene has (absent: no closures, no atom type, nothing per step).
  bool has(int species) const { return forces[species] != nullptr; }

  std::array<std::unique_ptr<SpeciesForces>, kSpeciesCount> forces;
  std::array<std::unique_ptr<OrientationIntegrator>, kSpeciesCount> rotation;  // null: a sphere
  std::array<double, kSpeciesCount> volume{};                                  // m^3, deposited as solid
  std::array<double, kSpeciesCount> diameter{};                                // m
  std::array<double, kSpeciesCount> mass{};                            // kg, the DEM's (dem_mass_scaling x physical)
  std::array<Vec3, kSpeciesCount> weight{Vec3::Zero(), Vec3::Zero()};  // N, physical mass x gravity
  double d_max = 0;                                                    // m, the largest diameter
  double d_min = 0;                                                    // m, the smallest
  bool any_orientation = false;
};

}  // namespace hemo::particles
