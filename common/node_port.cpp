// SPDX-License-Identifier: GPL-3.0-or-later
#include "node_port.h"

#include <hemo/hello_t.hpp>
#include <hemo/step_done_t.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>

namespace hemo {

double NodePort::now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

NodePort::NodePort(const RunContext& ctx, std::string role, std::string program, int ranks,
                   const std::vector<std::string>& kinds)
    : bus_(std::make_unique<Bus>(ctx, role, kinds)),
      // It also tells, in the run directory, whose heartbeats it hears: the coordinator's bus
      // check at start-up (docs/hosts.md).
      heartbeat_(std::make_unique<Heartbeat>(
          ctx, role, 0.5, [bus = bus_.get()] { return bus->counters(); },
          HeardReport{true, heard_report_file(ctx, role)})),
      role_(std::move(role)),
      step_(ctx.resume_step),
      step_started_(now()) {
  hello_t hello;
  hello.role = role_;
  hello.program = std::move(program);
  char host[256] = {0};
  gethostname(host, sizeof host - 1);
  hello.hostname = host;
  hello.pid = static_cast<int32_t>(getpid());
  hello.ranks = ranks;
  if (ctx.encrypt) spdlog::info("{}: the bus's messages are sealed (bus.encrypt: AES-256-GCM)", role_);
  bus_->publish(channel::hello, hello, 0, /*keep=*/true);
}

NodePort::~NodePort() = default;

Received NodePort::wait_for(const std::string& kind, std::int64_t step, const char* what) {
  const auto& ctx = bus_->context();
  double last_heard = now(), last_asked = now();
  for (;;) {
    auto it = pending_.find({kind, step});
    if (it != pending_.end()) {
      Received r = std::move(it->second);
      // Older steps of this kind are of no use any more; other kinds may be early, keep them.
      pending_.erase(pending_.lower_bound({kind, INT64_MIN}), std::next(it));
      return r;
    }
    bus_->poll(0.05, [&](const Received& msg) {
      // Only the coordinator keeps a node waiting: two nodes whose coordinator is gone would
      // otherwise keep each other alive with their heartbeats, for ever.
      if (msg.envelope.sender == "coordinator") last_heard = now();
      if (msg.kind == channel::step || msg.kind == channel::mesh || msg.kind == channel::fluid_state ||
          msg.kind == channel::particle_feedback)
        pending_[{msg.kind, msg.envelope.step}] = msg;
    });
    if (now() - last_asked > ctx.retry_s && !pending_.count({kind, step})) {
      bus_->request_resend(kind, step);
      last_asked = now();
    }
    if (now() - last_heard > ctx.timeout_s)
      throw std::runtime_error(
          fmt::format("{}: nothing heard from the coordinator for {:.0f} s while waiting for {} (step {})", role_,
                      ctx.timeout_s, what, step));
  }
}

void NodePort::report_done(bool ok, const std::string& error, const Diagnostics& diag) {
  step_done_t done;
  done.node = role_;
  done.ok = ok;
  done.error = error;
  done.compute_s = times_.compute_s;
  done.wait_s = times_.wait_s;
  done.n_diagnostics = static_cast<int32_t>(diag.size());
  for (const auto& [name, value] : diag) {
    done.names.push_back(name);
    done.values.push_back(value);
  }
  bus_->publish(channel::step_done, done, step_, /*keep=*/true);
}

void NodePort::finalize() {
  report_done(true, "", {{"finalized", 1}});
  heartbeat_.reset();
  bus_->log_counters();  // the process may exit without unwinding
}

void NodePort::fail(const std::string& error) {
  times_.compute_s = now() - step_started_;
  // Several copies: the coordinator must learn why, even if UDP drops one.
  for (int i = 0; i < 3; ++i) report_done(false, error, {});
  heartbeat_.reset();
  bus_->log_counters();
}

void FluidPort::initialize(mesh_t& mesh) { bus_->publish(channel::mesh, mesh, 0, /*keep=*/true); }

std::optional<FluidStep> FluidPort::advance(fluid_state_t& state, const Diagnostics& diag) {
  auto next = advance_with(channel::fluid_state, state, channel::particle_feedback, -1, diag,
                           /*report_first=*/false);
  if (!next) return std::nullopt;
  return FluidStep{next->first, next->second.as<particle_feedback_t>()};
}

mesh_t ParticlePort::initialize() { return wait_for(channel::mesh, 0, "the fluid mesh").as<mesh_t>(); }

std::optional<ParticleStep> ParticlePort::advance(particle_feedback_t& feedback, const Diagnostics& diag) {
  auto next = advance_with(channel::particle_feedback, feedback, channel::fluid_state, -fluid_lag_, diag,
                           /*report_first=*/true);
  if (!next) return std::nullopt;
  return ParticleStep{next->first, next->second.as<fluid_state_t>()};
}

}  // namespace hemo
