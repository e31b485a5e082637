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

// A rank's own bus whose kept messages are asked for again while the rank is busy elsewhere (in
// its node's collectives, in the DEM): a thread of its own answers the resend requests.
class AnsweringBus {
 public:
  AnsweringBus(const RunContext& ctx, const std::string& sender);
  ~AnsweringBus();
  AnsweringBus(const AnsweringBus&) = delete;
  AnsweringBus& operator=(const AnsweringBus&) = delete;
  Bus& bus() { return bus_; }
  // Throws std::runtime_error, naming `who`, when the thread lost the bus.
  void check(const std::string& who) const;
  // The bytes published on channels of `kind` (resends too) since the last call.
  std::uint64_t take_sent_bytes(const std::string& kind);

 private:
  Bus bus_;
  std::atomic<bool> stop_{false};
  mutable std::mutex error_mutex_;
  std::string error_;
  std::uint64_t sent_taken_ = 0;
  std::thread answering_;
};

// What a rank waits for each step: one message of that step on each of its pair channels, from
// the ranks of the other node it exchanges with; asks again for a late one by the retry interval
// and gives up after its patience.
class PairInbox {
 public:
  struct Source {
    int rank;  // the other node's
    std::string channel;
  };
  // `self`, `what`, `peer`: how a give-up names them ("particle rank 1", "fluid state",
  // "fluid rank"). `heard`: every pair channel of this rank, with each rank of the other node:
  // the sources may change (set_sources), and a message of the step waited for on one that is
  // not a source stops the wait.
  PairInbox(const RunContext& ctx, const std::string& sender, std::vector<Source> sources,
            const std::vector<Source>& heard, double patience_s, std::string self, std::string what,
            std::string peer);
  // From the next wait on (the overlap map after the particle ranks' boxes moved).
  void set_sources(std::vector<Source> sources) { sources_ = std::move(sources); }
  // True once every source's message of `step` came, waiting at most `seconds` (what came is
  // kept for the next call); `serve` is called between the polls. Throws std::runtime_error with
  // one line when one has not come within the patience.
  bool wait_within(std::int64_t step, double seconds, const std::function<void()>& serve);
  const std::vector<Source>& sources() const { return sources_; }
  // Source i's message of `step` (after wait_within said true).
  const Received& message(std::size_t i, std::int64_t step) const { return pending_.at({sources_[i].channel, step}); }
  // Drops what is of `step` or older (a resend answered twice, an early step's).
  void forget_through(std::int64_t step);
  // The bytes of every datagram of its channels it was handed since the last call.
  std::uint64_t take_received_bytes();

 private:
  std::vector<Source> sources_;
  std::map<std::string, int> heard_;  // channel -> the other node's rank
  double patience_s_;
  std::string self_, what_, peer_;
  Bus bus_;
  std::map<std::pair<std::string, std::int64_t>, Received> pending_;
  std::uint64_t received_taken_ = 0;
  std::int64_t waiting_for_ = -1;  // the step last waited for, and since when
  double waiting_since_ = 0, last_asked_ = 0;
};

// Fluid rank f's end of the state: every step, each reader's partition of the rank's state on
// FLUID_STATE.<f>.<p>, kept for resends of it and the step before.
class FluidRankPublisher {
 public:
  // `readers`: particle rank -> the cells it takes of this rank (from[p][f], global ids,
  // ascending); `global_of_local`: the global id of each of the rank's own cells, in its order.
  FluidRankPublisher(const RunContext& ctx, int rank, int ranks, int particle_ranks,
                     const std::map<int, std::vector<int>>& readers, const std::vector<int>& global_of_local);

  // Publishes every reader's partition of `local` (the rank's cells in its own order) as `step`.
  // Throws std::runtime_error when the resend thread lost the bus.
  void publish(const fluid_state_t& local, std::int64_t step);
  // The readers from the next publish on (the overlap map after the particle ranks' boxes
  // moved); what was published before stays kept for resends.
  void replan(const std::map<int, std::vector<int>>& readers);
  // The cells this rank publishes a step, summed over its readers.
  std::size_t cells_published() const;
  // The bytes of its partitions published (resends too) since the last call.
  std::uint64_t take_sent_bytes() { return out_.take_sent_bytes(channel::fluid_state); }

 private:
  struct Reader {
    std::string channel;
    std::vector<int> cells, local_index;
  };
  int rank_, ranks_, particle_ranks_;
  std::map<int, int> local_of_global_;
  std::map<int, Reader> readers_;
  AnsweringBus out_;
};

