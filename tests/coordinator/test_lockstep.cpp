// The lockstep (coordinator/lockstep.h) driven with fake nodes: the order of step orders and
// reports, which steps carry a checkpoint, and how long a node may stay silent.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "lockstep.h"
#include "runtime_fixture.h"

#include <chrono>
#include <filesystem>
#include <map>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>

using namespace hemo;
using namespace hemo::test;

namespace {
double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

std::vector<long> checkpoint_folders(const std::string& run_dir) {
  std::vector<long> steps;
  for (const auto& e : std::filesystem::directory_iterator(run_dir + "/checkpoints"))
    steps.push_back(std::stol(e.path().filename().string().substr(5)));
  std::sort(steps.begin(), steps.end());
  return steps;
}
}  // namespace

// Each node is in turn the slow one, so an order sent after the first report of a step, rather
// than after both, reaches the slow node while it still computes (it listens meanwhile) and
// shows in the ledger before that node's report.
TEST_F(RuntimeTest, StepIsOrderedOnlyAfterBothNodesReportedTheStepBefore) {
  scene_.time.coupling_steps = 10;
  launcher_.compute_s = [](const std::string& node, long step) {
    return (node == "fluid") == (step % 2 == 0) ? 0.08 : 0.0;
  };
  try {
    const Reached reached = drive_run();
    EXPECT_TRUE(reached.end);
    EXPECT_EQ(reached.step, 10);
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what();  // and what the nodes saw until then, below
  }

  std::set<std::pair<std::string, long>> reported;
  std::map<std::string, std::vector<long>> ordered;
  for (const Event& e : launcher_.ledger.events()) {
    if (e.kind == Event::reported) {
      reported.insert({e.node, e.step});
      continue;
    }
    ordered[e.node].push_back(e.step);
    for (const std::string node : {"fluid", "particles"})
      EXPECT_TRUE(reported.count({node, e.step - 1}))
          << "step " << e.step << (e.stop ? " (stop)" : "") << " reached " << e.node << " before " << node
          << " reported step " << e.step - 1;
  }
  const std::vector<long> all_steps{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};  // 11: the stop order
  EXPECT_EQ(ordered["fluid"], all_steps);
  EXPECT_EQ(ordered["particles"], all_steps);
}

