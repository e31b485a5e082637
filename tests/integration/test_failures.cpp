// Failures are loud and named: a killed node, a silent node, a bad scene.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_helpers.h"

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <regex>
#include <sstream>
#include <thread>
#include <vector>

using namespace hemo::test;

namespace {
// Starts a long run in the background, waits until it is stepping, signals one node.
CommandResult run_and_signal(const std::string& node, int signal, const std::string& name) {
  const std::string dir = fresh_run_dir(name);
  const std::string text = small_scene_text(100000);
  const std::string long_scene = dir + ".toml";
  std::ofstream(long_scene) << text;
  auto result =
      std::async(std::launch::async, [&] { return run(bin("hemocosim") + " run " + long_scene + " --out " + dir); });
  // Signal the node once the run steps: before that (a loaded machine can take over a minute to
  // start both nodes) the coordinator is still checking the bus, and says so instead.
  EXPECT_TRUE(wait_until_stepping(dir, 300)) << "the run never stepped";
  long pid = 0;
  std::ifstream(dir + "/" + node + ".pid") >> pid;
  EXPECT_GT(pid, 0);
  if (pid > 0) kill(static_cast<pid_t>(pid), signal);
  return result.get();
}
}  // namespace

TEST(Failures, KilledParticleNodeStopsTheRunNamingIt) {
  const auto r = run_and_signal("particles", SIGKILL, "kill-particles");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("particles node"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("signal 9"), std::string::npos) << r.output;
  EXPECT_LT(r.seconds, 120);
}

TEST(Failures, KilledFluidNodeStopsTheRunNamingIt) {
  const auto r = run_and_signal("fluid", SIGKILL, "kill-fluid");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("fluid node"), std::string::npos) << r.output;
}

// A stopped (not dead) node sends no heartbeat: the coordinator gives up after node_timeout_s (10 s).
TEST(Failures, FrozenNodeTimesOutNamingIt) {
  const auto r = run_and_signal("fluid", SIGSTOP, "freeze-fluid");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("fluid node stopped answering"), std::string::npos) << r.output;
}

namespace {
// The process of MPI rank `rank` among the descendants of `pid` (Open MPI tells each rank its
// number in OMPI_COMM_WORLD_RANK); 0 when there is none.
pid_t mpi_rank_below(pid_t pid, int rank) {
  std::map<pid_t, std::vector<pid_t>> children;
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string line;
    if (!std::getline(stat, line) || line.rfind(')') == std::string::npos) continue;
    std::istringstream rest(line.substr(line.rfind(')') + 2));
    char state = 0;
    pid_t parent = 0;
    rest >> state >> parent;
    children[parent].push_back(static_cast<pid_t>(std::stol(name)));
  }
  const std::string wanted = "OMPI_COMM_WORLD_RANK=" + std::to_string(rank);
  std::vector<pid_t> todo{pid};
  while (!todo.empty()) {
    const pid_t p = todo.back();
    todo.pop_back();
    for (const pid_t c : children[p]) {
      todo.push_back(c);
      std::ifstream environ("/proc/" + std::to_string(c) + "/environ");
      for (std::string var; std::getline(environ, var, '\0');)
        if (var == wanted) return c;
    }
  }
  return 0;
}
}  // namespace

// One rank of a two-rank particle node stopped alone (SIGSTOP), its node's rank 0 beating on:
// the coordinator names the node, the rank and the step once the rank's own heartbeat has been
// silent for node_timeout_s (10 s), without a restart to go on from (no checkpoint yet).
TEST(Failures, AFrozenRankOfATwoRankNodeIsNamedByNodeRankAndStep) {
  const std::string dir = fresh_run_dir("freeze-particle-rank");
  std::ofstream(dir + ".toml") << small_scene_text(100000);
  auto result = std::async(std::launch::async, [&] {
    return run(bin("hemocosim") + " run " + dir + ".toml --out " + dir + " --np-particles 2");
  });
  ASSERT_TRUE(wait_until_stepping(dir, 300)) << "the run never stepped";
  long node = 0;
  std::ifstream(dir + "/particles.pid") >> node;
  const pid_t rank1 = mpi_rank_below(static_cast<pid_t>(node), 1);
  EXPECT_GT(rank1, 0) << "no rank 1 below the particle node's process " << node;
  if (rank1 > 0) kill(rank1, SIGSTOP);
  const auto r = result.get();
  if (rank1 > 0) kill(rank1, SIGKILL);  // whatever its job's end left of it
  EXPECT_NE(r.exit_code, 0);
  const std::string line = error_line(r.output);
  EXPECT_TRUE(std::regex_search(line, std::regex("particles node's rank 1 of 2 stopped answering at step [0-9]+: "
                                                 "no heartbeat for 10 s")))
      << r.output;
  EXPECT_LT(r.seconds, 200);
}

