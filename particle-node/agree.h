// Errors that only some MPI ranks find (a damaged file of one rank) must stop every rank, before
// any collective step that the failing ranks would skip.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <mpi.h>

#include <climits>
#include <functional>
#include <stdexcept>
#include <string>

namespace hemo::particles {

// The error of the lowest rank that has one, on every rank ("" when no rank has one). Collective.
inline std::string agree_on_error(std::string error, MPI_Comm comm) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  int first = error.empty() ? INT_MAX : rank;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == INT_MAX) return {};
  int len = static_cast<int>(error.size());
  MPI_Bcast(&len, 1, MPI_INT, first, comm);
  error.resize(static_cast<std::size_t>(len));
  MPI_Bcast(error.data(), len, MPI_CHAR, first, comm);
  return error;
}

// Runs `check` on every rank; when it throws std::invalid_argument on some, throws the lowest
// rank's on all. Collective.
inline void agreed(const std::function<void()>& check, MPI_Comm comm) {
  std::string error;
  try {
    check();
  } catch (const std::invalid_argument& e) {
    error = e.what();
  }
  error = agree_on_error(error, comm);
  if (!error.empty()) throw std::invalid_argument(error);
}

}  // namespace hemo::particles
