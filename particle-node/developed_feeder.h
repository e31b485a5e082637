// An open vessel's feeder as its develop run left it (vessel.feeder_develop_s, model/feeder_develop.h):
// the particles of that run's last checkpoint, read with the checkpoint's own files
// (engine_state.h; written on any number of ranks), as the cells the open run's feeder starts with.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <placement.h>
#include <scene.h>

#include <string>
#include <vector>

namespace hemo::particles {

// The develop run `develop_dir`'s cells at its last step (feeder_develop_steps), about the z axis
// over [z0, z0 + period) as fill_open_vessel takes them, each with its motion; the scene's species
// and diameters. Throws std::runtime_error with one line naming the folder when the run did not
// reach its end or its cells are not of this scene's feeder (a species it lacks, another
// diameter, a cell outside the feeder's radius).
std::vector<PlacedParticle> developed_feeder_cells(const Scene& scene, const std::string& develop_dir, double z0);

}  // namespace hemo::particles
