// Fluid-force closures, chosen by name per species in the scene (docs/model.md §2, §3):
//
//   [rbc]       drag = "rbc_fit"   lift = "rbc_lift"   torque = "none"
//   [platelet]  drag = "oblate"    lift = "oblate"     torque = "oblate"
//               (spherical surrogate: drag = "schiller_naumann", lift = "shear_lift")
//
// Every closure is local: it sees one particle and the plasma around it, taken as uniform at
// the particle scale apart from the velocity gradient (ParticleFlow). Each one states its sign
// convention next to its formula, in its own header.
//
// A drag closure returns the coefficient beta of the linearised drag F = beta (u - v); for a
// nonlinear law beta = |F| / |u - v| depends on the slip (beta(Re)). The engine applies it with
// the exponential update of exponential_drag.h, stable whatever the DEM step. Lift and torque
// are returned as vectors and applied explicitly.
//
// Registration: a closure's header names it, one line per closure, in a block the compiler skips
// (LAMMPS's `#ifdef PairStyle` convention):
//
//   #ifdef HEMO_CLOSURE
//   HEMO_CLOSURE(drag, "stokes", StokesDrag)      // slot, the name a scene writes, the class
//   #endif
//
// CMake reads these lines (closure_table.cmake) into the closure table, closure_table.h in the
// build directory: the registry (registry.cpp) builds closures from it. Scene validation, which
// is engine-free, takes the names it accepts from model/closure_names.h instead; the registry
// static_asserts that the two lists are the same, so a new closure's name goes there too.
// "none" (no lift, no torque) is NoClosure's, below.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#ifdef HEMO_CLOSURE
HEMO_CLOSURE(lift, "none", NoClosure)
HEMO_CLOSURE(torque, "none", NoClosure)
#endif

#include <vec.h>

#include <scene.h>

#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace hemo::particles {

// What a closure may know about one particle and the plasma at its centre (SI units).
struct ParticleFlow {
  Vec3 slip = Vec3::Zero();      // u_r = u(x_p) - v_p, m/s
  Vec3 velocity = Vec3::Zero();  // u(x_p), m/s
  Mat3 gradient = Mat3::Zero();  // G[i][j] = d u_j / d x_i at x_p, 1/s
  double shear_rate = 0;         // sqrt(2 S:S), 1/s
  Vec3 axis = Vec3::UnitZ();     // symmetry axis n of an oblate platelet (unit, world frame)
  double centreline_speed = 0;   // |u_max| of the vessel flow, m/s
  double vessel_diameter = 0;    // m, the vessel's local diameter 2 R(z) at the particle (its shape's,
                                 // model/geometry.h; 0: not known, ClosureParams's nominal one)
  int cell = -1;                 // fluid cell holding the particle (-1: not known): a closure may
                                 // keep what depends only on the cell's values, per cell
};

// Constants of a closure: the particle, the plasma, the vessel.
struct ClosureParams {
  double diameter = 0;         // m, placeholder sphere (Re, reference areas)
  double fluid_density = 0;    // kg/m^3
  double viscosity = 0;        // Pa s, dynamic
  double aspect_ratio = 1;     // lambda = c / a of an oblate platelet
  double vessel_diameter = 0;  // m, nominal (the scene's)
  double kinematic_viscosity() const { return viscosity / fluid_density; }
  double reynolds(const Vec3& slip) const { return diameter * slip.norm() / kinematic_viscosity(); }
};

class ClosureRegistry;

// Every closure answers to the name it was made under (its HEMO_CLOSURE line, for logs). Only the
// registry sets it, so the name is spelled once, in the registration, and not again in the class.
class NamedClosure {
 public:
  const std::string& name() const { return name_; }

 private:
  friend class ClosureRegistry;
  std::string name_;
};

class DragClosure : public NamedClosure {
 public:
  virtual ~DragClosure() = default;
  // beta in N s/m with F = beta u_r; finite and >= 0, also at zero slip.
  virtual double coefficient(const ParticleFlow& flow) const = 0;
  // True when beta depends on nothing (the engine then computes the exponential factor once).
  virtual bool slip_independent() const { return false; }
  virtual bool needs_orientation() const { return false; }
  // Particle Reynolds number above which the law is outside its fit (the engine warns once).
  virtual double max_reynolds() const { return std::numeric_limits<double>::infinity(); }
};

class LiftClosure : public NamedClosure {
 public:
  virtual ~LiftClosure() = default;
  // N, on the particle, finite; zero at zero slip or zero shear as the law says.
  virtual Vec3 force(const ParticleFlow& flow) const = 0;
  virtual bool needs_orientation() const { return false; }
  virtual bool needs_centreline_speed() const { return false; }
};

class TorqueClosure : public NamedClosure {
 public:
  virtual ~TorqueClosure() = default;
  // N m, on the particle, world frame.
  virtual Vec3 torque(const ParticleFlow& flow) const = 0;
  virtual bool needs_orientation() const { return false; }
};

// The table's "none": the slot is left empty (no lift, no torque).
struct NoClosure {};

// Closures by name (the generated closure_table.h); "none" gives nullptr for lift and torque.
// Throw std::invalid_argument naming the known ones for an unknown name. The names come in the
// table's order, sorted: the ones scene validation accepts.
std::unique_ptr<DragClosure> make_drag_closure(const std::string& name, const ClosureParams& params);
std::unique_ptr<LiftClosure> make_lift_closure(const std::string& name, const ClosureParams& params);
std::unique_ptr<TorqueClosure> make_torque_closure(const std::string& name, const ClosureParams& params);
std::vector<std::string> drag_closure_names();
std::vector<std::string> lift_closure_names();
std::vector<std::string> torque_closure_names();

// The constants of a species' closures in a scene.
ClosureParams closure_params(const Species& species, const Scene& scene);

}  // namespace hemo::particles
