// When LIGGGHTS rebuilds its neighbour lists, decided in the frame that streams with the vessel's
// flow (scene key dem.neighbour_rebuild = "streaming"): a LIGGGHTS fix of ours,
// `hemo/streaming_neighbours`, replaces LIGGGHTS's own check (any particle moved half the skin
// since the last build) with one on the particles' motion relative to a streaming field u_s.
//
// Why: the cells stream along the axis at up to the centreline speed, so LIGGGHTS's absolute
// check rebuilds every few DEM steps, while what makes a Verlet list stale is the relative
// motion of neighbours, in a shear flow about shear rate x (cut-off + skin) per unit time (sheared
// MD builds its lists in the streaming frame for the same reason).
//
// The criterion. u_s(x) = u_max (1 - min(r^2 / R^2, 1)) z, the Poiseuille profile of the scene's
// driving (u_max = wall shear rate x R / 2, R the vessel's radius): a fixed field, axial, the
// same at every z, Lipschitz with L = 2 u_max / R = the wall shear rate (|grad u_s| <= 2 u_max
// r / R^2 inside, 0 outside). Let a list be built at t0 with positions x_i0, t = t0 + tau, and
// d_i = x_i(t) - x_i0 - u_s(x_i0) tau each particle's motion relative to the stream, D = max |d_i|.
// For any pair (or a pair with a periodic image: u_s does not depend on z),
//   x_i - x_j = (x_i0 - x_j0) + (u_s(x_i0) - u_s(x_j0)) tau + d_i - d_j,
//   |x_i - x_j| >= s0 (1 - L tau) - 2 D,       s0 = |x_i0 - x_j0|.
// A pair LIGGGHTS did not list had s0 > c_ij + skin (c_ij = contact distance factor x (r_i + r_j),
// the reach within which the pair style acts), so it stays beyond c_ij while
//   2 D + L (c_max + skin) tau < skin,         c_max the largest c_ij.
// The fix rebuilds at the first step where this fails. It holds for any fixed u_s with that
// Lipschitz bound; how close u_s is to the particles' motion decides only how long lists live.
// The primitive wall's list (particles within their radius + skin of the zcylinder) stays
// valid too: u_s is axial, so a particle's radial motion is at most |d_i| < skin / 2.
// The check costs what LIGGGHTS's does: one pass over the particles and one reduction per step.
//
// Why not the fluid's sampled velocity as u_s: it is piecewise per cell and changes every
// coupling step, so it has no Lipschitz bound the criterion could rest on; nor would a list's
// field be carried through a checkpoint. The scene's profile needs no state: a checkpoint's
// rebuild starts the same lists on resume.
//
// The ghost shell needs no widening however far the cells stream between builds: on one rank the
// periodic images are ghosts made at each build for every atom within cut-off + skin of an end,
// and a pair (or image pair) within reach at t was within reach + skin at the build by the bound
// above, so its image was made then and the pair listed; ghosts then move with their owners
// (LIGGGHTS's forward communication), and atoms are wrapped back into the box at the next build.
//
// On several MPI ranks the box is split across the vessel, never along it (`processors * * 1`;
// the fix refuses another grid). Every rank's sub-domain then spans the whole period, so the
// stream carries no atom out of its sub-domain: an atom leaves it only by its motion across the
// axis, at most |d_i| < skin / 2 between builds, as LIGGGHTS's own check allows. A pair of atoms
// of two ranks within reach at t was within reach + skin at the build (the bound above), so the
// ghost of one was made on the other's rank then, and follows its owner by forward
// communication; the periodic images along z are each rank's own, as on one rank. Split along z
// instead (LIGGGHTS's `processors 1 1 *`, the node's default), atoms would stream up to
// u_max tau out of their sub-domain, past the ghost shell: that is why the split is across.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <vector>

namespace LAMMPS_NS {
class LAMMPS;
class Fix;
}  // namespace LAMMPS_NS

namespace hemo::particles::dem {

constexpr const char* kStreamingNeighbourFix = "hemo_neighbours";

constexpr const char* kStreamingNeighbourStyle = "hemo/streaming_neighbours";
LAMMPS_NS::Fix* create_streaming_neighbours(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg);

// The input commands that hand the rebuild decision to the streaming criterion, for a vessel of
// `radius` (m) with `wall_shear_rate` (1/s). After `neighbor` (the skin) and the pair style.
std::vector<std::string> streaming_neighbour_commands(double radius, double wall_shear_rate);

}  // namespace hemo::particles::dem
