// The coupling steps of a run (coordinator/coupling_clock.h), without a run: fixed intervals as
// k dt, adaptive ones sized by the particles' relaxation times on the powers-of-two grid.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "coupling_clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

using hemo::CouplingClock;

namespace {
hemo::Timing timing(double dt, long steps, double relaxation_times = 0) {
  hemo::Timing t;
  t.coupling_interval = dt;
  t.coupling_steps = steps;
  t.coupling_relaxation_times = relaxation_times;
  return t;
}
hemo::Output every(long steps) {
  hemo::Output o;
  o.every_steps = steps;
  return o;
}
// Runs the clock to its end, reporting tau(step) before each step; the steps it made.
template <class Tau>
std::vector<CouplingClock::Step> run_to_end(CouplingClock& clock, Tau tau) {
  std::vector<CouplingClock::Step> steps;
  while (!clock.finished()) {
    clock.observe_relaxation_time(tau(clock.step()));
    steps.push_back(clock.next());
    if (steps.size() > 100000) throw std::runtime_error("the clock does not end");
  }
  return steps;
}
}  // namespace

// Fixed intervals: step k ends at exactly k dt (the same double as k * dt), output every n steps
// and at the last; relaxation times change nothing.
TEST(CouplingClock, FixedIntervalsEndAtKTimesDt) {
  const double dt = 1e-4;
  CouplingClock clock(timing(dt, 25), every(10));
  EXPECT_FALSE(clock.adaptive());
  EXPECT_EQ(clock.total_steps(), 25);
  const auto steps = run_to_end(clock, [](long) { return 1e-9; });
  ASSERT_EQ(steps.size(), 25u);
  for (const auto& s : steps) {
    EXPECT_EQ(s.time_s, s.number * dt) << "step " << s.number;  // bit for bit
    EXPECT_EQ(s.dt_s, dt);
    EXPECT_EQ(s.output, s.number % 10 == 0 || s.number == 25) << "step " << s.number;
  }
}

TEST(CouplingClock, FixedClockResumesAtItsStep) {
  CouplingClock clock(timing(2e-5, 40), every(10), 20);
  EXPECT_EQ(clock.time_s(), 20 * 2e-5);
  const auto s = clock.next();
  EXPECT_EQ(s.number, 21);
  EXPECT_EQ(s.time_s, 21 * 2e-5);
}

// With the particles relaxing in tau, each interval is the longest dt / 2^j at most N tau.
TEST(CouplingClock, AdaptiveIntervalIsTheLongestPowerOfTwoWithinNRelaxationTimes) {
  const double dt = 1e-4;
  struct Case {
    double n_tau, expected;
  };
  for (const Case c : {Case{2e-4, 1e-4}, Case{1e-4, 1e-4}, Case{0.99e-4, 0.5e-4}, Case{0.5e-4, 0.5e-4},
                       Case{0.3e-4, 0.25e-4}, Case{1.3e-6, dt / 128}}) {
    CouplingClock clock(timing(dt, 4, 1.0), every(1));
    clock.observe_relaxation_time(c.n_tau);
    EXPECT_EQ(clock.next().dt_s, c.expected) << "N tau = " << c.n_tau;
  }
}

