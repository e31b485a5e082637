// Restarts and swaps (coordinator/run_driver.h) driven with fake nodes: which checkpoint a
// restart goes on from, how often a lost node is restarted, what a swap launches, and what the
// profile of a restarted run counts.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "control_desk.h"
#include "lockstep.h"
#include "runtime_fixture.h"

#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <future>
#include <map>
#include <sstream>
#include <thread>

using namespace hemo;
using namespace hemo::test;

namespace {
// The first step each launch of `node` was ordered.
std::map<int, long> first_order_by_launch(const Ledger& ledger, const std::string& node) {
  std::map<int, long> first;
  for (const Event& e : ledger.events())
    if (e.kind == Event::ordered && e.node == node && !first.count(e.launch)) first[e.launch] = e.step;
  return first;
}

// RUN_DIR/profile.csv as node -> phase -> (total_s, per_step_ms).
std::map<std::string, std::map<std::string, std::pair<double, double>>> read_profile(const std::string& run_dir) {
  std::ifstream in(run_dir + "/profile.csv");
  std::map<std::string, std::map<std::string, std::pair<double, double>>> profile;
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::string node, phase, total, per_step;
    std::getline(row, node, ',');
    std::getline(row, phase, ',');
    std::getline(row, total, ',');
    std::getline(row, per_step, ',');
    profile[node][phase] = {std::stod(total), per_step.empty() ? 0.0 : std::stod(per_step)};
  }
  return profile;
}
}  // namespace

// Checkpoints every 2 steps. At step 4 the fluid writes and acknowledges its checkpoint, the
// particles die while writing theirs: the newest checkpoint both acknowledged is step 2, and the
// restart goes on from there, not from the fluid's newer one.
TEST_F(RuntimeTest, RestartGoesOnFromTheNewestCheckpointBothNodesAcknowledged) {
  scene_.output.checkpoint_every_steps = 2;
  scene_.run.max_restarts = 1;
  launcher_.compute_s = [](const std::string& node, long) { return node == "particles" ? 0.05 : 0.0; };
  launcher_.script = [](const std::string& node, int launch, long step) {
    return node == "particles" && launch == 0 && step == 4 ? Act::die_writing_checkpoint : Act::ok;
  };
  const Reached reached = drive_run();
  EXPECT_TRUE(reached.end);
  EXPECT_EQ(reached.restarts, 1);

  const auto launches = launcher_.launches();
  ASSERT_EQ(launches.size(), 4u);
  for (std::size_t i = 2; i < 4; ++i) {
    EXPECT_EQ(launches[i].launch, 1) << launches[i].node;
    EXPECT_EQ(launches[i].resume_step, 2) << launches[i].node << " restarted from the wrong checkpoint";
  }
  // The fluid's acknowledgement of step 4 was seen before the restart: the choice was there.
  bool fluid_acknowledged_4 = false;
  for (const Event& e : launcher_.ledger.events())
    fluid_acknowledged_4 |=
        e.kind == Event::reported && e.node == "fluid" && e.launch == 0 && e.step == 4 && e.checkpoint;
  EXPECT_TRUE(fluid_acknowledged_4);
  EXPECT_EQ(first_order_by_launch(launcher_.ledger, "fluid")[1], 3);
  EXPECT_EQ(first_order_by_launch(launcher_.ledger, "particles")[1], 3);
  EXPECT_EQ(dir_.last_checkpoint(), 8);

  // The metrics of the steps redone after the restart are there once.
  std::ifstream metrics(dir_.metrics_file());
  std::map<std::pair<long, std::string>, int> compute_rows;
  std::string line;
  std::getline(metrics, line);
  while (std::getline(metrics, line)) {
    std::istringstream row(line);
    std::string step, time, node, name;
    std::getline(row, step, ',');
    std::getline(row, time, ',');
    std::getline(row, node, ',');
    std::getline(row, name, ',');
    if (name == "compute_s") ++compute_rows[{std::stol(step), node}];
  }
  for (long k = 0; k <= 8; ++k)
    for (const std::string node : {"fluid", "particles"})
      EXPECT_EQ((compute_rows[{k, node}]), 1) << "step " << k << " " << node;
}

