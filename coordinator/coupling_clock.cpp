// SPDX-License-Identifier: GPL-3.0-or-later
#include "coupling_clock.h"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace hemo {

namespace {
constexpr std::int64_t ticks_per_interval(int level) { return std::int64_t{1} << (CouplingClock::kMaxLevel - level); }
}  // namespace

CouplingClock::CouplingClock(const Timing& time, const Output& output, long first_step, double first_time_s)
    : dt_max_s_(time.coupling_interval),
      relaxation_times_(time.coupling_relaxation_times),
      tick_s_(std::ldexp(time.coupling_interval, -kMaxLevel)),
      fixed_steps_(time.coupling_steps),
      end_ticks_(time.coupling_steps * ticks_per_interval(0)),
      output_ticks_(output.every_steps * ticks_per_interval(0)),
      step_(first_step) {
  ticks_ = adaptive() ? std::llround(first_time_s / tick_s_) : first_step * ticks_per_interval(0);
  if (ticks_ < 0 || ticks_ > end_ticks_)
    throw std::runtime_error(
        fmt::format("the run resumes at t = {:.6g} s, outside its span 0..{:.6g} s", first_time_s, end_time_s()));
  // A run resumed between two longest intervals goes on with intervals that end on its time.
  while (ticks_ % ticks_per_interval(level_) != 0) ++level_;
}

CouplingClock::Step CouplingClock::next() {
  const std::int64_t dt = ticks_per_interval(level_);
  ticks_ += dt;
  ++step_;
  return {step_, seconds(ticks_), seconds(dt), ticks_ % output_ticks_ == 0 || ticks_ == end_ticks_};
}

void CouplingClock::observe_relaxation_time(double tau_s) {
  if (!adaptive() || std::isnan(tau_s) || std::isinf(tau_s)) return;
  if (!(tau_s > 0))
    throw std::runtime_error(fmt::format("the particle node reported a drag relaxation time of {} s", tau_s));
  const double longest = relaxation_times_ * tau_s;  // the longest interval the particles allow
  int wanted = 0;
  while (wanted <= kMaxLevel && std::ldexp(dt_max_s_, -wanted) > longest) ++wanted;
  if (wanted > kMaxLevel)
    throw std::runtime_error(
        fmt::format("the drag relaxation time {:.3g} s asks for coupling intervals below {:.3g} s "
                    "(time.coupling_interval_s / 2^{}): "
                    "raise time.coupling_relaxation_times or lower time.coupling_interval_s",
                    tau_s, std::ldexp(dt_max_s_, -kMaxLevel), kMaxLevel));
  if (wanted > level_)
    level_ = wanted;  // shorter: at once (a shorter power of two still ends on the grid)
  else if (wanted < level_ && ticks_ % ticks_per_interval(level_ - 1) == 0)
    --level_;  // longer: one level a step, and only where the longer interval's grid is
}

}  // namespace hemo