// Particle rank p's end of the state: the partitions of the fluid ranks it takes cells from,
// assembled into the whole mesh's arrays at the cells' global places (the cells it does not
// take stay zero).
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
  std::uint64_t take_received_bytes() { return in_.take_received_bytes(); }
  // The cells it takes from the next receive on (the overlap map after the boxes moved).
  void replan(const std::map<int, std::vector<int>>& from);

 private:
  int rank_, ranks_, fluid_ranks_;
  std::vector<std::vector<int>> cells_;  // per source of in_, the cells it sends
  std::string mesh_hash_;
  int n_cells_;
  PairInbox in_;
};

// Particle rank p's end of the feedback: every step, its partial feedback (the sums of its own
// particles) for the cells it takes of each fluid rank f on PARTICLE_FEEDBACK.<f>.<p>, kept for
// resends of it and the step before.
class ParticleRankPublisher {
 public:
  // `from`: fluid rank -> the cells (ascending) p takes of it, from[p][f].
  ParticleRankPublisher(const RunContext& ctx, int rank, int ranks, int fluid_ranks,
                        const std::map<int, std::vector<int>>& from);

  // Publishes to every fluid rank its cells of `partial` (the whole mesh's arrays) as `step`.
  // Throws std::runtime_error when the resend thread lost the bus.
  void publish(const particle_feedback_t& partial, std::int64_t step);
  // The cells from the next publish on; what was published stays kept for resends.
  void replan(const std::map<int, std::vector<int>>& from);
  // The bytes of its partials published (resends too) since the last call.
  std::uint64_t take_sent_bytes() { return out_.take_sent_bytes(channel::particle_feedback); }

 private:
  struct Fluid {
    std::string channel;
    std::vector<int> cells;
  };
  int rank_, ranks_, fluid_ranks_;
  std::map<int, Fluid> fluids_;
  AnsweringBus out_;
};

// Fluid rank f's end of the feedback: its readers' partials of a step, checked against the map
// and summed (in ascending particle rank, so that every run of the same ranks adds alike) into
// the whole mesh's arrays at its own cells' places (the other cells stay zero).
class FluidRankReceiver {
 public:
  // `readers`: particle rank -> the cells it takes of this rank (from[p][f], ascending).
  FluidRankReceiver(const RunContext& ctx, int rank, int ranks, int particle_ranks,
                    const std::map<int, std::vector<int>>& readers, std::string mesh_hash, int n_cells,
                    double patience_s);

  // Every reader's partial of `step`, summed; as ParticleRankReceiver::receive.
  particle_feedback_t receive(std::int64_t step, const std::function<void()>& serve = {});
  std::optional<particle_feedback_t> receive_within(std::int64_t step, double seconds,
                                                    const std::function<void()>& serve = {});
  std::uint64_t take_received_bytes() { return in_.take_received_bytes(); }
  // The readers and cells from the next receive on.
  void replan(const std::map<int, std::vector<int>>& readers);

 private:
  int rank_, ranks_, particle_ranks_;
  std::vector<std::vector<int>> cells_;
  std::string mesh_hash_;
  int n_cells_;
  PairInbox in_;
};

// The overlap map's pairs of fluid rank f: particle rank -> from[p][f].
std::map<int, std::vector<int>> readers_of(const OverlapMap& map, int fluid_rank);

// Each end of one rank of either node: what it publishes and what it receives.
struct FluidRankEnd {
  std::unique_ptr<FluidRankPublisher> state;
  std::unique_ptr<FluidRankReceiver> feedback;
};
struct ParticleRankEnd {
  std::unique_ptr<ParticleRankReceiver> state;
  std::unique_ptr<ParticleRankPublisher> feedback;
};

// A node program of one rank (no MPI: the analytic fluid, the prescribed particles) facing a peer
// on more: its ends of the partitioned exchange, after the port's initialize (the mesh published
// or received): the decomposition's message out (all cells its own; one box, the mesh's, with no
// margin), the peer's in, the map. Nothing when the peer runs on one rank too (the whole-mesh
// messages are the exchange). Throws std::runtime_error with one line.
std::optional<FluidRankEnd> open_one_rank_fluid_end(FluidPort& port, const mesh_t& mesh, const RunContext& ctx);
std::optional<ParticleRankEnd> open_one_rank_particle_end(ParticlePort& port, const mesh_t& mesh,
                                                          const RunContext& ctx);

}  // namespace hemo
