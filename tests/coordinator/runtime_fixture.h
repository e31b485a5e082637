// A run of the coupling runtime (coordinator/run_driver.h) with fake nodes: a fresh run
// directory, a scene of fast steps and short timeouts, and drive() called as `hemocosim run`
// calls it, with the nodes launched by a FakeLauncher. The bus is in memory (common/wire.h,
// inproc://): the same envelope, tags and checks as a run's, no socket, no engine.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "fake_nodes.h"
#include "run_driver.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

namespace hemo::test {

class RuntimeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char root[] = "/tmp/hemo_runtime_XXXXXX";
    ASSERT_NE(mkdtemp(root), nullptr);
    root_ = root;
    const std::string scene_file = root_ + "/scene.toml";
    std::ofstream(scene_file) << "# the scene is given to drive() as an object; its file is only copied\n";
    auto [dir, ctx] = RunDirectory::create(root_ + "/run", scene_file);
    dir_ = dir;
    ctx_ = ctx;
    ctx_.lcm_url = "inproc://" + root_;
    dir_.record_bus_url(ctx_.lcm_url);
    scene_.time.coupling_interval = 1e-3;
    scene_.time.coupling_steps = 8;
    scene_.output.every_steps = 4;
    scene_.output.checkpoint_every_steps = 0;
    scene_.run.node_timeout = 1.0;
    scene_.run.startup_timeout = 4.0;
    scene_.run.step_timeout = 20.0;
    scene_.run.max_restarts = 0;
    scene_.run.fluid_command = "fake-fluid";
    scene_.run.particle_command = "fake-particles";
    // The fake nodes compute a step at once, not one after the other.
    scene_.coupling_scheme = CouplingScheme::parallel;
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) std::filesystem::remove_all(root_, ec);
  }

  // Runs from step 0 to `last` (0: the scene's end); `interrupted` stands for the signal handler.
  Reached drive_run(
      long last = 0, const std::function<bool()>& interrupted = [] { return false; }) {
    return drive(scene_, dir_, ctx_, {0, last > 0 ? last : scene_.time.coupling_steps}, launcher_, interrupted);
  }

  std::string root_;
  RunDirectory dir_;
  RunContext ctx_;
  Scene scene_;
  FakeLauncher launcher_;
};

}  // namespace hemo::test