// A node that dies at every launch is restarted run.max_restarts times, each time both nodes
// from the last common checkpoint, and then the run ends with the node's death as its error.
TEST_F(RuntimeTest, DeadNodeIsRestartedAtMostMaxRestartsTimes) {
  scene_.output.checkpoint_every_steps = 2;
  scene_.run.max_restarts = 2;
  launcher_.script = [](const std::string& node, int, long step) {
    return node == "particles" && step == 3 ? Act::die : Act::ok;
  };
  try {
    drive_run();
    FAIL() << "the run went on without its particle node";
  } catch (const NodeLost& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("particles node was killed by signal 9 (Killed) at step 3: fake particles: step 3"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("(after 2 restarts)"), std::string::npos) << what;
  }
  EXPECT_EQ(launcher_.launches_of("fluid"), 3);
  EXPECT_EQ(launcher_.launches_of("particles"), 3);
  for (const Launch& l : launcher_.launches())
    EXPECT_EQ(l.resume_step, l.launch == 0 ? 0 : 2) << l.node << " launch " << l.launch;
}

// `hemocosim swap` mid-run: the step the request came in is checkpointed (checkpoints are
// otherwise off here), both nodes start again from it, the particles as the new program with
// its arguments, the fluid as before; run.toml keeps the new program, signed, and the requester
// hears that it was done.
TEST_F(RuntimeTest, SwapRelaunchesTheNodeWithTheOtherCommandFromTheStepItCameIn) {
  scene_.time.coupling_steps = 12;
  launcher_.compute_s = [](const std::string&, long) { return 0.05; };
  auto answer = std::async(std::launch::async, [&] {
    // Once the run is under way.
    for (bool started = false; !started; std::this_thread::sleep_for(std::chrono::milliseconds(10)))
      for (const Event& e : launcher_.ledger.events()) started |= e.kind == Event::reported && e.step == 2;
    return ask_coordinator(ctx_, {7, "swap", "particles", "fake-other-particles --fast"}, 20);
  });
  const Reached reached = drive_run();
  EXPECT_TRUE(reached.end);
  EXPECT_EQ(reached.restarts, 0) << "a swap asked for is not a restart of a lost node";

  long checkpointed = -1;
  for (const Event& e : launcher_.ledger.events())
    if (e.kind == Event::ordered && e.checkpoint && e.launch == 0) checkpointed = e.step;
  ASSERT_GE(checkpointed, 3);
  ASSERT_LT(checkpointed, 12);
  const auto launches = launcher_.launches();
  ASSERT_EQ(launches.size(), 4u);
  for (std::size_t i = 2; i < 4; ++i) {
    EXPECT_EQ(launches[i].resume_step, checkpointed) << launches[i].node;
    const std::string program = launches[i].argv.at(0);
    if (launches[i].node == "particles") {
      EXPECT_EQ(program, "fake-other-particles");
      EXPECT_EQ(launches[i].argv.at(1), "--fast");
    } else {
      EXPECT_EQ(program, "fake-fluid");
    }
  }
  EXPECT_EQ(RunDirectory::open(dir_.path).first.particle_command, "fake-other-particles --fast");
  // Signed with the run's secret: a resume runs it without --allow-commands (the fluid's is the
  // scene's, which `run` signs; drive() alone does not).
  Scene swapped = scene_;
  swapped.run.particle_command = "fake-other-particles --fast";
  EXPECT_TRUE(dir_.commands_signed(ctx_, swapped));
  const auto a = answer.get();
  EXPECT_EQ(a.action, "done");
  EXPECT_NE(
      a.detail.find(fmt::format("particles node swapped for `fake-other-particles --fast` at step {}", checkpointed)),
      std::string::npos)
      << a.detail;
}

