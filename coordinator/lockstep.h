// The serial (Gauss-Seidel) lockstep of docs/design.md: the coordinator orders step k, both nodes
// report it done, and only then is step k+1 ordered. It also watches the nodes' health.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"
#include "liveness.h"
#include "node_launcher.h"
#include "rank_reports.h"
#include "run_directory.h"
#include "run_files.h"
#include "scene.h"

#include <fstream>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace hemo {

// A step whose reports break a stability guard (stability_guard.h): the nodes are healthy and
// can still be stopped in order, writing their final state.
struct UnstableRun : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A node that died or stopped answering (heartbeat timeout), rather than one that reported a
// failed step: the coordinator may restart both nodes from their last common checkpoint.
struct NodeLost : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Lockstep {
 public:
  // Launches both nodes through `launcher` (which must outlive the lockstep): from scratch
  // (first_step 0) or from the run's checkpoint of first_step.
  Lockstep(const Scene& scene, RunDirectory dir, const RunContext& ctx, NodeLauncher& launcher, long first_step = 0);
  ~Lockstep();

  // Orders step k (time at its end, its interval; output, checkpoint wanted or not).
  void order(long step, double time_s, double dt_s, bool write_output, bool write_checkpoint = false);
  // Waits until every rank of both nodes has reported step k done; throws a one-line error
  // naming the node (and rank) that failed, exited or stopped answering (NodeLost for the last two).
  void await(long step, double timeout_s);
  // Until the bus check (check_bus) has passed: called once the nodes are up, before the first
  // step is ordered, so that a run shorter than a heartbeat does not end with the check
  // undecided. Their heartbeats ran through their set-up, so it rarely waits; a node that has
  // written no report by then (another program swapped in) is not waited for.
  void settle_bus_check();
  // Orders the nodes to finish and waits for their clean exit.
  void stop(long step);

  // The newest checkpoint both nodes have acknowledged (-1: none yet).
  long common_checkpoint() const;

  // Per-node seconds of the last step: computing and waiting.
  double compute_s(const std::string& node) const { return nodes_.at(node).compute; }
  double wait_s(const std::string& node) const { return nodes_.at(node).wait; }
  // The value a node reported for the last step it finished, or at start-up (NaN: none).
  double diagnostic(const std::string& node, const std::string& name) const;

  // Where the time of the coupled steps went: per node, compute and wait and the phases the
  // node reports (diagnostics named phase_*_s), and the coupling overhead of the lockstep
  // itself (step wall time not spent computing in either node). Written to RUN_DIR/profile.csv,
  // with the bytes per step each rank of each node and the coordinator sent and received
  // (common/traffic.h): rows NODE,NAME_per_step,BYTES, (a mean over the steps; NAME as the node
  // reports it, rank<r>_sent_B, bus_sent_fluid_state_B, ...).
  std::string profile_report(double wall_s, long steps) const;

 private:
  struct NodeState {
    std::unique_ptr<NodeHandle> process;
    double last_heard = 0;
    bool heard = false;  // anything from it since it was launched (before that, it is starting up)
    bool said_hello = false;  // its rank count is its hello's, not the launch's
    RankReports reports{1, 0};  // which of its ranks reported which step (rank 0: the node's report)
    long checkpoint_step = -1;  // the newest checkpoint the node acknowledged
    double compute = 0, wait = 0;
    std::map<std::string, double> totals;  // compute_s, wait_s and the node's phase_* times, summed
    std::map<std::string, double> bytes;   // the node's byte counts (diagnostics *_B), summed
    std::map<std::string, double> last;    // the diagnostics of the last step done
  };
  void launch(const std::string& node, const std::string& command, const char* default_program, int ranks,
              long first_step);
  // From a node's hello (or its launch): listens to the channels of its ranks >= 1.
  void listen_to_ranks(const std::string& node);
  void check_health(long step);
  std::string why_silent(const std::string& name, NodeState& node) const;
  void forgive_own_pause(long step, double* step_started);
  // The bus check at start-up (docs/hosts.md): once both nodes reported whose heartbeats they
  // hear, every process must hear every other within run.bus_check_s, or the run stops with one
  // line naming who does not hear whom.
  void check_bus();
  // Handles what reaches the coordinator within wait_s: who was heard, the step reports.
  void hear(double wait_s);
  void record(const Received& msg);
  // A report of rank `rank` >= 1 of `node` (its timings and bytes).
  void record_rank(const Received& msg, const std::string& node, int rank);
  // Appends the reports recorded so far to RUN_DIR/metrics.csv. Called once the next step is
  // ordered (the coordinator would otherwise keep the nodes waiting while it formats them), at
  // the stop and when the lockstep ends, also by an error.
  void write_metrics();

  const Scene& scene_;
  RunDirectory dir_;
  RunContext ctx_;
  NodeLauncher& launcher_;
  long first_step_ = 0;  // the step the nodes started from
  std::unique_ptr<Bus> bus_;
  std::unique_ptr<Heartbeat> heartbeat_;
  std::map<std::string, NodeState> nodes_;
  struct RankOf {
    std::string node;
    int rank;
  };
  std::map<std::string, RankOf> rank_senders_;  // "particles.1" -> its node and rank
  AppendFile metrics_;  // rows appended whole (common/run_files.h)
  struct MetricsRow {
    long step;
    double time_s;
    std::string source;  // a node, or "lockstep" for the step's wall time and coupling overhead
    std::string name;
    double value;
  };
  std::vector<MetricsRow> unwritten_;  // rows not yet in metrics_
  double step_time_s_ = 0;
  double ordered_at_ = 0;                      // wall clock when the current step was ordered
  double stepping_wall_s_ = 0;                 // sum over steps >= 1 of order-to-all-done wall time
  double overhead_s_ = 0;                      // the part of it no node spent computing (see profile_report)
  std::map<std::string, double> own_bytes_;    // the coordinator's bytes of the steps, summed (rank0_sent_B, ...)
  std::string unstable_;                       // the first broken stability guard, if any
  bool bus_checked_ = false;                   // every process heard every other
  double bus_checked_at_ = 0;                  // when check_bus last looked
  std::map<std::string, double> reported_at_;  // when a node's heard report first appeared
  PauseWatch pauses_;                          // the coordinator's own pauses (liveness.h)
  double paused_s_ = 0;                        // the last of them (s; 0: none)
};

}  // namespace hemo
