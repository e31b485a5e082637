// The slurm launcher's placement (coordinator/node_launcher.h): the nodes share the allocation
// the coordinator runs in, read from Slurm itself (scontrol), and outside one the run is refused
// in one line before anything starts.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "node_launcher.h"

using namespace hemo;

namespace {
// Sets (or, with nullopt, unsets) an environment variable for one test, and restores it.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, std::optional<std::string> value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value)
      ::setenv(name, value->c_str(), 1);
    else
      ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_)
      ::setenv(name_, old_->c_str(), 1);
    else
      ::unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

Scene slurm_scene(int fluid_ranks, int particle_ranks) {
  Scene s;
  s.hosts.launcher = Launcher::slurm;
  s.run.fluid_ranks = fluid_ranks;
  s.run.particle_ranks = particle_ranks;
  return s;
}
}  // namespace

TEST(SlurmPlacement, TheNodesShareTheAllocationSlurmNames) {
  // `scontrol show hostnames` expands the node list without a cluster but not without a
  // configuration to parse: a minimal one of the test's own, so that the test does not depend on
  // whether this machine's Slurm was configured yet (deploy.slurm does it, later in the suite).
  const auto conf = std::filesystem::temp_directory_path() / "hemocosim-test-slurm.conf";
  std::ofstream(conf) << "ClusterName=hemotest\nSlurmctldHost=localhost\n";
  const ScopedEnv config("SLURM_CONF", conf.string());
  const ScopedEnv job("SLURM_JOB_ID", "42"), nodes("SLURM_JOB_NODELIST", "node[07-09]");
  const Scene placed = placed_in_allocation(slurm_scene(1, 4));
  EXPECT_EQ(placed.hosts.fluid, "node07:1");
  EXPECT_EQ(placed.hosts.particles, "node08:2,node09:2");
  // Hosts the scene gives are kept.
  Scene given = slurm_scene(1, 2);
  given.hosts.particles = "node09:2";
  EXPECT_EQ(placed_in_allocation(given).hosts.particles, "node09:2");
  EXPECT_EQ(placed_in_allocation(given).hosts.fluid, "node07:1");
  std::filesystem::remove(conf);
}

TEST(SlurmPlacement, OutsideAnAllocationTheRunIsRefusedInOneLine) {
  const ScopedEnv job("SLURM_JOB_ID", std::nullopt);
  try {
    placed_in_allocation(slurm_scene(1, 1));
    FAIL() << "placed without an allocation";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("sbatch or salloc"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  Scene local = slurm_scene(1, 1);
  local.hosts.launcher = Launcher::ssh;
  EXPECT_EQ(placed_in_allocation(local).hosts.particles, "");  // other launchers: unchanged
}
