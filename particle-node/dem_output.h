// What the engine shows of its particles between runs (collective): every particle for
// particles.h5, and the state part of a coupling step's diagnostics.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "dem_session.h"
#include "dem_species.h"
#include "dem_tracking.h"
#include "fluid_sampler.h"
#include "h5_output.h"

#include <facet_distance.h>
#include <mpi.h>

#include <optional>
#include <vector>

namespace hemo::particles {

// What a coupling step's DEM tells about itself (the node's step diagnostics).
struct EngineDiagnostics {
  long particles = 0;
  long outside_mesh = 0;                    // particles found in no fluid cell during the interval
  long in_wall_gap = 0;                     // particles now between a flat wall face and the round wall
  double core_particle_axial_velocity = 0;  // mean v_z of particles with r < R/2 (m/s)
  double core_fluid_axial_velocity = 0;     // mean fluid u_z sampled at those particles (m/s)
  long core_particles = 0;
  double max_overlap = 0;           // largest overlap / smaller diameter (pairs and wall)
  double max_speed = 0;             // m/s
  double max_reynolds[2] = {0, 0};  // per species, over the last run
  long lost = 0;                    // particles LIGGGHTS no longer has
  long in_vessel = 0;               // particles in the vessel (all but an open vessel's feeder's, centres inside its ends)
  long straddling = 0;              // an open vessel's particles whose centres are past an end, still in the DEM
  double volume_inside = 0;         // m^3, the particles' volume inside the ends at the last deposit
};

class DemOutput {
 public:
  DemOutput(const LiggghtsSession& liggghts, ParticleTracking& tracking, const DemSpecies& species,
            const CellLocator& locator, MPI_Comm comm);

  // The particles at the current state in `fluid` (null: no fluid state yet): count, core
  // velocities, wall gap, largest speed and overlap. What the last run found is the caller's.
  EngineDiagnostics diagnostics(const FluidSampler* fluid);
  // Every particle, sorted by id, z unwrapped (complete on every rank); in an open vessel, those
  // in the vessel (not its feeder).
  ParticleSnapshot snapshot(long step, double time_s);

 private:
  // The largest overlap of this rank's particles (pairs and wall), relative to the smaller diameter.
  double local_max_overlap() const;
  // An open vessel's atom whose centre is past an end (dem_open_ends.h), and one whose sphere
  // reaches past an end's plane, where the wall ends.
  bool straddles_outside(const double* x) const;
  bool crosses_an_end(const double* x, double radius) const;

  const LiggghtsSession& liggghts_;
  ParticleTracking& tracking_;
  const DemSpecies& species_;
  const CellLocator& locator_;
  MPI_Comm comm_;
  // A surface vessel's DEM wall, which its wall overlap is measured against as the DEM measures
  // its contacts (facet_distance.h); an axisymmetric vessel's overlap is radial, from R(z).
  std::optional<FacetDistance> facets_;
  // A surface vessel's core by fluid cell: whether the cell's centre is within half its section's
  // radius of the centre line. A section there is a search of the wall (model/surface_wall.h),
  // which for every particle every step would cost as much as the DEM.
  std::vector<char> core_cell_;
  bool in_core(const Vec3& x, int cell) const;
};

}  // namespace hemo::particles
