// Which ranks of a node have reported which step, and when each was last heard: the coordinator
// orders step k + 1 only once every rank of both nodes has reported step k (docs/design.md,
// "Lockstep"). Rank 0's report and heartbeat are the node's own (STEP_DONE, HEARTBEAT); every
// other rank reports and beats on channels of its own (common/rank_report.h). A rank not heard
// for the node timeout is named, by rank, while its node's rank 0 may still beat. Times are the
// caller's clock in seconds, so that this is tested with a clock held still.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace hemo {

class RankReports {
 public:
  // A node launched on `ranks` ranks at `now_s` (its hello may say another count: set_ranks).
  RankReports(int ranks, double now_s);

  int ranks() const { return static_cast<int>(ranks_.size()); }
  // The node's own count, from its hello; ranks added are starting up from `now_s`.
  void set_ranks(int ranks, double now_s);
  // Anything from rank `rank` (>= 1): its heartbeat or a report.
  void heard(int rank, double now_s);
  // Rank `rank` reported `step` done. False for a repeat, an older step or no such rank.
  bool reported(int rank, long step, double now_s);

  // The newest step every rank has reported (-1: none).
  long done_step() const;
  // The ranks that have not reported `step`, ascending.
  std::vector<int> missing(long step) const;

  // The first rank >= 1 silent for longer than it may be: `timeout_s` once heard, `startup_s`
  // before (it is starting up). Rank 0's silence is the node's (its heartbeat).
  struct Silence {
    int rank;
    bool started;  // heard at all since the launch
    double for_s;
  };
  std::optional<Silence> silent(double now_s, double timeout_s, double startup_s) const;
  // A pause of the coordinator itself (`away_s`) is nobody's silence.
  void forgive(double away_s, double now_s);

 private:
  struct Rank {
    long step = -1;  // the newest reported
    double last_heard = 0;
    bool heard = false;
  };
  std::vector<Rank> ranks_;
};

// "rank 1" or "ranks 0, 1", of a node of `of` ranks: "ranks 0, 1 of 2".
std::string rank_list_words(const std::vector<int>& ranks, int of);

}  // namespace hemo
