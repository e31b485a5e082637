// The orientations of the particles whose closures need one (platelets with an oblate closure):
// quaternion and angular momentum in a LIGGGHTS `fix property/atom` (so they migrate between
// ranks with their atom), advanced in the fluid-force callback (orientation.h: kick with the
// hydrodynamic + contact torque, drift). The callback turns the symmetry axis the closures see,
// and the resulting angular velocity goes to LIGGGHTS's omega (contacts see it) with the torque
// zeroed, so that nve/sphere leaves it alone. Other particles rotate as LIGGGHTS spheres.
//
// A step's kick is applied once, at its first evaluation: a `pre yes` set-up re-evaluates the
// step the previous run ended on. The drift to a step comes first, over the length of the step
// whose kick was applied last.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "dem_problem.h"
#include "dem_session.h"
#include "engine_state.h"
#include "orientation.h"
#include "vec.h"

#include <cstdint>
#include <map>

namespace hemo::particles {

class OrientationTracker {
 public:
  OrientationTracker(const LiggghtsSession& liggghts, FirstProblem& problems)
      : liggghts_(liggghts), problems_(problems) {}

  // One DEM step, the same for every atom.
  struct Step {
    std::int64_t ntimestep = 0;
    double dt = 0;
    long coupling_step = 0;    // labels errors
    bool advance = false;      // the orientations take this step's kick
    bool drift = false;        // and drift to it first
    double** spins = nullptr;  // per atom: q (w, x, y, z), L (3); null: no orientation tracked
  };
  Step step(std::int64_t ntimestep, double dt, long coupling_step) const;

  struct Spin {
    Quat q = Quat::Identity();
    Vec3 l = Vec3::Zero();  // angular momentum, world frame
  };
  // Atom i's orientation at this step: as stored (or as set() asked), drifted from the step
  // whose kick it took last.
  // `Integrator`: OrientationIntegrator, or SplittingIntegrator, whose calls are inlined.
  template <class Integrator>
  Spin at_step(const Step& step, int i, int tag, const Integrator& rotation) const;
  // Kicked by the fluid and contact torques (once per step), checked, stored, and its angular
  // velocity handed to LIGGGHTS.
  template <class Integrator>
  void kick_and_store(const Step& step, int i, int tag, const Integrator& rotation, Spin& spin,
                      const Vec3& fluid_torque);
  void finish_step(const Step& step);

  // Sets a particle's orientation from the next DEM step on; its angular momentum is kept.
  void set(long id, const Quat& q);

  void save(EngineState& state) const;
  void restore(const EngineState& state);

 private:
  const LiggghtsSession& liggghts_;
  FirstProblem& problems_;
  std::int64_t last_step_ = -1;  // the DEM step whose kick was applied last
  double last_dt_ = 0;           // the step length of that kick
  std::map<int, Quat> pending_;  // set(), applied at the next step
};

}  // namespace hemo::particles
