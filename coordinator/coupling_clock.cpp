// SPDX-License-Identifier: GPL-3.0-or-later
#include "coupling_clock.h"

#include <algorithm>
#include <cmath>

namespace hemo {

CouplingClock::CouplingClock(const Timing& time, const Output& output)
    : dt_max_(time.coupling_interval),
      max_change_(time.max_flow_change),
      end_time_(static_cast<double>(time.coupling_steps) * time.coupling_interval),
      output_period_(static_cast<double>(output.every_steps) * time.coupling_interval),
      fixed_steps_(time.coupling_steps),
      every_steps_(output.every_steps),
      planned_dt_(time.coupling_interval) {}

bool CouplingClock::finished() const { return adaptive() ? time_ >= end_time_ : step_ >= fixed_steps_; }

CouplingClock::Step CouplingClock::next() {
  ++step_;
  if (!adaptive()) {
    last_dt_ = dt_max_;
    time_ = static_cast<double>(step_) * dt_max_;
    return {step_, time_, dt_max_, step_ % every_steps_ == 0 || step_ == fixed_steps_};
  }
  // The next output time (or the end); an interval that would pass it, or stop a sliver short
  // of it, ends on it instead — in two halves when one step would be longer than allowed.
  const double stop_at = std::min(static_cast<double>(next_output_) * output_period_, end_time_);
  const double remaining = stop_at - time_;
  double dt = planned_dt_;
  bool output = false;
  if (dt >= remaining - kMinFraction * dt_max_) {
    if (remaining <= dt_max_) {
      dt = remaining;
      output = true;
    } else {
      dt = remaining / 2;
    }
  }
  if (output) {
    time_ = stop_at;
    ++next_output_;
  } else {
    time_ += dt;
  }
  last_dt_ = dt;
  return {step_, time_, dt, output};
}

void CouplingClock::observe_flow_change(double velocity_change) {
  if (!adaptive() || !(velocity_change >= 0) || !std::isfinite(velocity_change)) return;
  // The change grows with the interval: the interval that would have changed the flow by
  // max_change_, within the growth limit and the bounds.
  const double wanted = velocity_change > 0 ? last_dt_ * max_change_ / velocity_change : dt_max_;
  planned_dt_ = std::clamp(std::min(wanted, kMaxGrowth * planned_dt_), kMinFraction * dt_max_, dt_max_);
}

}  // namespace hemo
