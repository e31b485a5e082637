// The plasma of each fluid cell relaxing with its particles during a coupling interval
// (coupling.implicit_drag = "co_relaxed").
//
// Between two exchanges the fluid is frozen: every particle sees the plasma velocity U_seen of
// the last fluid step, and the fluid learns of their drag only when the interval is over. Where
// the cells' (DEM) mass in a fluid cell is comparable to its plasma's, that lag lets them exchange
// momentum with a plasma that never answers within the interval: the exchange then under-damps,
// and can feed, the contacts' oscillations (docs/scripts/coupling_cell_model.py --contact), and
// how much depends on the interval. Here each cell's plasma answers at every DEM step instead:
// its velocity is U_seen + shift_c, the shift moved by the reaction of its particles' drag,
//
//   M_c (shift' - shift) = - sum over its particles of dt_s (F_p + r_p beta_p shift'),
//
// M_c = rho (V_c - solid volume) the cell's plasma, F_p the step's fluid force on the particle
// (drag at U_seen with the exponential update of closures/exponential_drag.h, and lift),
// r_p beta_p the drag's slope in the plasma velocity, dt_s the step's share of the interval.
// Implicit in the new shift, so a cell's plasma and particles move towards their common
// velocity without overshooting whatever the step and the mass ratio, and what the particles
// gain the plasma loses, exactly. The fluid then takes the interval's impulse
// as an explicit source (the particle node hands it K = 0): the exchange has already been
// integrated with the plasma's inertia in it. The shift starts at 0 each interval: the fluid's
// new state already holds what the last interval's shifts held.
//
// Each particle reacts on the cell holding its centre (the deposition, which the fluid gets, may
// share it among cells: the shift is the interval's model of the plasma's answer, not its state).
//
// What it gets wrong: a cell's plasma answers as a free body, while the real plasma is
// incompressible and held by its neighbours. Over a long interval the particles drag their
// cell's plasma along and lose most of the resistance to moving relative to the rest of it: on
// the calibration scene at 1e-4 s the platelets' D comes out 7.6 times too large. It does remove
// the contact-exchange instability of dense suspensions (docs/performance.md §3 and §4).
//
// On several particle ranks a cell's sums are over every rank's particles in it. In the
// partitioned exchange only the ranks that take the cell can have particles there, so each rank
// sums with those ranks over the cells it shares with them (CellHaloSum): 32 B a shared cell and
// a DEM step, whatever the mesh; a rank then knows the plasma of every cell it takes, its
// neighbours' particles' answer included, and the ranks sharing a cell hold the same bits.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <vec.h>

#include <mpi.h>

#include <vector>

namespace hemo::particles {

class CellHaloSum;

class CellPlasmaRelaxation {
 public:
  // n_cells cells, every plasma mass 0 until set, every shift 0.
  explicit CellPlasmaRelaxation(int n_cells);

  // A new interval: the fluid's velocity already holds the last shifts.
  void start_interval();
  void set_plasma_mass(int cell, double kg) { mass_[cell] = kg; }

  // One particle's step: its fluid impulse at U_seen (N s, on the particle) and that impulse's
  // slope in the plasma velocity (kg: dt_s r beta).
  void add(int cell, const Vec3& impulse_at_seen_velocity, double slope) {
    double* s = &sums_[4 * static_cast<std::size_t>(cell)];
    if (!touched_mark_[static_cast<std::size_t>(cell)]) {
      touched_mark_[static_cast<std::size_t>(cell)] = 1;
      touched_.push_back(cell);
    }
    s[0] += impulse_at_seen_velocity.x();
    s[1] += impulse_at_seen_velocity.y();
    s[2] += impulse_at_seen_velocity.z();
    s[3] += slope;
  }
  // Ends the step: sums what every rank added and moves the shift of each cell with particles
  // implicitly. With `halo`, over the ranks sharing each cell (collective on its communicator);
  // without, over every rank of `comm`, whole-mesh (MPI_COMM_NULL: this process alone). The
  // cost is O(cells touched) with a halo or alone, O(cells) with the all-reduce.
  void relax(const CellHaloSum* halo, MPI_Comm comm);

  // The plasma velocity of `cell` is U_seen + shift(cell) (m/s).
  Vec3 shift(int cell) const {
    const double* d = &shift_[3 * static_cast<std::size_t>(cell)];
    return {d[0], d[1], d[2]};
  }
  double plasma_mass(int cell) const { return mass_[cell]; }
  int n_cells() const { return static_cast<int>(mass_.size()); }

 private:
  std::vector<double> mass_;   // kg per cell
  std::vector<double> shift_;  // m/s, 3 per cell
  std::vector<double> sums_;   // this step's impulse (3) and slope per cell
  std::vector<int> touched_;   // the cells add() reached this step, once each
  std::vector<char> touched_mark_;
  std::vector<int> shifted_;  // the cells whose shift this interval moved, once each
  std::vector<char> shifted_mark_;
  // Moves one cell's shift by its summed step and clears the sums.
  void relax_cell(int cell);
};

}  // namespace hemo::particles
