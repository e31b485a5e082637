// The scene's options that pick one of a few named behaviours: each is an enum the code compares,
// registered once here with its scene name and its reading (whose choice it is, in a few words,
// for `hemocosim check`). The scene reads a name through the table (model/scene.cpp,
// read_choice); nothing else spells a name. Options whose entries carry more than a name (the
// closures, the momentum forms, the vessel's shapes and ends) keep their own tables.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace hemo {

template <class E>
struct Choice {
  E value;
  std::string_view name;     // as in a scene file
  std::string_view reading;  // whose choice, and what it means
};

// ChoiceTable<E>::key is the scene key; ChoiceTable<E>::entries its values, the default first.
template <class E>
struct ChoiceTable;

template <class E>
const Choice<E>& choice_of(E value) {
  for (const Choice<E>& c : ChoiceTable<E>::entries)
    if (c.value == value) return c;
  return ChoiceTable<E>::entries.front();  // unreachable: every enumerator has an entry (tests/model)
}
template <class E>
std::string name_of(E value) {
  return std::string(choice_of(value).name);
}
template <class E>
std::vector<std::string> choice_names() {
  std::vector<std::string> names;
  for (const Choice<E>& c : ChoiceTable<E>::entries) names.emplace_back(c.name);
  return names;
}
// The value named `name`; false when there is none.
template <class E>
bool choice_named(const std::string& name, E& out) {
  for (const Choice<E>& c : ChoiceTable<E>::entries)
    if (c.name == name) {
      out = c.value;
      return true;
    }
  return false;
}

// coupling.scheme: the order of the two nodes' work within a coupling interval.
enum class CouplingScheme { serial, parallel };
template <>
struct ChoiceTable<CouplingScheme> {
  static constexpr std::string_view key = "coupling.scheme";
  static constexpr std::array<Choice<CouplingScheme>, 2> entries = {{
      {CouplingScheme::serial, "serial", "Gauss-Seidel: the fluid solves step k, then the particles move in it"},
      {CouplingScheme::parallel, "parallel", "Jacobi: both compute step k at once, the particles in the fluid of step k - 1"},
  }};
};

// dem.neighbour_rebuild: when the DEM's neighbour lists are rebuilt.
enum class NeighbourRebuild { engine, streaming };
template <>
struct ChoiceTable<NeighbourRebuild> {
  static constexpr std::string_view key = "dem.neighbour_rebuild";
  static constexpr std::array<Choice<NeighbourRebuild>, 2> entries = {{
      {NeighbourRebuild::engine, "engine", "LIGGGHTS's check: any particle moved half the skin"},
      {NeighbourRebuild::streaming, "streaming",
       "ours: the particles' motion relative to the scene's Poiseuille flow, a bound on the shear across the reach"},
  }};
};

// dem.load_balance: whether the particle ranks' sub-domains follow their particles. LIGGGHTS 3.8
// (Debian's liggghts 3.8.0) has neither LAMMPS's `balance` command nor its `fix balance`
// ("Unknown command", "Invalid fix style"), so the one reading is ours, of theirs: LAMMPS's
// `balance shift z` cut by particle count, applied through LIGGGHTS's own non-uniform sub-domains
// (Comm::zsplit) and its set-up's atom exchange (particle-node/dem_balance.h).
enum class LoadBalance { none, particle_count };
template <>
struct ChoiceTable<LoadBalance> {
  static constexpr std::string_view key = "dem.load_balance";
  static constexpr std::array<Choice<LoadBalance>, 2> entries = {{
      {LoadBalance::none, "none", "LIGGGHTS's equal slabs along the axis, fixed for the run"},
      {LoadBalance::particle_count, "particle_count",
       "ours, LAMMPS's `balance shift z` by particle count (LIGGGHTS 3.8 has none): the slabs' cuts moved every "
       "dem.load_balance_every_steps coupling steps so that each rank holds as many particles"},
  }};
};

// mesh.wall_polygon: where the O-grid's polygonal wall lies against the vessel's circle.
enum class WallPolygon { circumscribed, inscribed };
template <>
struct ChoiceTable<WallPolygon> {
  static constexpr std::string_view key = "mesh.wall_polygon";
  static constexpr std::array<Choice<WallPolygon>, 2> entries = {{
      {WallPolygon::circumscribed, "circumscribed",
       "ours: sides tangent to the circle, hydraulic diameter d, so d dP/(4l) is the wall's"},
      {WallPolygon::inscribed, "inscribed", "blockMesh's arcs: corners on the circle, hydraulic diameter d cos(pi/n)"},
  }};
};

