// The calibration vessel with both species at docs/model.md's sizes and masses, as a Scene
// (no file): for tests of the physics derived from a scene.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <scene.h>

namespace hemo::test {

inline Scene calibration_scene() {
  Scene s;
  s.vessel.diameter = 100e-6;
  s.vessel.length = 600e-6;
  s.driving.wall_shear_rate = 799;
  s.rbc.present = s.platelet.present = true;
  s.rbc.diameter = 5.56e-6;
  s.rbc.mass = 9.9e-14;
  s.platelet.diameter = 2.66e-6;
  s.platelet.mass = 8.79e-15;
  return s;
}

}  // namespace hemo::test
