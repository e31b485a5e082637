// The coupling steps of a run: when each ends, how long it is, whether it writes output.
//
// Fixed intervals (time.coupling_relaxation_times = 0, the default): step k ends at k dt, dt =
// time.coupling_interval_s, for time.coupling_steps steps; output every output.every_steps
// steps and at the last.
//
// Adaptive intervals (time.coupling_relaxation_times = N > 0): the run covers the same physical
// time, and each interval is the longest dt_max / 2^j (dt_max = time.coupling_interval_s, j >= 0)
// that is at most N tau, tau the shortest drag relaxation time m / beta the particle node
// reported for its particles at the end of the step before (at start-up: at rest). Why the
// particles' relaxation: within an interval each side sees the other frozen, and what the
// exchange lags behind is the particles' answer to the plasma, which takes a few tau; N says
// how many relaxation times an interval may lag (docs/performance.md measures what N costs).
// Why powers of two: every interval then ends on a multiple of its own length, so the
// intervals land on the output times of the fixed clock (multiples of every_steps x dt_max)
// with no cut intervals, and a DEM step only changes when tau moves by a factor two. An
// interval grows back (one level per step) only where it ends on a multiple of the longer one.
// Time is counted in ticks of dt_max / 2^kMaxLevel, so it is exact however the levels change.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"

#include <cstdint>

namespace hemo {

class CouplingClock {
 public:
  // A clock whose last step done is first_step, ending at first_time_s (a resumed run; the
  // adaptive clock takes the time from the particle node's checkpoint, the fixed one computes it).
  CouplingClock(const Timing& time, const Output& output, long first_step = 0, double first_time_s = 0);

  struct Step {
    long number = 0;      // 1, 2, ...
    double time_s = 0;    // physical time at the step's end
    double dt_s = 0;      // the coupling interval
    bool output = false;  // write the nodes' output for this step
  };

  bool adaptive() const { return relaxation_times_ > 0; }
  bool finished() const { return ticks_ >= end_ticks_; }
  // The next step (call only while !finished()).
  Step next();
  // The shortest drag relaxation time the particle node reported for the step just done (s;
  // NaN or infinite: none, no bound). Sizes the intervals that follow.
  void observe_relaxation_time(double tau_s);

  long step() const { return step_; }
  double time_s() const { return seconds(ticks_); }
  double end_time_s() const { return seconds(end_ticks_); }
  // The number of steps when known in advance (fixed intervals), else 0.
  long total_steps() const { return adaptive() ? 0 : fixed_steps_; }
  int level() const { return level_; }  // the interval of the next step is dt_max / 2^level

  // The shortest interval is dt_max / 2^kMaxLevel: a relaxation time below it is an error.
  static constexpr int kMaxLevel = 30;

 private:
  double seconds(std::int64_t ticks) const { return static_cast<double>(ticks) * tick_s_; }

  double dt_max_s_, relaxation_times_, tick_s_;
  long fixed_steps_;
  std::int64_t end_ticks_, output_ticks_;  // the end, and the period of the output times
  long step_ = 0;
  std::int64_t ticks_ = 0;
  int level_ = 0;
};

}  // namespace hemo
