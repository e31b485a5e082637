// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_plasma.h"

#include <algorithm>
#include <stdexcept>

namespace hemo::particles {

CellPlasmaRelaxation::CellPlasmaRelaxation(int n_cells)
    : mass_(n_cells, 0.0), shift_(3 * mass_.size(), 0.0), sums_(4 * mass_.size(), 0.0) {}

void CellPlasmaRelaxation::start_interval() { std::fill(shift_.begin(), shift_.end(), 0.0); }

void CellPlasmaRelaxation::relax(MPI_Comm comm) {
  int ranks = 1;
  if (comm != MPI_COMM_NULL) MPI_Comm_size(comm, &ranks);
  if (ranks > 1)  // every rank takes part, whether or not it has particles
    MPI_Allreduce(MPI_IN_PLACE, sums_.data(), static_cast<int>(sums_.size()), MPI_DOUBLE, MPI_SUM, comm);
  for (std::size_t c = 0; c < mass_.size(); ++c) {
    double* s = &sums_[4 * c];
    if (s[3] == 0 && s[0] == 0 && s[1] == 0 && s[2] == 0) continue;
    double* d = &shift_[3 * c];
    const double m = mass_[c];
    // m (d' - d) = -(P + A d')  =>  d' = (m d - P) / (m + A)
    const double denominator = m + s[3];
    if (!(denominator > 0)) throw std::runtime_error("a fluid cell with particles has no plasma and no drag");
    for (int k = 0; k < 3; ++k) d[k] = (m * d[k] - s[k]) / denominator;
    std::fill(s, s + 4, 0.0);
  }
}

}  // namespace hemo::particles
