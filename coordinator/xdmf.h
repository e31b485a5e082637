// ParaView sidecars for a run directory: particles.xmf next to particles.h5 (a temporal
// collection of point clouds with their attributes) and fluid/fluid.foam, which ParaView's
// OpenFOAM reader opens.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>

namespace hemo {

// Writes the sidecars for whatever the run has written so far; returns the number of particle
// snapshots described. Throws with a one-line reason when particles.h5 cannot be read.
int write_paraview_sidecars(const std::string& run_dir);

}  // namespace hemo
