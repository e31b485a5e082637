// What `hemocosim monitor` makes of a run's bus traffic (issue #23): per interval, the exchange
// latency of each direction, compute and wait per node, the step rate and ETA, bytes/s per
// channel, resends, every process's rejection counts and the nodes' latest diagnostics, as one
// JSON object (docs/design.md "Monitoring" documents its schema). The terminal table, the
// `--json` lines and the `--http` page all show this one row, so they cannot disagree.
// Pure bookkeeping: no bus, no clock of its own (times are passed in), so it is unit-tested
// without a run (tests/coordinator/test_monitor_stats.cpp).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"

#include <cstdint>
#include <deque>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace hemo {

// A process's bus counters as its heartbeat carries them (heartbeat_t).
struct ProcessCounts {
  std::int64_t accepted = 0;
  std::int64_t rejected_short = 0, rejected_foreign = 0, rejected_auth = 0, rejected_prestart = 0, rejected_replay = 0,
               rejected_undecodable = 0;
};

// The four exchanges of a coupling step and which way each goes; the latency is kept per channel.
struct Direction {
  const char* channel;
  const char* from_to;
};
const std::vector<Direction>& latency_directions();

inline constexpr const char* kMonitorSchema = "hemocosim-monitor/1";

class MonitorStats {
 public:
  // total_steps: the run's coupling steps (for the ETA); 0 when unknown.
  explicit MonitorStats(std::string run_id, long total_steps = 0, double rate_window_s = 10);

  // Every accepted message: its size, and its latency from sent (sender's clock, ns) to
  // received (this host's, µs); sent_unix_ns 0 (no stamp) or received 0 leave latency out. A
  // pair's channel of the partitioned exchange (FLUID_STATE.<f>.<p>) counts in its kind's latency.
  void message(const std::string& kind, const std::string& sender, std::int64_t step, std::size_t bytes,
               std::int64_t sent_unix_ns, std::int64_t received_unix_us, double now_s);
  void step_order(std::int64_t step, double time_s);
  void step_done(const std::string& node, std::int64_t step, bool ok, const std::string& error, double compute_s,
                 double wait_s, const std::vector<std::string>& names, const std::vector<double>& values);
  // The report of a node's rank >= 1 (its timings and bytes: rank<r>_sent_B, ...): shown with
  // the node's diagnostics, its timings as rank<r>_compute_s and rank<r>_wait_s.
  void rank_done(const std::string& node, int rank, std::int64_t step, double compute_s, double wait_s,
                 const std::vector<std::string>& names, const std::vector<double>& values);
  void heartbeat(const std::string& sender, double uptime_s, const ProcessCounts& counts);
  void own_counts(const ProcessCounts& counts) { own_ = counts; }
  // The imposed wall shear stress (model/momentum_balance.h) and the plasma's viscosity, to hold
  // the fluid's `wall_shear_stress_Pa` against; without them the row has the realised stress only.
  void balance_reference(const Scene& scene);

  // Ends the interval that began at the previous call (or at construction) and returns its row.
  // now_s: the monitor's monotonic clock; unix_s: the wall clock, for the row's time stamp.
  nlohmann::json close_interval(double now_s, double unix_s);

  // The last coupling step both nodes reported done (-1: none seen yet).
  std::int64_t completed_step() const;

 private:
  struct Latency {
    std::uint64_t n = 0;
    double sum_ms = 0, max_ms = 0, last_ms = 0;
  };
  struct Channel {
    std::uint64_t msgs = 0, bytes = 0, window_msgs = 0, window_bytes = 0;
    std::int64_t last_step = -1;
    std::string last_sender;
  };
  struct Node {
    std::int64_t step = -1;
    bool ok = true;
    std::string error;
    double window_compute = 0, window_wait = 0;
    int window_reports = 0;
    double last_compute = 0, last_wait = 0;
    std::vector<std::pair<std::string, double>> diagnostics;
    std::map<int, std::pair<std::int64_t, std::vector<std::pair<std::string, double>>>> ranks;  // r >= 1: step, values
  };
  struct Process {
    double last_heard_s = -1;
    double uptime_s = 0;
    std::optional<ProcessCounts> counts;
  };

  std::string run_id_;
  long total_steps_;
  double rate_window_s_;
  double started_s_ = -1, window_start_s_ = -1;
  std::map<std::string, Latency> latency_;  // channel -> this interval's
  std::map<std::string, Channel> channels_;
  std::map<std::string, Node> nodes_;
  std::map<std::string, Process> processes_;
  std::optional<ProcessCounts> own_;
  std::set<std::tuple<std::string, std::string, std::int64_t>> seen_;  // (kind, sender, step) of kept kinds
  std::uint64_t repeats_ = 0, resend_requests_ = 0, window_resend_requests_ = 0;
  std::int64_t ordered_step_ = -1;
  double time_s_ = 0;
  std::int64_t interval_start_completed_ = -1;
  std::deque<std::pair<double, std::int64_t>> history_;  // (now_s, completed step) at interval ends
  struct WallShear {
    std::optional<double> imposed_Pa, viscosity_Pa_s, mesh_ratio;
    double window_sum = 0;
    int window_samples = 0;
    std::optional<double> last_Pa;
  } wall_shear_;
};

// Step rate over a history of (time, completed step) and the ETA to `total` steps: what the
// monitor shows, separate so that its arithmetic is tested on its own. The rate is taken over the
// samples within `window_s` of the newest (at least two), so a stalled run's rate falls to 0.
struct RateEta {
  std::optional<double> steps_per_s;
  std::optional<double> eta_s;
};
RateEta rate_and_eta(const std::deque<std::pair<double, std::int64_t>>& history, double window_s, long total);

// The row as the terminal table (`hemocosim monitor` without --json).
std::string format_monitor_table(const nlohmann::json& row, const std::string& lcm_url);

}  // namespace hemo
