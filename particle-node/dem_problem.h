// The error a DEM run ends with: of all the problems its steps noted on any rank (a particle
// outside the mesh, a non-finite state or force, an unstable spin), the one of the particle with
// the smallest id, so that every rank reports the same line.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <mpi.h>

#include <cstdint>
#include <string>
#include <utility>

namespace hemo::particles {

class FirstProblem {
 public:
  void clear() { what_.clear(); }
  void note(int tag, std::string what) {
    if (what_.empty() || tag < tag_) {
      tag_ = tag;
      what_ = std::move(what);
    }
  }
  // The problem of the smallest particle id over all ranks, known to every rank ("" when none).
  // Collective.
  std::string agree(MPI_Comm comm) const {
    struct {
      int tag;
      int rank;
    } mine{what_.empty() ? INT32_MAX : tag_, 0}, best;
    MPI_Comm_rank(comm, &mine.rank);
    MPI_Allreduce(&mine, &best, 1, MPI_2INT, MPI_MINLOC, comm);
    if (best.tag == INT32_MAX) return {};
    int len = static_cast<int>(what_.size());
    MPI_Bcast(&len, 1, MPI_INT, best.rank, comm);
    std::string msg = what_;
    msg.resize(static_cast<std::size_t>(len));
    MPI_Bcast(msg.data(), len, MPI_CHAR, best.rank, comm);
    return msg;
  }

 private:
  std::string what_;  // on this rank
  int tag_ = 0;
};

}  // namespace hemo::particles