// The profile of a restarted run is of the span after the restart: its steps and their times,
// not the steps the lost span did and the restart redid. Each node reports 10 ms x the step
// number as its compute time; the particles die at step 6, the restart goes on from 4.
TEST_F(RuntimeTest, ProfileAfterARestartCountsOnlyTheSpanAfterIt) {
  scene_.output.checkpoint_every_steps = 4;
  scene_.run.max_restarts = 1;
  launcher_.compute_s = [](const std::string&, long step) { return 0.01 * static_cast<double>(step); };
  launcher_.script = [](const std::string& node, int launch, long step) {
    return node == "particles" && launch == 0 && step == 6 ? Act::die : Act::ok;
  };
  const Reached reached = drive_run();
  EXPECT_TRUE(reached.end);
  EXPECT_EQ(reached.restarts, 1);
  const auto profile = read_profile(dir_.path);
  const double after_restart = 0.01 * (5 + 6 + 7 + 8);
  for (const std::string node : {"fluid", "particles"}) {
    ASSERT_TRUE(profile.count(node) && profile.at(node).count("compute_s")) << node;
    const auto [total, per_step_ms] = profile.at(node).at("compute_s");
    EXPECT_NEAR(total, after_restart, 1e-9) << node;
    EXPECT_NEAR(per_step_ms, 1e3 * after_restart / 4, 1e-6) << node;
  }
}

// A node that freezes is lost after the heartbeat timeout and restarted with the other from the
// last common checkpoint; the run then ends as if nothing happened.
TEST_F(RuntimeTest, FrozenNodeIsRestartedFromTheLastCommonCheckpoint) {
  scene_.output.checkpoint_every_steps = 3;
  scene_.run.max_restarts = 1;
  launcher_.script = [](const std::string& node, int launch, long step) {
    return node == "fluid" && launch == 0 && step == 5 ? Act::freeze : Act::ok;
  };
  const Reached reached = drive_run();
  EXPECT_TRUE(reached.end);
  EXPECT_EQ(reached.restarts, 1);
  for (const Launch& l : launcher_.launches())
    EXPECT_EQ(l.resume_step, l.launch == 0 ? 0 : 3) << l.node << " launch " << l.launch;
  EXPECT_EQ(launcher_.launches().size(), 4u);
}

// An interrupt (Ctrl-C, SIGTERM) stops the run after the step it came in, which is checkpointed
// though no checkpoint is due, so that `hemocosim resume` goes on from there.
TEST_F(RuntimeTest, InterruptStopsAfterTheStepWithACheckpoint) {
  scene_.time.coupling_steps = 12;
  scene_.output.checkpoint_every_steps = 0;
  launcher_.compute_s = [](const std::string&, long) { return 0.02; };
  const auto interrupted = [this] {
    for (const Event& e : launcher_.ledger.events())
      if (e.kind == Event::reported && e.step == 4) return true;
    return false;
  };
  const Reached reached = drive_run(0, interrupted);
  EXPECT_FALSE(reached.end);
  EXPECT_GE(reached.step, 5);
  EXPECT_LT(reached.step, 12);
  EXPECT_EQ(dir_.last_checkpoint(), reached.step);
  for (const Event& e : launcher_.ledger.events()) {
    if (e.kind == Event::ordered && e.checkpoint) {
      EXPECT_EQ(e.step, reached.step) << e.node;
    }
  }
}

// A node that gave up waiting for a silent coordinator (a coordinator paused for longer than the
// nodes wait, docs/architecture.md "Liveness") is healthy: both nodes are restarted from the last
// checkpoint, unlike after a failed step, and the cause is named.
TEST_F(RuntimeTest, NodeThatGaveUpOnTheCoordinatorIsRestartedFromTheLastCheckpoint) {
  scene_.output.checkpoint_every_steps = 2;
  scene_.run.max_restarts = 1;
  launcher_.script = [](const std::string& node, int launch, long step) {
    return node == "fluid" && launch == 0 && step == 5 ? Act::give_up : Act::ok;
  };
  const Reached reached = drive_run();
  EXPECT_TRUE(reached.end);
  EXPECT_EQ(reached.restarts, 1);
  const auto launches = launcher_.launches();
  ASSERT_EQ(launches.size(), 4u);
  for (std::size_t i = 2; i < 4; ++i) EXPECT_EQ(launches[i].resume_step, 4) << launches[i].node;
}
