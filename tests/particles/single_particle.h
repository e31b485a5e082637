// A single particle stepped exactly as the engine's force callback and LIGGGHTS's velocity
// Verlet step it (leapfrog: velocity at half steps, the fluid force of step n from x_n and
// v_{n-1/2}, exponential drag with the step's other forces; orientation drift then kick), in an
// analytic flow instead of a mesh. For single-particle tests and the step-size accuracy study.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "fluid_forces.h"
#include "orientation.h"

#include <functional>
#include <memory>

namespace hemo::particles::testing {

struct SingleParticle {
  Vec3 x = Vec3::Zero();
  Vec3 v = Vec3::Zero();  // v_{n-1/2}
  Quat q = Quat::Identity();
  Vec3 l = Vec3::Zero();  // angular momentum L_{n-1/2}
  bool started = false;
};

// The flow a particle at x moving at v sees (velocity, slip, gradient, shear rate, u_max).
using FlowAt = std::function<ParticleFlow(const Vec3& x, const Vec3& v)>;

class SingleParticleStepper {
 public:
  SingleParticleStepper(const SpeciesForces& forces, const OrientationIntegrator* rotation, FlowAt flow)
      : forces_(&forces), rotation_(rotation), flow_(std::move(flow)) {}

  // One DEM step of dt under an external (non-fluid) force.
  FluidForce step(SingleParticle& p, double dt, const Vec3& external = Vec3::Zero()) const {
    ParticleFlow flow = flow_(p.x, p.v);
    if (rotation_) {
      if (p.started) rotation_->drift(p.q, p.l, dt);
      flow.axis = symmetry_axis(p.q);
    }
    const FluidForce f = forces_->evaluate(flow, external, dt);
    if (rotation_) rotation_->kick(p.q, p.l, f.torque, dt);
    p.v += dt / forces_->mass() * (f.total() + external);
    p.x += dt * p.v;
    p.started = true;
    return f;
  }

 private:
  const SpeciesForces* forces_;
  const OrientationIntegrator* rotation_;
  FlowAt flow_;
};

}  // namespace hemo::particles::testing