// Until a node has been heard from it is starting up (MPI launch, engine set-up, a loaded host):
// it has run.startup_timeout_s for its first heartbeat, not the shorter node_timeout_s; a node
// that never says anything within the start-up allowance is named as not started.
namespace {
CommandResult run_with_slow_particle_start(const std::string& name, int delay_s, const std::string& timeouts) {
  const std::string dir = fresh_run_dir(name);
  const std::string wrapper = dir + "-slow-particles.sh";
  std::ofstream(wrapper) << "#!/bin/sh\nsleep " << delay_s << "\nexec " << bin("hemocosim-particles") << " \"$@\"\n";
  std::filesystem::permissions(wrapper, std::filesystem::perms::owner_all);
  std::string text = small_scene_text(20, "particle_command = \"" + wrapper + "\"\n" + timeouts);
  const std::string own_timeout = "node_timeout_s = 10";
  const auto at = text.find(own_timeout);
  if (at == std::string::npos) throw std::runtime_error("coupled_small.toml lost its node_timeout_s");
  text.erase(at, own_timeout.size());
  std::ofstream(dir + ".toml") << text;
  return run(bin("hemocosim") + " run " + dir + ".toml --out " + dir);
}
}  // namespace

TEST(Failures, ANodeSlowToStartIsGivenTheStartUpAllowance) {
  const auto r = run_with_slow_particle_start("slow-start", 5, "node_timeout_s = 2\nstartup_timeout_s = 120\n");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("done in"), std::string::npos) << r.output;
}

TEST(Failures, ANodeThatNeverStartsIsNamedAfterTheStartUpAllowance) {
  const auto r = run_with_slow_particle_start("never-starts", 60, "node_timeout_s = 1\nstartup_timeout_s = 4\n");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("particles node did not start at step 0: no heartbeat for 4 s"), std::string::npos)
      << r.output;
  EXPECT_LT(r.seconds, 40) << r.output;
}

// The stability guards stop a run whose reports break them, in one line naming the cause, and
// keep the state the run went unstable in: the nodes are stopped in order and write it.
namespace {
void expect_guard_stops_run(const std::string& name, const std::string& run_keys, const std::string& cause) {
  const std::string dir = fresh_run_dir(name);
  const std::string path = dir + ".toml";
  std::ofstream(path) << small_scene_text(40, run_keys);
  const auto r = run(bin("hemocosim") + " run " + path + " --out " + dir);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find(cause), std::string::npos) << r.output;
  const auto at = r.output.find(" at step ");
  ASSERT_NE(at, std::string::npos) << r.output;
  const long step = std::stol(r.output.substr(at + 9));
  EXPECT_GE(step, 1);
  EXPECT_LE(step, 40);
  // The state at the failing step: the particles' last snapshot is that step's.
  const auto names = snapshot_names(dir + "/particles.h5");
  ASSERT_FALSE(names.empty());
  EXPECT_EQ(std::stol(names.back()), step) << "the particles did not keep the state of the unstable step";
  EXPECT_TRUE(std::filesystem::exists(dir + "/particles.xmf"));
}
}  // namespace

TEST(Failures, CourantNumberAboveTheGuardStopsTheRunNamingIt) {
  // Any moving flow breaks a limit of 1e-9.
  expect_guard_stops_run("guard-courant", "max_courant = 1e-9\n", "fluid Courant number");
}

TEST(Failures, OverlapAboveTheGuardStopsTheRunNamingIt) {
  // The placement leaves touching cells; any contact breaks a limit of 1e-12 of a diameter.
  expect_guard_stops_run("guard-overlap", "max_overlap = 1e-12\n", "cells overlap by");
}

TEST(Failures, UnknownSceneKeyIsRefusedInOneLineNamingIt) {
  const std::string dir = fresh_run_dir("unknown-key");
  const auto r = run(bin("hemocosim") + " run " + scene("unknown_key.toml") + " --out " + dir);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find("vessel.wall_thickness_um"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(":4:"), std::string::npos) << r.output;  // its line
  EXPECT_FALSE(std::filesystem::exists(dir)) << "a refused scene must not create a run";
}

// A scene without particles: `check` says what `run` will do, and `run` refuses it in one line
// before it creates anything (the particle node would stop at its start, after the fluid node).
TEST(Failures, SceneWithoutParticlesIsRefusedByRunInOneLine) {
  const std::string dir = fresh_run_dir("no-particles");
  const std::string path = dir + ".toml";
  std::ofstream(path) << "[vessel]\ndiameter_um = 100\nlength_um = 600\n[driving]\nwall_shear_rate_per_s = 799\n";
  const auto check = run(bin("hemocosim") + " check " + path);
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find("particles   none"), std::string::npos) << check.output;
  const auto r = run(bin("hemocosim") + " run " + path + " --out " + dir);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find("no particles"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir)) << "a refused scene must not create a run";
  std::filesystem::remove(path);
}

