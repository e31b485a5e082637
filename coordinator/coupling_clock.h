// The coupling steps of a run: when each ends, how long it is and whether it writes output.
//
// Fixed intervals (time.max_flow_change = 0, the default): step k ends at k dt, dt =
// time.coupling_interval_s, for time.coupling_steps steps; output every output.every_steps steps
// and at the last.
//
// Adaptive intervals (time.max_flow_change = c > 0): the run covers the same physical time,
// coupling_steps x coupling_interval_s, with each interval as long as the flow allows: the
// fluid reports how much the step changed it (velocity_change = max|dU| / max|U|), and the next
// interval is sized so that change stays at c, growing at most 1.5x per step, never longer than
// coupling_interval_s nor shorter than 1/1000 of it. The change grows with the interval (to
// first order, linearly), so a flow that settles earns long intervals and a flow in a transient
// short ones. Output is written at the same physical times as with fixed intervals
// (every_steps x coupling_interval_s): an interval that would pass one is cut to end on it.
//
// Why the flow's change and not the particles' relaxation times: the particles see the flow
// frozen over an interval and, with the exponential drag, follow it at any DEM step; their
// relaxation times (microseconds for blood cells) are far below any useful interval and bound
// nothing. What the interval must resolve is how fast the flow they see moves on.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "scene.h"

namespace hemo {

class CouplingClock {
 public:
  CouplingClock(const Timing& time, const Output& output);

  struct Step {
    long number = 0;      // 1, 2, ...
    double time_s = 0;    // physical time at the step's end
    double dt_s = 0;      // the coupling interval
    bool output = false;  // write the nodes' output for this step
  };

  bool adaptive() const { return max_change_ > 0; }
  bool finished() const;
  // The next step (call only while !finished()).
  Step next();
  // What the fluid reported for the step just done: max|dU| / max|U| over it.
  void observe_flow_change(double velocity_change);

  double end_time() const { return end_time_; }
  long fixed_steps() const { return fixed_steps_; }  // the number of steps at fixed intervals

  // The bounds of an adaptive interval, as multiples of time.coupling_interval_s.
  static constexpr double kMinFraction = 1e-3;
  static constexpr double kMaxGrowth = 1.5;

 private:
  double dt_max_, max_change_, end_time_, output_period_;
  long fixed_steps_, every_steps_;
  long step_ = 0;
  double time_ = 0;
  double last_dt_ = 0;
  double planned_dt_;     // the adaptive interval wanted next, before cutting to an output time
  long next_output_ = 1;  // index of the next output time (adaptive)
};

}  // namespace hemo
