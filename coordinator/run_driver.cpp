// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_driver.h"

#include "control_desk.h"
#include "coupling_clock.h"
#include "lockstep.h"
#include "node_port.h"
#include "progress.h"

#include <fmt/format.h>

#include <cmath>
#include <optional>

namespace hemo {

namespace {
// The clock of a span: fixed intervals count from its first step; adaptive ones take the time
// the particle node resumed at and size the first interval from its start-up report.
CouplingClock span_clock(const Scene& scene, const Lockstep& lockstep, long first_step) {
  if (!scene.time.adaptive_interval()) return CouplingClock(scene.time, scene.output, first_step);
  const double resumed_at = first_step > 0 ? lockstep.diagnostic("particles", kTimeDiagnostic) : 0.0;
  if (!std::isfinite(resumed_at))
    throw std::runtime_error(fmt::format(
        "the particle node did not report the time of its checkpoint of step {} (adaptive intervals need it)",
        first_step));
  CouplingClock clock(scene.time, scene.output, first_step, resumed_at);
  clock.observe_relaxation_time(lockstep.diagnostic("particles", kRelaxationDiagnostic));
  return clock;
}

// The lockstep from start-up (at span.first) to the stop order, with progress and the final
// profile. Both nodes write a checkpoint every output.checkpoint_every_steps and at an early
// stop (interrupt, --stop-after-step); a run that fails keeps the last one both acknowledged.
// Returns where it got to. A restart or swap asked for (ControlDesk) is carried out at the
// end of the step it came in: that step is checkpointed and RestartRequested thrown; the
// request `restarted` (of the span before) is answered once the nodes run again.
Reached drive_span(const Scene& scene, const RunDirectory& dir, const RunContext& ctx, const Span span,
                   NodeLauncher& launcher, const std::function<bool()>& interrupted, Progress& progress,
                   ControlDesk& desk, std::optional<ControlRequest>& restarted) {
  const double span_start_s = progress.seconds();  // the profile is of this span: its steps, its wall time
  Lockstep lockstep(scene, dir, ctx, launcher, span.first);
  lockstep.await(span.first, scene.run.startup_timeout);
  lockstep.settle_bus_check();
  CouplingClock clock = span_clock(scene, lockstep, span.first);
  progress.starts_at(clock.time_s());
  if (restarted) {
    desk.answer(*restarted, true,
                fmt::format("{} node {} at step {}", restarted->node,
                            restarted->action == "swap" ? "swapped for `" + restarted->command + "`" : "restarted",
                            span.first));
    restarted.reset();
  }

  const long every_checkpoint = scene.output.checkpoint_every_steps;
  while (!clock.finished() && clock.step() < span.last) {
    const CouplingClock::Step step = clock.next();
    const long k = step.number;
    const bool last = k == span.last || clock.finished();
    const bool stopping_early = (interrupted() || last) && !clock.finished();
    auto request = desk.take();
    if (request && last) {
      desk.answer(*request, false, "the run is at its last step");
      request.reset();
    }
    const bool checkpoint = (every_checkpoint > 0 && k % every_checkpoint == 0) || stopping_early || request;
    lockstep.order(k, step.time_s, step.dt_s, step.output, checkpoint);
    try {
      lockstep.await(k, scene.run.step_timeout);
    } catch (const UnstableRun&) {
      // Keep the state the run went unstable in: the nodes write it as they finish. The last
      // checkpoint is the one from before: one of this step would resume into the instability.
      try {
        lockstep.stop(k + 1);
      } catch (const std::exception&) {
      }
      if (checkpoint) dir.drop_checkpoint(k);  // once the nodes are done writing
      throw;
    }
    if (checkpoint && lockstep.common_checkpoint() == k) {
      dir.seal_checkpoint(k);  // complete: one to go on from
      dir.keep_only_checkpoint(k);
    }
    if (request) throw RestartRequested(*request);
    clock.observe_relaxation_time(lockstep.diagnostic("particles", kRelaxationDiagnostic));
    progress.update(k, step.time_s,
                    fmt::format("{}fluid {:.2f} s, particles {:.2f} s",
                                clock.adaptive() ? fmt::format("dt {:.3g} s  ", step.dt_s) : "",
                                lockstep.compute_s("fluid"), lockstep.compute_s("particles")),
                    clock.finished() || stopping_early);
    if (stopping_early) break;
  }
  lockstep.stop(clock.step() + 1);
  fmt::print(stderr, "{}", lockstep.profile_report(progress.seconds() - span_start_s, clock.step() - span.first));
  return {clock.step(), clock.time_s(), clock.finished()};
}
}  // namespace

// Tells where to go on from after a run stopped before its end.
std::string resume_hint(const RunDirectory& dir) {
  const auto last = dir.last_checkpoint();
  return last ? fmt::format("; its last checkpoint is step {}: `hemocosim resume {}` goes on from there", *last,
                            dir.path)
              : "; it has no checkpoint to resume from";
}

// A node swapped for another program (`hemocosim swap`, kept in run.toml) runs as that one.
void use_swapped_programs(const RunDirectory& dir, Scene& scene) {
  if (!dir.fluid_command.empty()) scene.run.fluid_command = dir.fluid_command;
  if (!dir.particle_command.empty()) scene.run.particle_command = dir.particle_command;
}

// The whole span, restarting both nodes from their last common checkpoint when one dies or
// stops answering (at most run.max_restarts times), or when asked to (`hemocosim restart`,
// `hemocosim swap`; docs/design.md "Checkpoint, restart, swap").
Reached drive(const Scene& scene_as_given, RunDirectory& dir, const RunContext& given_ctx, Span span,
              NodeLauncher& launcher, const std::function<bool()>& interrupted) {
  Scene scene = scene_as_given;  // a swap changes a node's command
  RunContext ctx = given_ctx;
  ctx.encrypt = scene.bus.encrypt;  // the coordinator's messages; the nodes are told (Lockstep::launch)
  if (ctx.encrypt) fmt::print(stderr, "hemocosim: bus messages encrypted (bus.encrypt: AES-256-GCM)\n");
  ControlDesk desk(ctx);
  std::optional<ControlRequest> restarted;  // to answer once the nodes run again
  // Fixed intervals: the ETA is to the step the run stops after (--stop-after-step), not the end.
  const bool adaptive = scene.time.adaptive_interval();
  Progress progress(adaptive ? 0 : span.last,
                    adaptive ? scene.time.end_time() : static_cast<double>(span.last) * scene.time.coupling_interval,
                    span.first);
  for (int restarts = 0;;) {
    long from = 0;
    try {
      Reached reached = drive_span(scene, dir, ctx, span, launcher, interrupted, progress, desk, restarted);
      fmt::print(stderr, "hemocosim: {} in {:.1f} s{}; results in {}\n",
                 reached.end ? "done"
                 : scene.time.adaptive_interval()
                     ? fmt::format("stopped after step {} (t = {:.6g} s of {:.6g} s)", reached.step, reached.time_s,
                                   scene.time.end_time())
                     : fmt::format("stopped after step {} of {}", reached.step, scene.time.coupling_steps),
                 progress.seconds(),
                 restarts > 0 ? fmt::format(" ({} restart{})", restarts, restarts > 1 ? "s" : "") : "", dir.path);
      reached.restarts = restarts;
      return reached;
    } catch (const RestartRequested& asked) {
      // Both nodes are stopped by now (the lockstep is gone).
      const auto& r = asked.request;
      if (r.action == "swap") {
        dir.record_command(r.node, r.command);
        use_swapped_programs(dir, scene);
        dir.sign_commands(ctx, scene);  // asked for with the run's secret: a resume runs it too
      }
      const auto checkpoint = dir.last_checkpoint();
      if (!checkpoint) {
        desk.answer(r, false, "no checkpoint was completed to restart from");
        throw std::runtime_error(
            fmt::format("{} of the {} node asked for, but no checkpoint was completed", r.action, r.node));
      }
      from = *checkpoint;
      fmt::print(stderr,
                 "hemocosim: {} of the {} node asked for{}: restarting both nodes from the checkpoint of step {}\n",
                 r.action, r.node, r.action == "swap" ? " (`" + r.command + "`)" : "", from);
      restarted = r;
    } catch (const NodeLost& e) {
      if (dir.out_of_space()) throw;  // a restart would fail the same way (run.cpp names the cause)
      const auto checkpoint = dir.last_checkpoint();
      if (restarted) desk.answer(*restarted, false, e.what());
      if (!checkpoint || restarts == scene.run.max_restarts || interrupted()) {
        if (restarts == 0 || !checkpoint) throw;
        throw NodeLost(fmt::format("{} (after {} restart{})", e.what(), restarts, restarts > 1 ? "s" : ""));
      }
      ++restarts;
      from = *checkpoint;
      fmt::print(stderr,
                 "hemocosim: {}; restarting both nodes from the checkpoint of step {} (restart {} of at most {})\n",
                 e.what(), from, restarts, scene.run.max_restarts);
      restarted.reset();
    } catch (const std::exception& e) {
      if (restarted) desk.answer(*restarted, false, e.what());
      throw;
    }
    dir.drop_metrics_after(from);
    span.first = from;
  }
}

}  // namespace hemo