// Nodes on 2 and 3 ranks: each rank but 0 reports on its own channel, a node's in turn late
// (after its rank 0 by 80 ms), and a step is ordered only once every rank of both nodes has
// reported the step before. The ranks' timings and bytes reach metrics.csv and profile.csv.
TEST_F(RuntimeTest, StepIsOrderedOnlyAfterEveryRankOfBothNodesReportedTheStepBefore) {
  scene_.time.coupling_steps = 8;
  scene_.run.fluid_ranks = 2;
  scene_.run.particle_ranks = 3;
  launcher_.ranks_later_s = [](const std::string& node, long step) {
    return (node == "fluid") == (step % 2 == 0) ? 0.08 : 0.0;
  };
  try {
    const Reached reached = drive_run();
    EXPECT_TRUE(reached.end);
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what();
  }

  const std::map<std::string, int> ranks{{"fluid", 2}, {"particles", 3}};
  std::set<std::tuple<std::string, int, long>> reported;
  int orders = 0;
  for (const Event& e : launcher_.ledger.events()) {
    if (e.kind == Event::reported) {
      reported.insert({e.node, e.rank, e.step});
      continue;
    }
    ++orders;
    for (const auto& [node, n] : ranks)
      for (int r = 0; r < n; ++r)
        EXPECT_TRUE(reported.count({node, r, e.step - 1}))
            << "step " << e.step << " reached " << e.node << " before rank " << r << " of " << node
            << " reported step " << e.step - 1;
  }
  EXPECT_EQ(orders, 2 * 9);  // steps 1..8 and the stop, to each node

  // Every rank's report of every step is in the metrics, under its node.
  std::ifstream metrics(dir_.metrics_file());
  std::set<std::tuple<std::string, std::string, long>> rows;
  std::string line;
  std::getline(metrics, line);
  while (std::getline(metrics, line)) {
    std::stringstream in(line);
    std::string step, time, node, name;
    std::getline(in, step, ',');
    std::getline(in, time, ',');
    std::getline(in, node, ',');
    std::getline(in, name, ',');
    rows.insert({node, name, std::stol(step)});
  }
  for (long k = 0; k <= 8; ++k) {
    EXPECT_TRUE(rows.count({"fluid", "rank1_compute_s", k})) << k;
    EXPECT_TRUE(rows.count({"fluid", "rank1_sent_B", k})) << k;
    EXPECT_TRUE(rows.count({"particles", "rank2_wait_s", k})) << k;
    EXPECT_FALSE(rows.count({"fluid", "rank2_compute_s", k})) << k;
  }
  std::ifstream profile(dir_.path + "/profile.csv");
  const std::string csv((std::istreambuf_iterator<char>(profile)), std::istreambuf_iterator<char>());
  EXPECT_NE(csv.find("particles,rank2_sent_B_per_step,200,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("fluid,rank1_sent_B_per_step,100,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("particles,rank1_compute_s,"), std::string::npos) << csv;
}

// A rank >= 1 that stops (no heartbeat, no report) while its node's rank 0 beats on is named by
// node, rank and step once the node timeout (1 s) has passed.
TEST_F(RuntimeTest, ARankThatStopsIsNamedByItsNodeRankAndStep) {
  scene_.run.particle_ranks = 2;
  launcher_.script = [](const std::string& node, int, long step) {
    return node == "particles" && step == 3 ? Act::rank_stops : Act::ok;
  };
  const auto start = std::chrono::steady_clock::now();
  try {
    drive_run();
    FAIL() << "a silent rank went unnoticed";
  } catch (const NodeLost& e) {
    EXPECT_NE(std::string(e.what()).find("particles node's rank 1 of 2 stopped answering at step 3: no heartbeat for 1 s"),
              std::string::npos)
        << e.what();
  }
  EXPECT_LT(seconds_since(start), 5.0);
}

// Checkpoints every 3 steps and at --stop-after-step 8 (of 10): the orders of steps 3, 6 and 8
// carry write_checkpoint and no other; the run keeps only the newest (of step 8).
TEST_F(RuntimeTest, CheckpointIsOrderedOnTheCheckpointStepsAndAtAnEarlyStop) {
  scene_.time.coupling_steps = 10;
  scene_.output.checkpoint_every_steps = 3;
  const Reached reached = drive_run(8);
  EXPECT_FALSE(reached.end);
  EXPECT_EQ(reached.step, 8);

  std::map<std::string, std::vector<long>> checkpoint_orders, stop_orders, acknowledged;
  for (const Event& e : launcher_.ledger.events()) {
    if (e.kind == Event::ordered && e.checkpoint) checkpoint_orders[e.node].push_back(e.step);
    if (e.kind == Event::ordered && e.stop) stop_orders[e.node].push_back(e.step);
    if (e.kind == Event::reported && e.checkpoint) acknowledged[e.node].push_back(e.step);
  }
  const std::vector<long> expected{3, 6, 8};
  for (const std::string node : {"fluid", "particles"}) {
    EXPECT_EQ(checkpoint_orders[node], expected) << node;
    EXPECT_EQ(acknowledged[node], expected) << node;
    EXPECT_EQ(stop_orders[node], std::vector<long>{9}) << node;
  }
  EXPECT_EQ(checkpoint_folders(dir_.path), std::vector<long>{8});
  EXPECT_EQ(dir_.last_checkpoint(), 8);
}

// A node that reports a failed step is not restarted (it would fail again), however many
// restarts are allowed, and the error names it, the step and its reason.
TEST_F(RuntimeTest, NodeReportingAFailedStepIsNotRestartedAndIsNamed) {
  scene_.output.checkpoint_every_steps = 2;
  scene_.run.max_restarts = 3;
  launcher_.script = [](const std::string& node, int, long step) {
    return node == "particles" && step == 3 ? Act::fail : Act::ok;
  };
  try {
    drive_run();
    FAIL() << "the run went on after a failed step";
  } catch (const NodeLost& e) {
    FAIL() << "a failed step was taken for a lost node: " << e.what();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("particles node failed at step 3: fake particles diverged at step 3"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(launcher_.launches_of("fluid"), 1);
  EXPECT_EQ(launcher_.launches_of("particles"), 1);
}

// A node that was heard from and then falls silent is lost after run.node_timeout_s, not after
// the start-up allowance (here 8 s, the whole test's budget).
TEST_F(RuntimeTest, FrozenNodeIsLostAfterTheNodeTimeout) {
  scene_.run.node_timeout = 1.0;
  scene_.run.startup_timeout = 8.0;
  launcher_.script = [](const std::string& node, int, long step) {
    return node == "fluid" && step == 2 ? Act::freeze : Act::ok;
  };
  const auto start = std::chrono::steady_clock::now();
  try {
    drive_run();
    FAIL() << "a frozen node went unnoticed";
  } catch (const NodeLost& e) {
    EXPECT_NE(std::string(e.what()).find("fluid node stopped answering at step 2: no heartbeat for 1 s"),
              std::string::npos)
        << e.what();
  }
  EXPECT_LT(seconds_since(start), 5.0);
}

// A node not heard from yet is starting up: it has run.startup_timeout_s (4 s) even where the
// heartbeat timeout (1 s) has long passed.
TEST_F(RuntimeTest, SlowStartingNodeHasTheStartupTimeout) {
  launcher_.start_delay_s = [](const std::string& node, int) { return node == "particles" ? 2.5 : 0.0; };
  const Reached reached = drive_run();
  EXPECT_TRUE(reached.end);
  EXPECT_EQ(reached.restarts, 0);
  EXPECT_EQ(launcher_.launches_of("particles"), 1);
}

// ... and no more than that: a node never heard from is lost once the start-up allowance is over.
TEST_F(RuntimeTest, NodeThatNeverStartsIsLostAfterTheStartupTimeout) {
  scene_.run.startup_timeout = 2.0;
  launcher_.start_delay_s = [](const std::string& node, int) { return node == "fluid" ? 60.0 : 0.0; };
  const auto start = std::chrono::steady_clock::now();
  try {
    drive_run();
    FAIL() << "a node that never started went unnoticed";
  } catch (const NodeLost& e) {
    EXPECT_NE(std::string(e.what()).find("fluid node did not start at step 0: no heartbeat for 2 s"), std::string::npos)
        << e.what();
  }
  const double waited = seconds_since(start);
  EXPECT_GE(waited, 2.0);
  EXPECT_LT(waited, 5.0);
}