TEST(Failures, HelpWorksForEveryCommand) {
  for (const std::string cmd :
       {"hemocosim --help", "hemocosim run --help", "hemocosim check --help", "hemocosim monitor --help",
        "hemocosim resume --help", "hemocosim analyze --help", "hemocosim plot --help", "hemocosim study --help",
        "hemocosim bench --help", "hemocosim restart --help", "hemocosim swap --help", "hemocosim-fluid --help",
        "hemocosim-particles --help"}) {
    const auto r = run(bin("") + cmd);
    EXPECT_EQ(r.exit_code, 0) << cmd << "\n" << r.output;
    EXPECT_NE(r.output.find("--"), std::string::npos) << cmd;
  }
}

// The monitor joins a running run's bus and shows its channels; Ctrl-C on the coordinator
// stops the run and its nodes, keeping what was written.
TEST(Monitor, ShowsTheTrafficOfARunningRun) {
  const std::string dir = fresh_run_dir("monitored");
  const std::string text = small_scene_text(100000);
  std::ofstream(dir + ".toml") << text;
  auto result =
      std::async(std::launch::async, [&] { return run(bin("hemocosim") + " run " + dir + ".toml --out " + dir); });
  // Stepping, not merely started: a particle node still starting up has nothing to count yet.
  ASSERT_TRUE(wait_until_stepping(dir)) << "the run did not start stepping";
  const auto mon = run(bin("hemocosim") + " monitor " + dir + " --duration 4 --plain");
  long pid = 0;
  std::ifstream(dir + "/coordinator.pid") >> pid;
  ASSERT_GT(pid, 0);
  kill(static_cast<pid_t>(pid), SIGINT);
  const auto r = result.get();

  EXPECT_EQ(mon.exit_code, 0) << mon.output;
  for (const char* channel : {"FLUID_STATE", "PARTICLE_FEEDBACK", "STEP_DONE", "STEP ", "HEARTBEAT"})
    EXPECT_NE(mon.output.find(channel), std::string::npos) << channel << " missing in\n" << mon.output;
  EXPECT_NE(mon.output.find("fluid alive"), std::string::npos) << mon.output;
  // Each process's drops by cause, from its heartbeat: a clean run drops nothing.
  EXPECT_NE(mon.output.find("dropped by"), std::string::npos) << mon.output;
  for (const char* who : {"coordinator", "fluid", "particles", "\\(this monitor\\)"})
    EXPECT_TRUE(
        std::regex_search(mon.output, std::regex(std::string("\n") + who + " +[1-9][0-9]* +0 +0 +0 +0 +0 +0\n")))
        << who << " in\n"
        << mon.output;
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("interrupted"), std::string::npos) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir + "/particles.h5"));
  // Interrupted, it checkpoints the step it stopped after: `hemocosim resume` can go on.
  const auto at = r.output.find("interrupted after step ");
  ASSERT_NE(at, std::string::npos) << r.output;
  const long step = std::stol(r.output.substr(at + 23));
  EXPECT_NE(r.output.find("its last checkpoint is step " + std::to_string(step)), std::string::npos) << r.output;
}

namespace {
// Processes (not zombies) in process group `pgid`, from /proc.
std::vector<long> live_processes_in_group(long pgid) {
  std::vector<long> found;
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(entry.path() / "stat");
    std::string stat;
    if (!std::getline(in, stat)) continue;
    const auto close = stat.rfind(')');  // after "pid (comm)": state ppid pgrp
    if (close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 2));
    char state = 0;
    long ppid = 0, pgrp = 0;
    rest >> state >> ppid >> pgrp;
    if (pgrp == pgid && state != 'Z') found.push_back(std::stol(name));
  }
  return found;
}
}  // namespace

