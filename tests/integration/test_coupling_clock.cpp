// The coupling steps a run orders (coordinator/coupling_clock.h), without a run: fixed intervals
// as the scene says, and adaptive ones against a flow whose rate of change is known.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "coupling_clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

using hemo::CouplingClock;

namespace {

struct Schedule {
  std::vector<CouplingClock::Step> steps;
  std::vector<double> change;  // the flow's change over each step
};

// Runs a clock to the end against a flow that changes at `rate(t)` per second relative to its
// size, so that a step of dt ending at t changes it by rate(t) dt.
Schedule run_clock(double interval, long steps, long every, double max_change,
                   const std::function<double(double)>& rate) {
  hemo::Timing time;
  time.coupling_interval = interval;
  time.coupling_steps = steps;
  time.max_flow_change = max_change;
  hemo::Output output;
  output.every_steps = every;
  CouplingClock clock(time, output);
  Schedule s;
  while (!clock.finished()) {
    s.steps.push_back(clock.next());
    const auto& st = s.steps.back();
    s.change.push_back(rate(st.time_s) * st.dt_s);
    clock.observe_flow_change(s.change.back());
    if (s.steps.size() > 100000) break;
  }
  return s;
}

}  // namespace

TEST(CouplingClock, FixedIntervalsAreTheScenesSteps) {
  const auto s = run_clock(2e-5, 25, 10, 0, [](double) { return 1e6; });
  ASSERT_EQ(s.steps.size(), 25u);
  for (std::size_t i = 0; i < s.steps.size(); ++i) {
    const long k = static_cast<long>(i) + 1;
    EXPECT_EQ(s.steps[i].number, k);
    EXPECT_EQ(s.steps[i].dt_s, 2e-5);
    EXPECT_EQ(s.steps[i].time_s, k * 2e-5);
    EXPECT_EQ(s.steps[i].output, k == 10 || k == 20 || k == 25) << k;
  }
}

// A flow that never changes enough to matter: the adaptive clock orders exactly the fixed steps.
TEST(CouplingClock, AdaptiveWithoutLimitOrdersTheFixedSteps) {
  const auto fixed = run_clock(1e-4, 37, 10, 0, [](double) { return 10.0; });
  const auto adaptive = run_clock(1e-4, 37, 10, 1e9, [](double) { return 10.0; });
  ASSERT_EQ(adaptive.steps.size(), fixed.steps.size());
  for (std::size_t i = 0; i < fixed.steps.size(); ++i) {
    EXPECT_EQ(adaptive.steps[i].dt_s, fixed.steps[i].dt_s) << i;
    EXPECT_NEAR(adaptive.steps[i].time_s, fixed.steps[i].time_s, 1e-12 * fixed.steps[i].time_s) << i;
    EXPECT_EQ(adaptive.steps[i].output, fixed.steps[i].output) << i;
  }
}

// A start-up transient that decays (rate 2000/s -> 2/s with a 2 ms time scale) against a target
// change of 1e-3 per step: after the first step (taken at the longest interval: nothing is
// known yet) no step changes the flow by more than the target, the intervals are short in the
// transient and reach the longest once it has passed, output lands exactly on the fixed
// intervals' output times and the run ends exactly at their end.
TEST(CouplingClock, AdaptiveIntervalsHoldTheFlowChangeAndLandOnOutputTimes) {
  const double interval = 1e-4, target = 1e-3, tau = 2e-3;
  const long steps = 200, every = 25;  // 0.02 s, output every 2.5 ms
  auto rate = [&](double t) { return 2000 * std::exp(-t / tau) + 2; };
  const auto s = run_clock(interval, steps, every, target, rate);
  ASSERT_FALSE(s.steps.empty());
  EXPECT_GT(s.change.front(), target);  // the first step: longest interval, fast flow
  for (std::size_t i = 1; i < s.steps.size(); ++i) {
    EXPECT_LE(s.change[i], target * (1 + 1e-9)) << "step " << i + 1 << " at t = " << s.steps[i].time_s;
    EXPECT_LE(s.steps[i].dt_s, interval * (1 + 1e-12));
    EXPECT_GE(s.steps[i].dt_s, CouplingClock::kMinFraction * interval * (1 - 1e-12));
    if (!s.steps[i - 1].output)
      EXPECT_LE(s.steps[i].dt_s, CouplingClock::kMaxGrowth * s.steps[i - 1].dt_s * (1 + 1e-12)) << i;
  }
  // Short in the transient (rate 2000/s allows 5e-7 s), the longest once the flow has settled.
  EXPECT_LT(s.steps[1].dt_s, 0.02 * interval);
  long at_longest = 0;
  for (const auto& st : s.steps) at_longest += st.time_s > 0.015 && st.dt_s == interval;
  EXPECT_GT(at_longest, 30);
  // Output at n x 2.5 ms exactly, and at the end.
  std::vector<double> outputs;
  for (const auto& st : s.steps)
    if (st.output) outputs.push_back(st.time_s);
  ASSERT_EQ(outputs.size(), 8u);
  for (std::size_t n = 0; n < outputs.size(); ++n) EXPECT_DOUBLE_EQ(outputs[n], (n + 1) * every * interval);
  EXPECT_DOUBLE_EQ(s.steps.back().time_s, steps * interval);
  EXPECT_TRUE(s.steps.back().output);
  for (std::size_t i = 1; i < s.steps.size(); ++i) EXPECT_GT(s.steps[i].time_s, s.steps[i - 1].time_s);
}

// A flow that suddenly starts changing fast: the next interval shrinks to hold the target.
TEST(CouplingClock, AdaptiveIntervalShrinksWhenTheFlowSpeedsUp) {
  const double interval = 1e-4, target = 1e-3;
  auto rate = [](double t) { return t < 5e-3 ? 1.0 : 100.0; };  // 1e-4 s allows rate 10/s
  const auto s = run_clock(interval, 100, 10, target, rate);
  std::size_t jump = 0;
  while (jump < s.steps.size() && s.steps[jump].time_s < 5e-3) ++jump;
  ASSERT_LT(jump + 2, s.steps.size());
  EXPECT_EQ(s.steps[jump - 1].dt_s, interval);
  EXPECT_NEAR(s.steps[jump + 1].dt_s, target / 100, 1e-12);
  EXPECT_GT(s.change[jump], target);  // the step that met the change could not know it
  EXPECT_LE(s.change[jump + 1], target * (1 + 1e-9));
}
