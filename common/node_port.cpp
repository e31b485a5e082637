// SPDX-License-Identifier: GPL-3.0-or-later
#include "node_port.h"

#include <hemo/hello_t.hpp>
#include <hemo/step_done_t.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <filesystem>

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
      run_dir_(std::filesystem::path(heard_report_file(ctx, role_)).parent_path().parent_path().string()),
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

void NodePort::keep_pending(const Received& msg) {
  if (msg.kind == channel::step || msg.kind == channel::mesh || msg.kind == channel::fluid_state ||
      msg.kind == channel::particle_feedback || msg.kind == channel::partition || msg.kind == channel::domain)
    pending_[{msg.kind, msg.envelope.step}] = msg;
  // Only the other node's hello: this node's own and a resent one of a monitor are not wanted.
  if (msg.kind == channel::hello && msg.as<hello_t>().role != role_) pending_[{msg.kind, 0}] = msg;
}

Received NodePort::wait_for(const std::string& kind, std::int64_t step, const char* what) {
  const auto& ctx = bus_->context();
  double last_heard = now(), last_asked = now();
  PauseWatch pauses;
  bool said_waiting = false;
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
      if (msg.envelope.sender == "coordinator") {
        if (said_waiting)
          spdlog::info("{}: the coordinator is heard again after {:.0f} s of silence", role_, now() - last_heard);
        last_heard = now();
        said_waiting = false;
      }
      keep_pending(msg);
    });
    // While this node was paused nobody could be heard: that silence is not the coordinator's.
    if (const double away = pauses.turn(); away > 0) {
      last_heard = std::min(now(), last_heard + away);
      if (away > std::min(5.0, ctx.timeout_s / 2)) spdlog::warn("{}: this node was {}", role_, pause_words(away));
    }
    if (now() - last_asked > ctx.retry_s && !pending_.count({kind, step})) {
      bus_->request_resend(kind, step);
      last_asked = now();
    }
    const double silent = now() - last_heard;
    if (silent <= ctx.timeout_s) continue;
    const auto why = coordinator_silence(silent);
    if (!why) {
      if (!said_waiting)
        spdlog::warn(
            "{}: nothing heard from the coordinator for {:.0f} s while waiting for {} (step {}); {}: waiting for it",
            role_, silent, what, step, coordinator_whereabouts());
      said_waiting = true;
      continue;
    }
    gave_up_after_s_ = silent;
    throw std::runtime_error(
        fmt::format("{}: nothing heard from the coordinator for {:.0f} s while waiting for {} (step {}){}", role_,
                    silent, what, step, *why));
  }
}

// Whether a silence of `silent` seconds ends the wait, and why (docs/architecture.md "Liveness"):
// nothing while the coordinator may come back.
std::optional<std::string> NodePort::coordinator_silence(double silent) const {
  const auto& ctx = bus_->context();
  // Its messages arrive but are refused as older than this node: waiting does not help.
  if (const auto lag = bus_->prestart_lag_s("coordinator"))
    return fmt::format(
        "; its messages are refused as sent before this node started: its clock is {:.1f} s behind this host's "
        "(clock skew: the hosts' clocks must agree within {:g} s; NTP?)",
        *lag, 1e-6 * static_cast<double>(kClockSkewAllowanceUs));
  switch (coordinator_state(run_dir_)) {
    case ProcessState::stopped:
      return std::nullopt;  // it decides once it runs again
    case ProcessState::running:
    case ProcessState::elsewhere:
      if (silent <= kCoordinatorPatience * ctx.timeout_s) return std::nullopt;
      return fmt::format("; {}, and this node gave up after {:g} times run.node_timeout_s", coordinator_whereabouts(),
                         kCoordinatorPatience);
    case ProcessState::gone:
      return std::string("; its process is gone");
    case ProcessState::unknown:
      break;
  }
  return std::string("");
}

std::string NodePort::coordinator_whereabouts() const {
  switch (coordinator_state(run_dir_)) {
    case ProcessState::stopped:
      return "its process is stopped (SIGSTOP or a suspended shell?)";
    case ProcessState::running:
      return "its process runs";
    case ProcessState::elsewhere:
      return "its process is on another host";
    case ProcessState::gone:
      return "its process is gone";
    case ProcessState::unknown:
      break;
  }
  return "where it runs is not known";
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

Diagnostics NodePort::with_bus_traffic(const Diagnostics& diag) {
  Diagnostics out = diag;
  const BusTraffic current = bus_->traffic();
  auto add = [&](const char* way, const std::map<std::string, std::uint64_t>& total,
                 const std::map<std::string, std::uint64_t>& before) {
    for (const auto& [kind, bytes] : total) {
      const auto it = before.find(kind);
      const std::uint64_t since = bytes - (it == before.end() ? 0 : it->second);
      if (since == 0) continue;
      std::string name = kind;
      std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
      out.emplace_back(fmt::format("bus_{}_{}_B", way, name), static_cast<double>(since));
    }
  };
  // A report without diagnostics (a resumed node's first, of a step the coordinator has) stays
  // without.
  if (!diag.empty()) {
    add("sent", current.sent, traffic_reported_.sent);
    add("received", current.received, traffic_reported_.received);
  }
  traffic_reported_ = current;
  return out;
}

void NodePort::finalize() {
  report_done(true, "", {{"finalized", 1}});
  heartbeat_.reset();
  bus_->log_counters();  // the process may exit without unwinding
}

void NodePort::fail(const std::string& error) {
  times_.compute_s = now() - step_started_;
  // Gave up on a silent coordinator: it tells that coordinator, if it runs again, that the nodes
  // are to be restarted, not the run ended (docs/architecture.md "Liveness").
  Diagnostics diag;
  if (gave_up_after_s_ > 0) diag.emplace_back(kCoordinatorSilentDiagnostic, gave_up_after_s_);
  // Several copies: the coordinator must learn why, even if UDP drops one.
  for (int i = 0; i < 3; ++i) report_done(false, error, diag);
  heartbeat_.reset();
  bus_->log_counters();
}

int NodePort::peer_ranks() {
  if (!peer_ranks_) peer_ranks_ = wait_for(channel::hello, 0, "the other node's hello").as<hello_t>().ranks;
  return *peer_ranks_;
}

void FluidPort::initialize(mesh_t& mesh) { bus_->publish(channel::mesh, mesh, 0, /*keep=*/true); }

std::optional<FluidStep> FluidPort::advance_partitioned(const Diagnostics& diag) {
  fluid_state_t none;
  auto next = advance_with("", none, "", -1, diag, /*report_first=*/false);
  if (!next) return std::nullopt;
  return FluidStep{next->first, {}};
}

std::optional<ParticleStep> ParticlePort::advance_partitioned(const Diagnostics& diag) {
  particle_feedback_t none;
  auto next = advance_with("", none, "", 0, diag, /*report_first=*/true);
  if (!next) return std::nullopt;
  return ParticleStep{next->first, {}};
}

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
