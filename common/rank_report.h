// The step report of one rank of a node on several MPI ranks (docs/design.md, "Lockstep"): the
// coordinator orders step k + 1 only once every rank of both nodes has reported step k, so each
// rank but 0 reports its own step, on a channel of its own (channel::rank_report), with its own
// timings and bytes. Rank 0's report is the node's, on STEP_DONE through its NodePort, with the
// node's reduced physics diagnostics beside its own timings and bytes.
//
// A rank reports step k after it has published and kept what it sends for step k: an order
// k + 1 then makes no one wait for anything that can be missing for good. Its reports are kept
// (the last two steps) and published again when the coordinator asks, by a thread of the rank's
// own, since the rank spends its waits in its node's collectives, not polling a bus. The same
// thread beats twice a second on the rank's heartbeat channel, heard by the coordinator alone:
// a rank that stops (killed, frozen, its host gone) is named while its node's rank 0 still beats.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"
#include "node_port.h"
#include "traffic.h"

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace hemo {

// The bytes one rank moved for the coupling since its last report, named as profile.csv's
// per-rank columns have them: rank<r>_sent_B and rank<r>_received_B, and of them what loss cost,
// rank<r>_resent_B and rank<r>_received_again_B (traffic.h).
Diagnostics rank_bytes(int rank, const TrafficBytes& bytes);

class RankReporter {
 public:
  // Rank `rank` (>= 1) of the node that says hello as `role`; joins the bus as that rank's sender
  // (rank_sender: "fluid.1").
  RankReporter(const RunContext& ctx, const std::string& role, int rank);
  ~RankReporter();
  RankReporter(const RankReporter&) = delete;
  RankReporter& operator=(const RankReporter&) = delete;

  // Reports `step` done: its computing time (since begin_step), the wait before it, and `diag`
  // (the rank's bytes; a resumed node's first report, of a step the coordinator has, goes
  // without). Throws std::runtime_error when the resend thread lost the bus.
  void report(std::int64_t step, const Diagnostics& diag);
  // The rank has the next step's order and inputs: its wait ends and its computing begins.
  void begin_step();
  // Its computing ends: what it does until report() (publishing its part) is coupling.
  void end_computing() { computing_ended_at_ = now(); }
  // The bytes of its reports and heartbeats published (resends too) since the last call: what
  // reporting by rank costs the rank (rank<r>_sent_report_B).
  std::uint64_t take_sent_bytes();

 private:
  static double now();

  std::string role_;
  int rank_;
  std::string channel_;
  Bus bus_;
  double step_started_;
  double computing_ended_at_ = -1;  // end_computing's for this step; < 0: report() ends it
  double waiting_since_ = 0;
  double wait_s_ = 0;  // of the step being computed: from the last report to its order
  std::atomic<bool> stop_{false};
  mutable std::mutex error_mutex_;
  std::string error_;  // the resend thread's, when it lost the bus
  std::uint64_t sent_taken_ = 0;
  std::thread answering_;
};

}  // namespace hemo
