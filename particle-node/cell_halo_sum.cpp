// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_halo_sum.h"

#include <traffic.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <iterator>

namespace hemo::particles {

CellHaloSum::CellHaloSum(const OverlapMap& map, int rank, MPI_Comm comm) : rank_(rank), comm_(comm) {
  const std::vector<int> mine = map.needed(rank);
  for (int q = 0; q < static_cast<int>(map.from.size()); ++q) {
    if (q == rank) continue;
    const std::vector<int> theirs = map.needed(q);
    Peer peer{q, {}};
    std::set_intersection(mine.begin(), mine.end(), theirs.begin(), theirs.end(), std::back_inserter(peer.cells));
    if (peer.cells.empty()) continue;
    std::vector<int> merged;
    std::set_union(shared_.begin(), shared_.end(), peer.cells.begin(), peer.cells.end(), std::back_inserter(merged));
    shared_ = std::move(merged);
    peers_.push_back(std::move(peer));
  }
}

void CellHaloSum::sum(std::vector<double>& values, int per_cell) const {
  const std::size_t k = static_cast<std::size_t>(per_cell);
  constexpr int kTag = 3601;
  std::vector<std::vector<double>> out(peers_.size()), in(peers_.size());
  std::vector<MPI_Request> requests;
  for (std::size_t i = 0; i < peers_.size(); ++i) {
    const Peer& peer = peers_[i];
    for (int c : peer.cells)
      out[i].insert(out[i].end(), values.begin() + static_cast<std::ptrdiff_t>(k * c),
                    values.begin() + static_cast<std::ptrdiff_t>(k * c + k));
    in[i].resize(out[i].size());
    requests.emplace_back();
    MPI_Irecv(in[i].data(), static_cast<int>(in[i].size()), MPI_DOUBLE, peer.rank, kTag, comm_, &requests.back());
    requests.emplace_back();
    MPI_Isend(out[i].data(), static_cast<int>(out[i].size()), MPI_DOUBLE, peer.rank, kTag, comm_, &requests.back());
    const std::uint64_t bytes = sizeof(double) * static_cast<std::uint64_t>(out[i].size());
    RankTraffic::sent(bytes);
    RankTraffic::received(bytes);
  }
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
  // Ascending rank order, this rank's own among them: every rank sharing a cell adds alike.
  std::vector<double> total(values.size(), 0.0);
  auto add = [&](const std::vector<int>& cells, const double* from) {
    for (std::size_t j = 0; j < cells.size(); ++j)
      for (std::size_t d = 0; d < k; ++d) total[k * static_cast<std::size_t>(cells[j]) + d] += from[k * j + d];
  };
  std::vector<double> own;
  for (int c : shared_)
    own.insert(own.end(), values.begin() + static_cast<std::ptrdiff_t>(k * c),
               values.begin() + static_cast<std::ptrdiff_t>(k * c + k));
  bool own_added = false;
  for (std::size_t i = 0; i < peers_.size(); ++i) {
    if (!own_added && peers_[i].rank > rank_) {
      add(shared_, own.data());
      own_added = true;
    }
    add(peers_[i].cells, in[i].data());
  }
  if (!own_added) add(shared_, own.data());
  for (int c : shared_)
    for (std::size_t d = 0; d < k; ++d) values[k * static_cast<std::size_t>(c) + d] = total[k * static_cast<std::size_t>(c) + d];
}

}  // namespace hemo::particles
