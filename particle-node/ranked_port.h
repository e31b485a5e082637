// The particle node's bus connection on one or more MPI ranks: rank 0 alone holds the
// ParticlePort (joins the bus, heartbeats, publishes); what it receives — the mesh once, then
// each step's order — is broadcast (LCM-encoded) to the other ranks, so every rank runs the same
// steps. The fluid state comes whole to rank 0 and the feedback goes whole from it when both
// nodes run on one rank; else every rank takes the cells it needs from the fluid ranks that own
// them and sends them its partial feedback for those cells itself, on channels of its own (the
// partitioned exchange: common/rank_exchange.h, docs/notes/partitioned-exchange.md). The
// diagnostics are reduced over ranks; only rank 0's are published, with every rank's bytes of
// the step.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <mpi.h>
#include <node_port.h>
#include <overlap_map.h>
#include <rank_exchange.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace hemo::particles {

// A fluid state that does not fit what this rank expects, or does not come: every rank knows it
// (agreed), so the node stops cleanly with its one line.
class ExchangeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class RankedPort {
 public:
  // `make_port` is called on rank 0 only.
  RankedPort(MPI_Comm comm, const std::function<std::unique_ptr<ParticlePort>()>& make_port);

  // The mesh, on every rank; rank 0 also hears how many ranks the fluid runs on (its hello).
  mesh_t initialize();
  // Whether the fluid state comes by partition (either node on more than one rank).
  bool partitioned() const { return partitioned_; }
  // Partitioned, collective: rank 0 publishes every rank's box and `margin` (DOMAIN) and takes
  // the fluid's decomposition (PARTITION); every rank computes the overlap map and opens its own
  // ends (the state in, the feedback out) on `ctx`'s bus. Returns the map. Throws ExchangeError
  // on every rank.
  OverlapMap start_exchange(const mesh_t& mesh, const Box& box, double margin, const RunContext& ctx);
  // Collective. Rank 0 publishes `feedback` and `diag` (partitioned: every rank publishes its
  // own partial `feedback`, rank 0 `diag`); every rank gets the next step or nothing (stop).
  // When rank 0 fails to get a step (bus error, timeout) every rank throws.
  std::optional<ParticleStep> advance(particle_feedback_t& feedback, const Diagnostics& diag);
  void finalize();
  // Rank 0 tells the coordinator (other ranks: nothing).
  void fail(const std::string& error);
  // The step being worked on (rank 0: the port's, which starts at a resumed run's step).
  std::int64_t step() const { return port_ ? port_->step() : step_; }
  int rank() const { return rank_; }

 private:
  enum Control : int { kContinue = 0, kStop = 1, kError = 2 };
  void broadcast_control(int& control, std::string& error);
  // `diag` and, on rank 0, the bytes each rank moved for the coupling since its last report
  // (rank<r>_sent_B, rank<r>_received_B; common/traffic.h); collective.
  Diagnostics with_rank_traffic(const Diagnostics& diag);

  MPI_Comm comm_;
  int rank_ = 0;
  int ranks_ = 1;
  std::unique_ptr<ParticlePort> port_;
  std::int64_t step_ = 0;
  bool partitioned_ = false;
  int fluid_lag_ = 0;  // the port's, on every rank
  int fluid_ranks_ = 1;
  std::unique_ptr<ParticleRankReceiver> receiver_;
  std::unique_ptr<ParticleRankPublisher> publisher_;
};

}  // namespace hemo::particles
