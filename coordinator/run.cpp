// hemocosim run: launch both nodes and drive the lockstep to the end.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "commands.h"
#include "lockstep.h"
#include "progress.h"
#include "scene.h"
#include "xdmf.h"

#include <fmt/format.h>

#include <csignal>
#include <ctime>
#include <fstream>
#include <unistd.h>

namespace hemo {

namespace {
volatile std::sig_atomic_t interrupted = 0;
void on_signal(int) { interrupted = 1; }

std::string default_run_dir(const Scene& scene) {
  char stamp[32];
  const std::time_t t = std::time(nullptr);
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&t));
  return fmt::format("runs/{}-{}", scene.run.name, stamp);
}
// The lockstep from start-up to the stop order, with progress and the final profile.
void drive(const Scene& scene, const RunDirectory& dir, const RunContext& ctx) {
  Lockstep lockstep(scene, dir, ctx);
  lockstep.await(0, scene.run.startup_timeout);

  const long steps = scene.time.coupling_steps;
  Progress progress(steps, scene.time.coupling_interval);
  for (long k = 1; k <= steps; ++k) {
    if (interrupted) throw std::runtime_error(fmt::format("interrupted at step {}; output so far is in {}", k, dir.path));
    const bool output = k % scene.output.every_steps == 0 || k == steps;
    lockstep.order(k, k * scene.time.coupling_interval, output);
    try {
      lockstep.await(k, scene.run.step_timeout);
    } catch (const UnstableRun&) {
      // Keep the state the run went unstable in: the nodes write it as they finish.
      try { lockstep.stop(k + 1); } catch (const std::exception&) {}
      throw;
    }
    progress.update(k, fmt::format("fluid {:.2f} s, particles {:.2f} s", lockstep.compute_s("fluid"),
                                   lockstep.compute_s("particles")));
  }
  lockstep.stop(steps + 1);
  fmt::print(stderr, "{}", lockstep.profile_report(progress.seconds(), steps));
  fmt::print(stderr, "hemocosim: done in {:.1f} s; results in {}\n", progress.seconds(), dir.path);
}
}  // namespace

int run_command(const RunOptions& opt) {
  Scene scene = load_scene(opt.scene);
  if (opt.fluid_ranks > 0) scene.run.fluid_ranks = opt.fluid_ranks;
  if (opt.particle_ranks > 0) scene.run.particle_ranks = opt.particle_ranks;
  auto [dir, ctx] = RunDirectory::create(opt.out.empty() ? default_run_dir(scene) : opt.out, opt.scene);
  ctx.drop_every = scene.run.drop_every;
  std::ofstream(dir.path + "/coordinator.pid") << getpid() << "\n";
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  fmt::print(stderr, "hemocosim: run {} in {}\n", ctx.run_id, dir.path);

  try {
    drive(scene, dir, ctx);
  } catch (...) {
    // The nodes are stopped by now; make what they wrote openable before reporting.
    try { write_paraview_sidecars(dir.path); } catch (const std::exception&) {}
    throw;
  }
  const int snapshots = write_paraview_sidecars(dir.path);
  fmt::print(stderr, "hemocosim: {} particle snapshots; open {}/particles.xmf and fluid/fluid.foam in ParaView\n",
             snapshots, dir.path);
  return 0;
}

}  // namespace hemo
