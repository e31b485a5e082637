// The ranks' own ends of the partitioned exchange (docs/notes/partitioned-exchange.md): each
// rank of a node that runs on more than one, or whose peer does, joins the bus as a sender of
// its own (fluid.<f>, particles.<p>), so that every receiver checks its messages against that
// rank's own replay window and a lost one is asked of the one rank that kept it. The node's
// rank 0 still holds the NodePort (hello, orders, reports, heartbeat); these carry the state.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"
#include "node_port.h"
#include "partition_exchange.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace hemo {

// "fluid.3": rank 3's sender name of the node whose rank 0 says hello as `role`.
std::string rank_sender(const std::string& role, int rank);

// Fluid rank f's end: every step, each reader's partition of the rank's state on
// FLUID_STATE.<f>.<p>, kept for resends of it and the step before; the resends are answered by
// a thread of its own, as the rank spends the particles' wait in its node's collectives.
class FluidRankPublisher {
 public:
  // `readers`: particle rank -> the cells it takes of this rank (from[p][f], global ids,
  // ascending); `global_of_local`: the global id of each of the rank's own cells, in its order.
  FluidRankPublisher(const RunContext& ctx, int rank, int ranks, int particle_ranks,
                     const std::map<int, std::vector<int>>& readers, const std::vector<int>& global_of_local);
  ~FluidRankPublisher();
  FluidRankPublisher(const FluidRankPublisher&) = delete;
  FluidRankPublisher& operator=(const FluidRankPublisher&) = delete;

  // Publishes every reader's partition of `local` (the rank's cells in its own order) as `step`.
  // Throws std::runtime_error when the resend thread lost the bus.
  void publish(const fluid_state_t& local, std::int64_t step);
  // The cells this rank publishes a step, summed over its readers.
  std::size_t cells_published() const;
  // The bytes of its partitions published (resends too) since the last call.
  std::uint64_t take_sent_bytes();

 private:
  struct Reader {
    std::string channel;
    std::vector<int> cells, local_index;
  };
  int rank_;
  std::map<int, Reader> readers_;
  Bus bus_;
  std::atomic<bool> stop_{false};
  mutable std::mutex error_mutex_;
  std::string error_;  // the resend thread's, when it lost the bus
  std::uint64_t sent_taken_ = 0;
  std::thread answering_;
};

// Particle rank p's end: the partitions of the fluid ranks it takes cells from, assembled into
// the whole mesh's arrays at the cells' global places (the cells it does not take stay zero).
class ParticleRankReceiver {
 public:
  // `from`: fluid rank -> the cells (ascending) p takes of it; `patience_s`: how long a step's
  // partitions may keep it waiting before it gives up.
  ParticleRankReceiver(const RunContext& ctx, int rank, int ranks, int fluid_ranks,
                       const std::map<int, std::vector<int>>& from, std::string mesh_hash, int n_cells,
                       double patience_s);

  // Every fluid rank's partition of `step`, checked against the map and assembled; asks again
  // for one late by the retry interval. Throws std::runtime_error with one line when one does not
  // fit (the rank, the cell) or one has not come within the patience.
  // `serve`, when given, is called between the polls: a rank that also holds the node's port
  // answers its peers' resend requests there (NodePort::serve) while it waits.
  fluid_state_t receive(std::int64_t step, const std::function<void()>& serve = {});
  // The same, waiting at most `seconds`: nothing when some partition has not come yet (what
  // came is kept for the next call).
  std::optional<fluid_state_t> receive_within(std::int64_t step, double seconds,
                                              const std::function<void()>& serve = {});
  // The bytes of the partitions it was handed (every datagram of its channels) since the last call.
  std::uint64_t take_received_bytes();

 private:
  struct Source {
    int fluid_rank;
    std::string channel;
    std::vector<int> cells;
  };
  int rank_;
  std::vector<Source> sources_;
  std::string mesh_hash_;
  int n_cells_;
  double patience_s_;
  Bus bus_;
  std::map<std::pair<std::string, std::int64_t>, Received> pending_;
  std::uint64_t received_taken_ = 0;
  std::int64_t waiting_for_ = -1;  // the step receive_within was last called for, and since when
  double waiting_since_ = 0, last_asked_ = 0;
};

// A node program of one rank (no MPI: the analytic fluid, the prescribed particles) facing a peer
// on more: its end of the partitioned exchange, after the port's initialize (the mesh published
// or received): the decomposition's message out (all cells its own; one box, the mesh's, with no
// margin), the peer's in, the map. Nothing when the peer runs on one rank too (the whole-mesh
// messages are the exchange). Throws std::runtime_error with one line.
std::unique_ptr<FluidRankPublisher> open_one_rank_fluid_end(FluidPort& port, const mesh_t& mesh,
                                                            const RunContext& ctx);
std::unique_ptr<ParticleRankReceiver> open_one_rank_particle_end(ParticlePort& port, const mesh_t& mesh,
                                                                 const RunContext& ctx);

}  // namespace hemo
