// An open vessel's feeder developed before its run (vessel.feeder_develop_s = T; docs/design.md,
// "Open ends"). A feeder is a periodic straight tube; from a random placement its suspension takes
// a while to form its cell-free layer, and until it has, it hands the vessel an undeveloped inflow.
// So the coordinator first runs the feeder alone, as the periodic scene it is, for T, and the open
// run's feeder starts from that run's last checkpoint (its cells' positions, velocities, angular
// velocities and orientations), the vessel from copies of them (model/placement.h). The derived
// scene is the open scene's file with only what makes it the feeder changed:
//   [vessel]   a straight periodic tube of the feeder's diameter (2 R: the inlet's) and length (its
//              period, FeederLayout::period), every other vessel key dropped;
//   [mesh]     the feeder's layers (FeederLayout::layers), the O-grid's cross-section as the scene
//              gives it (the feeder region of the open mesh is that O-grid: fluid-node/vessel_mesh.h);
//   [driving]  the pressure drop over the period that gives the feeder the open scene's body force
//              G = dP / (rho l) (fluid-node/fluid_case.cpp);
//   time.coupling_steps      ceil(T / coupling interval);
//   output.checkpoint_every_steps  the scene's if it divides them, else all of them, so that the
//              last step writes the checkpoint the open run reads;
//   run.name   "<name>-feeder-develop".
// Everything else (blood, closures, contact, numerics, seed, guards, [hosts]) is the scene's.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"

#include <string>

namespace hemo {

// The develop run's directory inside the open run's.
inline constexpr const char* kFeederDevelopFolder = "feeder-develop";

// Whether a scene develops its feeder first.
bool develops_feeder(const Scene& scene);

// ceil(T / coupling interval): at least T (round-off of the quotient aside).
long feeder_develop_steps(const Scene& scene);

// The derived scene's file text, from the open scene (parsed) and its file's text. Throws
// std::invalid_argument when the scene does not develop its feeder, and toml::parse_error when
// the text is not TOML.
std::string feeder_develop_scene_text(const Scene& scene, const std::string& scene_text);

}  // namespace hemo
