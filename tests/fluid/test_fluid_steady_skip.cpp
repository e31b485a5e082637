// One-way coupling: the fluid node stops solving once the flow is steady (issue #6, docs/design.md
// "skip what a scene doesn't need"). The real hemocosim-fluid under the coordinator over the real
// bus, driven by hemocosim-prescribed-particles.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_run.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

using namespace hemo::fluidtest;

namespace {

// The paper's cross-section (4/3), 4 axial cells, 799 1/s, steps of 2e-4 s (a tenth of the viscous
// time R^2/nu), 80 steps: the flow settles from the analytic profile to the discrete one. The
// prescribed node publishes a moving solid-fraction blob and a momentum source, which a one-way
// fluid must ignore.
SceneSpec one_way(const std::string& name, const std::string& fluid_keys, bool two_way = false) {
  SceneSpec s;
  s.name = name;
  s.axial = 4;
  s.dt = 2e-4;
  s.steps = 80;
  s.particle_command =
      bin("hemocosim-prescribed-particles") +
      " --mode blob --phi 0.1 --blob-phi 0.3 --blob-sigma-um 12 --blob-speed-m-s 0.05 --record state.csv";
  s.extra = std::string("[coupling]\ntwo_way = ") + (two_way ? "true" : "false") + "\n\n[fluid]\n" + fluid_keys + "\n";
  return s;
}

}  // namespace

// With fluid.skip_when_steady (the default) a one-way run stops solving once max|dU|/max|U| over
// a step is below fluid.steady_tolerance (1e-8), and publishes the same state afterwards; the
// published velocity equals that of a run solving every step to a few times the tolerance (the
// flow relaxes geometrically, so what is left after a step that changed it by 1e-8 is of the same
// order). A two-way run with the same keys solves every step.
TEST(FluidSteadySkip, OneWayRunStopsSolvingOnceSteadyWithTheSameFlow) {
  const auto skip = run_scene(one_way("one-way-skip", "skip_when_steady = true"));
  ASSERT_EQ(skip.command.exit_code, 0) << skip.command.output;
  const auto every = run_scene(one_way("one-way-every-step", "skip_when_steady = false"));
  ASSERT_EQ(every.command.exit_code, 0) << every.command.output;
  const auto two_way = run_scene(one_way("two-way-skip-key", "skip_when_steady = true", true));
  ASSERT_EQ(two_way.command.exit_code, 0) << two_way.command.output;

  const auto ms = read_metrics(skip.dir), me = read_metrics(every.dir), mt = read_metrics(two_way.dir);
  const long n = 80;
  const double solves_skip = last(ms, "fluid", "fluid_solves");
  const double solves_every = last(me, "fluid", "fluid_solves");
  const double solves_two_way = last(mt, "fluid", "fluid_solves");
  long first_skipped = -1;
  const auto& solved = ms.at({"fluid", "fluid_solved"});
  for (long k = 1; k <= n; ++k) {
    if (solved.at(k) == 0 && first_skipped < 0) first_skipped = k;
    if (first_skipped > 0) {
      EXPECT_EQ(solved.at(k), 0) << "once steady, never solved again (step " << k << ")";
    }
  }

  const auto a = read_state(skip.dir + "/state.csv"), b = read_state(every.dir + "/state.csv");
  ASSERT_EQ(a.size(), b.size());
  double du = 0, dg = 0, umax = 0, gmax = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      umax = std::max(umax, std::abs(b[i].u[k]));
      du = std::max(du, std::abs(a[i].u[k] - b[i].u[k]));
    }
    for (int k = 0; k < 9; ++k) {
      gmax = std::max(gmax, std::abs(b[i].grad[k]));
      dg = std::max(dg, std::abs(a[i].grad[k] - b[i].grad[k]));
    }
  }
  const double mean_skip = last(ms, "fluid", "mean_velocity_m_s"), mean_every = last(me, "fluid", "mean_velocity_m_s");
  std::printf(
      "one-way steady skip (4/3/4, dt = 2e-4 s, %ld steps): fluid solves %.0f (skip) vs %.0f (every step) vs "
      "%.0f (two-way); first step not solved %ld; max |du|/u_max = %.3e, max |dG|/G_max = %.3e, "
      "mean velocity %.10e vs %.10e (rel %.2e); fluid compute %.3f s vs %.3f s\n",
      n, solves_skip, solves_every, solves_two_way, first_skipped, du / umax, dg / gmax, mean_skip, mean_every,
      std::abs(mean_skip / mean_every - 1),
      [&] {
        double t = 0;
        for (const auto& [k, v] : ms.at({"fluid", "compute_s"})) t += k >= 1 ? v : 0;
        return t;
      }(),
      [&] {
        double t = 0;
        for (const auto& [k, v] : me.at({"fluid", "compute_s"})) t += k >= 1 ? v : 0;
        return t;
      }());
  EXPECT_EQ(solves_every, n);
  EXPECT_EQ(solves_two_way, n) << "a two-way scene solves every step";
  EXPECT_GT(first_skipped, 1);
  EXPECT_EQ(solves_skip, first_skipped - 1);
  EXPECT_LT(solves_skip, 0.75 * n) << "the skip must save solves";
  EXPECT_LT(du / umax, 1e-7);
  EXPECT_LT(dg / gmax, 1e-7);
  EXPECT_LT(std::abs(mean_skip / mean_every - 1), 1e-7);
  EXPECT_GT(du, 0.0) << "the runs are not the same run";
  // The state published while skipping carries the new time.
  EXPECT_NEAR(last(ms, "fluid", "time_s"), n * 2e-4, 1e-12);
  EXPECT_NEAR(last(ms, "particles", "fluid_time_s"), n * 2e-4, 1e-12);
}
