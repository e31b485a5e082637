// Fake nodes for the runtime's unit tests: threads in the test process that speak the node side
// of the protocol on the run's real bus (step orders in; heartbeats, step reports and
// checkpoint acknowledgements out), launched by the lockstep through FakeLauncher in place of
// the OpenFOAM and LIGGGHTS processes. A script says what each one does at each step: report
// it done, report it failed, die, die while writing its checkpoint, or freeze. Launched with
// --ranks N > 1, a fake node's ranks 1..N-1 report each step after its rank 0, each through
// the ranks' real reporter (common/rank_report.h), and may fall silent alone.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"
#include "node_launcher.h"

#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace hemo::test {

enum class Act {
  ok,                      // report the step done (and write and acknowledge its checkpoint if ordered)
  fail,                    // report the step failed, then exit with status 1
  die,                     // end without a word, as if killed
  die_writing_checkpoint,  // begin the step's checkpoint, then end without a word
  freeze,                  // stop heartbeats and answers, but keep running
  rank_stops,              // rank 0 reports the step done, the last rank falls silent (no beat, no report)
  give_up,                 // fail the step as a node that gave up on a silent coordinator, then exit 1
};

// One thing a fake node saw or did, in the order it happened across all fake nodes.
struct Event {
  enum Kind { ordered, reported } kind;
  std::string node;
  int launch = 0;  // 0: the node's first launch, 1: its first restart, ...
  long step = 0;
  int rank = 0;             // reported: which rank of the node
  bool checkpoint = false;  // ordered: write_checkpoint; reported: acknowledged one
  bool stop = false;        // ordered: the stop order
};

class Ledger {
 public:
  void add(Event e) {
    std::lock_guard<std::mutex> lock(mutex_);
    events_.push_back(std::move(e));
  }
  std::vector<Event> events() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return events_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Event> events_;
};

// What a launch was asked to run.
struct Launch {
  std::string node;
  int launch = 0;
  std::vector<std::string> argv;
  long resume_step = 0;  // --resume-step, 0 without
};

class FakeLauncher : public NodeLauncher {
 public:
  // Set before the run; called from the fake nodes' threads.
  std::function<Act(const std::string& node, int launch, long step)> script = [](const std::string&, int, long) {
    return Act::ok;
  };
  // Seconds a node computes a step (it listens to the bus meanwhile) and reports as compute_s;
  // of its start-up step, only reported (its set-up time).
  std::function<double(const std::string& node, long step)> compute_s = [](const std::string&, long) { return 0.0; };
  // Seconds between a node's rank 0's report of a step and its other ranks' (listening meanwhile).
  std::function<double(const std::string& node, long step)> ranks_later_s = [](const std::string&, long) {
    return 0.0;
  };
  // Seconds before a launched node sends its first heartbeat.
  std::function<double(const std::string& node, int launch)> start_delay_s = [](const std::string&, int) {
    return 0.0;
  };

  std::unique_ptr<NodeHandle> launch(const std::string& node, const std::vector<std::string>& argv,
                                     const std::string& log_path) override;

  std::vector<Launch> launches() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return launches_;
  }
  int launches_of(const std::string& node) const;

  Ledger ledger;

 private:
  mutable std::mutex mutex_;
  std::vector<Launch> launches_;
};

}  // namespace hemo::test
