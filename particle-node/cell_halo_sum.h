// Per-cell values summed over the particle ranks that share the cells, without the whole mesh:
// the partitioned exchange's replacement for an all-reduce of whole-mesh arrays
// (docs/notes/partitioned-exchange.md, item 6). Used once a coupling step for the solid volume
// (the void fraction, the co-relaxed plasma's mass) and every DEM step for the co-relaxed
// plasma's impulse sums (cell_plasma.h).
//
// Each particle rank p deposits its own particles only, and only into the cells it takes of the
// fluid, needed(p) of the overlap map (ParticleNode checks it every step). A cell's total is
// then the sum over the ranks that take it, and p gets it for its cells by exchanging with each
// rank q the values of needed(p) ∩ needed(q), which is empty for ranks whose grown boxes are
// apart. Every rank adds a cell's values in ascending rank order, so that the ranks sharing it
// hold the same bits. A sum costs O(shared cells), in bytes and in time: nothing in it runs over
// the whole mesh. Collective: every rank of the communicator calls sum() together.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <mpi.h>
#include <overlap_map.h>

#include <cstdint>
#include <vector>

namespace hemo::particles {

class CellHaloSum {
 public:
  CellHaloSum(const OverlapMap& map, int rank, MPI_Comm comm);

  // `values`: per_cell values per cell of the whole mesh, this rank's own; on return each cell it
  // shares with another rank holds the sum over every rank that takes it (the rest unchanged).
  // Its bytes count as the rank's halo traffic (RankTraffic::halo).
  void sum(double* values, int per_cell) const;
  void sum(std::vector<double>& values, int per_cell) const { sum(values.data(), per_cell); }

  // The cells this rank shares with some other (ascending).
  const std::vector<int>& shared() const { return shared_; }
  // What one sum of `per_cell` values a cell sends (and receives): 8 B a value of each cell it
  // shares, once per rank it shares it with.
  std::uint64_t bytes(int per_cell) const;

 private:
  struct Peer {
    int rank;
    std::vector<int> cells;  // needed(rank_) ∩ needed(rank), ascending
    std::vector<int> slots;  // each cell's place in shared_
  };
  int rank_;
  MPI_Comm comm_;
  std::vector<Peer> peers_;  // ascending rank
  std::vector<int> shared_;
};

}  // namespace hemo::particles