// The adaptive run covers the scene's time, every output time of the fixed clock is a step's end
// (output there and nowhere else), and the intervals add up to the time exactly.
TEST(CouplingClock, AdaptiveIntervalsLandOnTheFixedOutputTimes) {
  const double dt = 1e-4;
  const long steps = 20, every_steps = 3;
  CouplingClock clock(timing(dt, steps, 5.0), every(every_steps));
  EXPECT_TRUE(clock.adaptive());
  EXPECT_EQ(clock.total_steps(), 0);
  // tau wanders over two decades: intervals of dt / 2^0 .. dt / 2^7.
  const auto made =
      run_to_end(clock, [&](long k) { return dt / 5.0 * std::pow(10.0, -2.0 * std::abs(std::sin(0.37 * k))); });
  double sum = 0;
  std::vector<double> outputs;
  for (const auto& s : made) {
    sum += s.dt_s;
    if (s.output) outputs.push_back(s.time_s);
  }
  EXPECT_NEAR(sum, steps * dt, 1e-12 * steps * dt);
  EXPECT_EQ(made.back().time_s, steps * dt);
  std::vector<double> expected;
  for (long k = every_steps; k <= steps; k += every_steps) expected.push_back(k * dt);
  expected.push_back(steps * dt);  // the last step, not a multiple of every_steps
  ASSERT_EQ(outputs.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(outputs[i], expected[i], 1e-15) << i;
  EXPECT_GT(made.size(), static_cast<std::size_t>(4 * steps));  // the short intervals did happen
}

// An interval shortens at once, and grows back one level a step, only where it ends on the
// longer interval's grid: 1/4 -> 1/2 needs a time that is a multiple of dt/2.
TEST(CouplingClock, IntervalShrinksAtOnceAndGrowsOneLevelOnItsGrid) {
  const double dt = 1.0;  // plain numbers: the ticks are exact
  CouplingClock clock(timing(dt, 10, 1.0), every(10));
  clock.observe_relaxation_time(0.3);  // -> 1/4
  auto s = clock.next();
  EXPECT_EQ(s.dt_s, 0.25);
  EXPECT_EQ(s.time_s, 0.25);
  clock.observe_relaxation_time(100.0);  // wants 1, but t = 0.25 is not on the 1/2 grid
  s = clock.next();
  EXPECT_EQ(s.dt_s, 0.25);
  EXPECT_EQ(s.time_s, 0.5);
  clock.observe_relaxation_time(100.0);  // on the 1/2 grid: one level up
  s = clock.next();
  EXPECT_EQ(s.dt_s, 0.5);
  EXPECT_EQ(s.time_s, 1.0);
  clock.observe_relaxation_time(100.0);
  s = clock.next();
  EXPECT_EQ(s.dt_s, 1.0);
  EXPECT_EQ(s.time_s, 2.0);
  clock.observe_relaxation_time(0.01);  // -> 1/128 at once
  EXPECT_EQ(clock.next().dt_s, 1.0 / 128);
}

// No report (a stand-in node), or one without drag, bounds nothing; a relaxation time below the
// shortest interval on the grid, or not positive, stops the run with a message naming the cure.
TEST(CouplingClock, MissingRelaxationTimeBoundsNothingAndImpossibleOnesAreNamed) {
  CouplingClock clock(timing(1e-4, 4, 10.0), every(1));
  clock.observe_relaxation_time(std::numeric_limits<double>::quiet_NaN());
  clock.observe_relaxation_time(std::numeric_limits<double>::infinity());
  EXPECT_EQ(clock.next().dt_s, 1e-4);
  try {
    clock.observe_relaxation_time(1e-18);
    FAIL() << "a relaxation time of 1e-18 s was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("time.coupling_relaxation_times"), std::string::npos) << e.what();
  }
  EXPECT_THROW(clock.observe_relaxation_time(0.0), std::runtime_error);
  EXPECT_THROW(clock.observe_relaxation_time(-1e-6), std::runtime_error);
}

// Resumed at a time between two longest intervals, the clock goes on with intervals that end on
// its grid, and lands on the end.
TEST(CouplingClock, AdaptiveClockResumesAtTheCheckpointsTime) {
  CouplingClock clock(timing(1.0, 4, 1.0), every(4), 7, 1.375);
  EXPECT_EQ(clock.step(), 7);
  EXPECT_EQ(clock.time_s(), 1.375);
  clock.observe_relaxation_time(100.0);  // wants 1, the grid allows 1/8 now
  const auto s = clock.next();
  EXPECT_EQ(s.number, 8);
  EXPECT_EQ(s.dt_s, 0.125);
  EXPECT_EQ(s.time_s, 1.5);
  const auto rest = run_to_end(clock, [](long) { return 100.0; });
  EXPECT_EQ(rest.back().time_s, 4.0);
  EXPECT_TRUE(rest.back().output);
  EXPECT_THROW(CouplingClock(timing(1.0, 4, 1.0), every(4), 3, 4.5), std::runtime_error);
}