// A coordinator killed outright (SIGKILL: no handler runs) takes its nodes with it: each node
// (and whatever runs in its process group) is gone within seconds, not left computing or
// waiting out its node timeout.
namespace {
// A long run of the small scene in the background, once it steps, and its processes' ids.
struct SteppingRun {
  std::string dir;
  std::future<hemo::test::CommandResult> result;
  long coordinator = 0, fluid = 0, particles = 0;
};
SteppingRun start_stepping_run(const std::string& name, const std::string& written_once_stepping) {
  SteppingRun r;
  r.dir = fresh_run_dir(name);
  std::ofstream(r.dir + ".toml") << small_scene_text(100000);  // node_timeout_s = 10
  const std::string dir = r.dir;
  r.result =
      std::async(std::launch::async, [dir] { return run(bin("hemocosim") + " run " + dir + ".toml --out " + dir); });
  for (int i = 0; i < 600 && !std::filesystem::exists(dir + "/" + written_once_stepping); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::this_thread::sleep_for(std::chrono::seconds(1));  // stepping
  std::ifstream(dir + "/coordinator.pid") >> r.coordinator;
  std::ifstream(dir + "/fluid.pid") >> r.fluid;
  std::ifstream(dir + "/particles.pid") >> r.particles;
  return r;
}
}  // namespace

TEST(Failures, NodesDieWithAKilledCoordinator) {
  SteppingRun running = start_stepping_run("orphaned", "metrics.csv");
  auto& result = running.result;
  const long coordinator = running.coordinator, fluid = running.fluid, particles = running.particles;
  ASSERT_GT(coordinator, 0);
  ASSERT_GT(fluid, 0);
  ASSERT_GT(particles, 0);
  ASSERT_FALSE(live_processes_in_group(fluid).empty());
  ASSERT_FALSE(live_processes_in_group(particles).empty());
  ASSERT_EQ(kill(static_cast<pid_t>(coordinator), SIGKILL), 0);
  result.get();
  const auto killed = std::chrono::steady_clock::now();
  while ((!live_processes_in_group(fluid).empty() || !live_processes_in_group(particles).empty()) &&
         std::chrono::steady_clock::now() - killed < std::chrono::seconds(10))
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  EXPECT_TRUE(live_processes_in_group(fluid).empty()) << "fluid node still running " << took << " s after";
  EXPECT_TRUE(live_processes_in_group(particles).empty()) << "particle node still running " << took << " s after";
  EXPECT_LT(took, 5.0);  // below the node timeout (10 s): they did not merely time out
}

// One Ctrl-C (or SIGTERM) stops the run within seconds, after the step under way, with a
// checkpoint of that very step to resume from, and its nodes with it.
TEST(Failures, AnInterruptStopsTheRunWithinSecondsWithACheckpointOfItsLastStep) {
  SteppingRun running = start_stepping_run("interrupted", "metrics.csv");
  auto& result = running.result;
  const long coordinator = running.coordinator, fluid = running.fluid, particles = running.particles;
  ASSERT_GT(coordinator, 0);
  ASSERT_FALSE(live_processes_in_group(fluid).empty());
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(kill(static_cast<pid_t>(coordinator), SIGINT), 0);
  const auto r = result.get();
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_NE(r.exit_code, 0);
  std::smatch stopped, checkpoint;
  ASSERT_TRUE(std::regex_search(r.output, stopped, std::regex("interrupted after step (\\d+)"))) << r.output;
  ASSERT_TRUE(std::regex_search(r.output, checkpoint, std::regex("its last checkpoint is step (\\d+)"))) << r.output;
  EXPECT_EQ(stopped[1], checkpoint[1]) << "the checkpoint is of the step the run stopped after";
  EXPECT_LT(took, 5.0);  // "within a few seconds" (issue #21); a step of this scene takes milliseconds
  for (int i = 0; i < 50 && !(live_processes_in_group(fluid).empty() && live_processes_in_group(particles).empty());
       ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(live_processes_in_group(fluid).empty());
  EXPECT_TRUE(live_processes_in_group(particles).empty());
}

// A second Ctrl-C (or SIGTERM) stops the coordinator at once, and its nodes with it.
TEST(Failures, ASecondInterruptStopsAtOnce) {
  SteppingRun running = start_stepping_run("interrupted-twice", "particles.pid");
  auto& result = running.result;
  const long coordinator = running.coordinator, fluid = running.fluid, particles = running.particles;
  ASSERT_GT(coordinator, 0);
  ASSERT_GT(fluid, 0);
  ASSERT_GT(particles, 0);
  ASSERT_FALSE(live_processes_in_group(fluid).empty());
  const auto t0 = std::chrono::steady_clock::now();
  kill(static_cast<pid_t>(coordinator), SIGTERM);
  kill(static_cast<pid_t>(coordinator), SIGINT);
  const auto r = result.get();
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("interrupted twice: stopped at once"), std::string::npos) << r.output;
  EXPECT_LT(took, 2.0);
  for (int i = 0; i < 50 && !(live_processes_in_group(fluid).empty() && live_processes_in_group(particles).empty());
       ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(live_processes_in_group(fluid).empty());
  EXPECT_TRUE(live_processes_in_group(particles).empty());
}
