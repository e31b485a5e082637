// The particle node's bus connection on one or more MPI ranks: rank 0 alone holds the
// ParticlePort (joins the bus, heartbeats, publishes); what it receives — the mesh once, then
// each step's order — is broadcast (LCM-encoded) to the other ranks, so every rank runs the same
// steps. The fluid state comes whole to rank 0 and the feedback goes whole from it when both
// nodes run on one rank; else every rank takes the cells it needs from the fluid ranks that own
// them and sends them its partial feedback for those cells itself, on channels of its own (the
// partitioned exchange: common/rank_exchange.h, docs/notes/partitioned-exchange.md). The
// diagnostics are reduced over ranks; only rank 0's are published. Every other rank reports its
// own step to the coordinator (common/rank_report.h): its timings and bytes; rank 0's report
// carries its own and the node's diagnostics.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <mpi.h>
#include <node_port.h>
#include <overlap_map.h>
#include <rank_exchange.h>
#include <rank_report.h>

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
  // `make_port` is called on rank 0 only; every other rank joins the bus on `ctx` to report its
  // steps. Collective; throws on every rank when one could not.
  RankedPort(MPI_Comm comm, const RunContext& ctx, const std::function<std::unique_ptr<ParticlePort>()>& make_port);

  // The mesh, on every rank; rank 0 also hears how many ranks the fluid runs on (its hello).
  mesh_t initialize();
  // Whether the fluid state comes by partition (either node on more than one rank).
  bool partitioned() const { return partitioned_; }
  // Partitioned, collective: rank 0 publishes every rank's box and `margin` (DOMAIN) and takes
  // the fluid's decomposition (PARTITION); every rank computes the overlap map and opens its own
  // ends (the state in, the feedback out) on `ctx`'s bus. Returns the map. Throws ExchangeError
  // on every rank. `boxes_move`: the map's inputs are kept for publish_boxes (O(cells)).
  OverlapMap start_exchange(const mesh_t& mesh, const Box& box, double margin, const RunContext& ctx,
                            bool boxes_move = false);
  // Partitioned, collective, at a step the scene moves the slabs after (load_balance_after):
  // rank 0 publishes every rank's box and `margin` as DOMAIN of `step`, from which they hold
  // (whether or not they moved: the fluid waits for it); when they `moved`, every rank computes
  // the map of the new boxes and its ends use it from this step on, and the map is returned.
  // Throws ExchangeError on every rank.
  std::optional<OverlapMap> publish_boxes(const Box& box, double margin, std::int64_t step, bool moved);
  // Collective. Rank 0 publishes `feedback` (partitioned: every rank its own partial
  // `feedback`) and reports the step with `diag`, every other rank reports it with its own
  // bytes; every rank gets the next step or nothing (stop). When rank 0 fails to get a step (bus
  // error, timeout) every rank throws.
  // `before_state`, when given, is called on every rank with the new step's number once its
  // order is here and before its fluid state is taken (the slabs may move then: publish_boxes).
  std::optional<ParticleStep> advance(particle_feedback_t& feedback, const Diagnostics& diag,
                                      const std::function<void(std::int64_t)>& before_state = {});
  void finalize();
  // Rank 0 tells the coordinator (other ranks: nothing).
  void fail(const std::string& error);
  // The step being worked on (rank 0: the port's, which starts at a resumed run's step).
  std::int64_t step() const { return port_ ? port_->step() : step_; }
  int rank() const { return rank_; }

 private:
  enum Control : int { kContinue = 0, kStop = 1, kError = 2 };
  void broadcast_control(int& control, std::string& error);
  // Every rank's box and the margin, on every rank.
  ParticleDecomposition every_box(const Box& box, double margin) const;
  // What this rank reports: on rank 0 `diag` and its own bytes moved for the coupling since its
  // last report, on every other rank its bytes alone (rank<r>_sent_B, rank<r>_resent_B,
  // rank<r>_received_B, rank<r>_received_again_B, rank<r>_received_fluid_state_B,
  // rank<r>_sent_feedback_B, rank<r>_halo_B, rank<r>_sent_report_B; common/traffic.h).
  Diagnostics with_rank_traffic(const Diagnostics& diag);

  MPI_Comm comm_;
  int rank_ = 0;
  int ranks_ = 1;
  std::unique_ptr<ParticlePort> port_;
  std::int64_t step_ = 0;
  bool partitioned_ = false;
  int fluid_lag_ = 0;  // the port's, on every rank
  int fluid_ranks_ = 1;
  // The map's inputs other than the boxes, for when they move.
  CellPoints cell_points_;
  FluidDecomposition fluid_;
  std::optional<AxialPeriod> period_;
  std::string mesh_hash_;
  std::unique_ptr<ParticleRankReceiver> receiver_;
  std::unique_ptr<ParticleRankPublisher> publisher_;
  std::unique_ptr<RankReporter> reporter_;  // every rank's but 0's (several ranks)
};

}  // namespace hemo::particles
