// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_halo_sum.h"

#include <traffic.h>

#include <algorithm>
#include <cstddef>
#include <iterator>

namespace hemo::particles {

CellHaloSum::CellHaloSum(const OverlapMap& map, int rank, MPI_Comm comm) : rank_(rank), comm_(comm) {
  const std::vector<int> mine = map.needed(rank);
  for (int q = 0; q < static_cast<int>(map.from.size()); ++q) {
    if (q == rank) continue;
    const std::vector<int> theirs = map.needed(q);
    Peer peer{q, {}, {}};
    std::set_intersection(mine.begin(), mine.end(), theirs.begin(), theirs.end(), std::back_inserter(peer.cells));
    if (peer.cells.empty()) continue;
    std::vector<int> merged;
    std::set_union(shared_.begin(), shared_.end(), peer.cells.begin(), peer.cells.end(), std::back_inserter(merged));
    shared_ = std::move(merged);
    peers_.push_back(std::move(peer));
  }
  for (Peer& peer : peers_)
    for (int c : peer.cells)
      peer.slots.push_back(static_cast<int>(std::lower_bound(shared_.begin(), shared_.end(), c) - shared_.begin()));
}

std::uint64_t CellHaloSum::bytes(int per_cell) const {
  std::uint64_t values = 0;
  for (const Peer& peer : peers_) values += static_cast<std::uint64_t>(per_cell) * peer.cells.size();
  return sizeof(double) * values;
}

void CellHaloSum::sum(double* values, int per_cell) const {
  const std::size_t k = static_cast<std::size_t>(per_cell);
  constexpr int kTag = 3601;
  std::vector<std::vector<double>> out(peers_.size()), in(peers_.size());
  std::vector<MPI_Request> requests;
  for (std::size_t i = 0; i < peers_.size(); ++i) {
    const Peer& peer = peers_[i];
    for (int c : peer.cells) out[i].insert(out[i].end(), values + k * c, values + k * c + k);
    in[i].resize(out[i].size());
    requests.emplace_back();
    MPI_Irecv(in[i].data(), static_cast<int>(in[i].size()), MPI_DOUBLE, peer.rank, kTag, comm_, &requests.back());
    requests.emplace_back();
    MPI_Isend(out[i].data(), static_cast<int>(out[i].size()), MPI_DOUBLE, peer.rank, kTag, comm_, &requests.back());
  }
  RankTraffic::halo(bytes(per_cell));
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
  // Ascending rank order, this rank's own among them: every rank sharing a cell adds alike.
  std::vector<double> total(k * shared_.size(), 0.0);
  auto add_own = [&] {
    for (std::size_t j = 0; j < shared_.size(); ++j)
      for (std::size_t d = 0; d < k; ++d) total[k * j + d] += values[k * static_cast<std::size_t>(shared_[j]) + d];
  };
  bool own_added = false;
  for (std::size_t i = 0; i < peers_.size(); ++i) {
    if (!own_added && peers_[i].rank > rank_) {
      add_own();
      own_added = true;
    }
    const std::vector<int>& slots = peers_[i].slots;
    for (std::size_t j = 0; j < slots.size(); ++j)
      for (std::size_t d = 0; d < k; ++d) total[k * static_cast<std::size_t>(slots[j]) + d] += in[i][k * j + d];
  }
  if (!own_added) add_own();
  for (std::size_t j = 0; j < shared_.size(); ++j)
    std::copy_n(total.begin() + static_cast<std::ptrdiff_t>(k * j), k, values + k * static_cast<std::size_t>(shared_[j]));
}

}  // namespace hemo::particles
