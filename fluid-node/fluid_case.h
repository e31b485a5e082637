// What the fluid node takes from a scene, and the OpenFOAM case it writes from it
// (RUN_DIR/fluid: system/, constant/polyMesh, 0/). Plain C++, no OpenFOAM.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "vessel_mesh.h"

#include <driving.h>  // driving_pressure_drop
#include <momentum_forms.h>
#include <scene.h>
#include <suspension_viscosity.h>
#include <vessel_ends.h>

#include <optional>
#include <string>

namespace hemo {

// The fluid problem in SI units.
struct FluidSettings {
  double density = 0;                       // kg/m^3
  double viscosity = 0;                     // Pa s
  double kinematic_viscosity = 0;           // m^2/s
  double pressure_drop = 0;                 // Pa over the vessel length
  double body_force = 0;                    // m/s^2 along +z: G = dP / (rho l)
  double dt = 0;                            // s, coupling interval = one fluid time step
  double largest_particle_diameter = 0;     // m, over the species present (0: none, or shared over a kernel)
  FluidSolver solver;                       // scene keys fluid.*: tolerances, PISO correctors, steady skip
  bool skip_when_steady = false;            // fluid.skip_when_steady and a one-way scene
  MomentumForm momentum;                    // coupling.momentum: the plasma's equation and what it publishes
  SuspensionViscosity suspension;           // plasma.suspension_viscosity: the mixture's own stress, beyond the paper
  bool publish_pressure_gradient = false;   // the form puts F_p on the particles: grad P goes with the state
  bool publish_viscous_force = false;       // the form puts F_v on the particles: div tau goes with the state
  bool publish_face_flux_velocity = false;  // coupling.plasma_velocity = "face_flux": U from the face fluxes
  bool open_ends = false;                   // vessel.ends: an inlet and an outlet (vessel_ends.h)
  double inlet_flow_rate = 0;               // m^3/s, open ends: Q = pi R0^3 gamma_w / 4 (driving.h)
  VesselInlet::Profile inlet_profile = VesselInlet::Profile::feeder;  // open ends: vessel.inlet
  bool inlet_carries_q = true;  // open ends: the inlet's flux is inlet_flow_rate (else a feeder's own)
};

FluidSettings fluid_settings(const Scene& scene);

// Analytic Poiseuille velocity of the particle-free vessel at radius r (m/s along z).
double poiseuille_velocity(const FluidSettings& fluid, const Vessel& vessel, double r);

// Unresolved coupling needs every fluid cell larger than every particle. Cell size is the
// edge of the cube of the cell's volume. Returns the one-line reason when the mesh is too
// fine for the particles, nothing when it is fine.
std::optional<std::string> unresolved_mesh_problem(const MeshGeometry& geometry, double largest_particle_diameter);

enum class InitialFlow { rest, poiseuille };

// Writes the case directory: system/{controlDict,fvSchemes,fvSolution}, constant/polyMesh,
// 0/{U,p}. The time step is the coupling interval; the case writes nothing unless asked. An open
// vessel's boundary conditions: the inlet's velocity as vessel.inlet says, carrying
// fluid.inlet_flow_rate, p zeroGradient there; the outlet p = 0, U inletOutlet.
void write_case(const std::string& case_dir, const FluidSettings& fluid, const Vessel& vessel, const PolyMesh& mesh,
                const MeshGeometry& geometry, InitialFlow initial);

// Writes system/decomposeParDict: `ranks` subdomains of whole cross-sections, split along the
// vessel axis (method simple, n = (1 1 ranks)). Throws std::invalid_argument when the mesh has
// fewer axial cells than ranks.
void write_decomposition(const std::string& case_dir, int ranks, const MeshSpec& mesh);

}  // namespace hemo