// coupling.fluid_velocity: the plasma velocity a particle's closures see.
enum class FluidVelocity { reconstructed, cell };
template <>
struct ChoiceTable<FluidVelocity> {
  static constexpr std::string_view key = "coupling.fluid_velocity";
  static constexpr std::array<Choice<FluidVelocity>, 2> entries = {{
      {FluidVelocity::reconstructed, "reconstructed", "ours: u_c + G^T (x - x_c), exact for a linear field"},
      {FluidVelocity::cell, "cell", "CFDEM's default: the value of the particle's cell"},
  }};
};

// coupling.plasma_velocity: the cell velocity the fluid publishes.
enum class PlasmaVelocity { face_flux, cell_centre };
template <>
struct ChoiceTable<PlasmaVelocity> {
  static constexpr std::string_view key = "coupling.plasma_velocity";
  static constexpr std::array<Choice<PlasmaVelocity>, 2> entries = {{
      {PlasmaVelocity::face_flux, "face_flux", "ours: U rebuilt from the conservative face fluxes"},
      {PlasmaVelocity::cell_centre, "cell_centre", "CFDEM's: OpenFOAM's cell-centre U"},
  }};
};

// coupling.implicit_drag: the coefficient K with which the fluid treats the particles' drag
// implicitly (model/scene.h says what each deposits; co_relaxed: particle-node/cell_plasma.h).
enum class ImplicitDrag { interval_response, instantaneous, co_relaxed };
template <>
struct ChoiceTable<ImplicitDrag> {
  static constexpr std::string_view key = "coupling.implicit_drag";
  static constexpr std::array<Choice<ImplicitDrag>, 3> entries = {{
      {ImplicitDrag::interval_response, "interval_response", "ours: K from the interval's drag response"},
      {ImplicitDrag::instantaneous, "instantaneous", "CFDEM's implicitCouple: the fluid takes K = sum beta / V"},
      {ImplicitDrag::co_relaxed, "co_relaxed", "ours: each cell's plasma answers its particles every DEM step"},
  }};
};

// platelet.orientation_integrator: how a platelet's quaternion is advanced over a DEM step.
enum class OrientationMethod { splitting, euler };
template <>
struct ChoiceTable<OrientationMethod> {
  static constexpr std::string_view key = "orientation_integrator";  // under the species' table
  static constexpr std::array<Choice<OrientationMethod>, 2> entries = {{
      {OrientationMethod::splitting, "splitting", "ours: second order, exact torque-free rotation"},
      {OrientationMethod::euler, "euler", "the paper's Algorithm 1 as printed (explicit, first order)"},
  }};
};

// coupling.fluid_force: when the closures are evaluated and what is held until the next.
enum class FluidForceUpdate { per_dem_step, held_implicit_drag, held };
template <>
struct ChoiceTable<FluidForceUpdate> {
  static constexpr std::string_view key = "coupling.fluid_force";
  static constexpr std::array<Choice<FluidForceUpdate>, 3> entries = {{
      {FluidForceUpdate::per_dem_step, "per_dem_step",
       "ours: closures every time.closure_every_dem_steps DEM steps, drag on the current velocity every step"},
      {FluidForceUpdate::held_implicit_drag, "held_implicit_drag",
       "CFDEM's couple/cfd/force/implicit: drag implicit on the current velocity, lift and torque held from the "
       "exchange"},
      {FluidForceUpdate::held, "held", "CFDEM's couple/cfd/force: drag, lift, torque held from the exchange"},
  }};
};

// hosts.launcher: how a node with hosts is started (docs/hosts.md, docs/slurm.md).
enum class Launcher { ssh, local, slurm };
template <>
struct ChoiceTable<Launcher> {
  static constexpr std::string_view key = "hosts.launcher";
  static constexpr std::array<Choice<Launcher>, 3> entries = {{
      {Launcher::ssh, "ssh", "on its first host, by the launch command"},
      {Launcher::local, "local", "here; Open MPI places its ranks"},
      {Launcher::slurm, "slurm", "a job step of the Slurm job the coordinator runs in"},
  }};
};

// hosts.transport: what carries the bus (docs/hosts.md).
enum class Transport { multicast, tcp };
template <>
struct ChoiceTable<Transport> {
  static constexpr std::string_view key = "hosts.transport";
  static constexpr std::array<Choice<Transport>, 2> entries = {{
      {Transport::multicast, "multicast", "LCM's UDP multicast"},
      {Transport::tcp, "tcp", "LCM's tcpq through a relay the coordinator runs, where multicast is blocked"},
  }};
};

}  // namespace hemo
