// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_plasma.h"

#include "cell_halo_sum.h"

#include <traffic.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>

namespace hemo::particles {

CellPlasmaRelaxation::CellPlasmaRelaxation(int n_cells)
    : mass_(n_cells, 0.0),
      shift_(3 * mass_.size(), 0.0),
      sums_(4 * mass_.size(), 0.0),
      touched_mark_(mass_.size(), 0),
      shifted_mark_(mass_.size(), 0) {}

void CellPlasmaRelaxation::start_interval() {
  // Only the cells an interval moved hold a shift: O(cells moved), not O(mesh), a coupling step.
  for (const int c : shifted_) {
    std::fill_n(shift_.begin() + 3 * static_cast<std::ptrdiff_t>(c), 3, 0.0);
    shifted_mark_[static_cast<std::size_t>(c)] = 0;
  }
  shifted_.clear();
}

void CellPlasmaRelaxation::relax(const CellHaloSum* halo, MPI_Comm comm) {
  int ranks = 1;
  if (comm != MPI_COMM_NULL) MPI_Comm_size(comm, &ranks);
  if (halo) {
    halo->sum(sums_, 4);
    // A shared cell another rank's particles reached moves here too: this rank may have
    // particles there later in the interval.
    for (int c : halo->shared()) relax_cell(c);
  } else if (ranks > 1) {  // every rank takes part, whether or not it has particles
    MPI_Allreduce(MPI_IN_PLACE, sums_.data(), static_cast<int>(sums_.size()), MPI_DOUBLE, MPI_SUM, comm);
    RankTraffic::all_reduce(sizeof(double) * static_cast<std::uint64_t>(sums_.size()), ranks);
    for (int c = 0; c < n_cells(); ++c) relax_cell(c);
  }
  for (int c : touched_) {
    relax_cell(c);
    touched_mark_[static_cast<std::size_t>(c)] = 0;
  }
  touched_.clear();
}

void CellPlasmaRelaxation::relax_cell(int cell) {
  double* s = &sums_[4 * static_cast<std::size_t>(cell)];
  if (s[3] == 0 && s[0] == 0 && s[1] == 0 && s[2] == 0) return;  // no particles, or already moved
  double* d = &shift_[3 * static_cast<std::size_t>(cell)];
  if (!shifted_mark_[static_cast<std::size_t>(cell)]) {
    shifted_mark_[static_cast<std::size_t>(cell)] = 1;
    shifted_.push_back(cell);
  }
  const double m = mass_[static_cast<std::size_t>(cell)];
  // m (d' - d) = -(P + A d')  =>  d' = (m d - P) / (m + A)
  const double denominator = m + s[3];
  if (!(denominator > 0)) throw std::runtime_error("a fluid cell with particles has no plasma and no drag");
  for (int k = 0; k < 3; ++k) d[k] = (m * d[k] - s[k]) / denominator;
  std::fill(s, s + 4, 0.0);
}

}  // namespace hemo::particles
