// The closures a scene may choose, one line each: the one place a closure's name is spelled.
// X(name, class) per slot, in the order error messages list them.
//
// The registry (../registry.cpp) expands the lines into factories and gives each closure its
// name; scene validation (common/scene.cpp) expands them into the names it accepts. This header
// therefore includes nothing and names the classes only as tokens: hemocommon and the
// coordinator read it without depending on the particle node (Eigen, LIGGGHTS, the closures).
// "none" (no lift, no torque) is the registry's NoClosure.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#define HEMO_DRAG_CLOSURES(X) \
  X("stokes", StokesDrag)     \
  X("rbc_fit", RbcFitDrag)    \
  X("oblate", OblateDrag)     \
  X("schiller_naumann", SchillerNaumannDrag)

#define HEMO_LIFT_CLOSURES(X) \
  X("none", NoClosure)        \
  X("rbc_lift", RbcLift)      \
  X("oblate", OblateLift)     \
  X("shear_lift", ShearLift)

#define HEMO_TORQUE_CLOSURES(X) \
  X("none", NoClosure)          \
  X("oblate", OblateTorque)
