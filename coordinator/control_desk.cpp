// SPDX-License-Identifier: GPL-3.0-or-later
#include "control_desk.h"

#include <fmt/format.h>

#include <unistd.h>
#include <chrono>

namespace hemo {

namespace {
bool is_node(const std::string& node) { return node == "fluid" || node == "particles"; }

// A control message; nothing for bytes that are not one (they carry the run's tag, but must not
// stop a run or a requester by failing to decode).
std::optional<control_t> as_control(const Received& msg) {
  try {
    return msg.as<control_t>();  // decoded by the bus on arrival; LCM's decoder can throw
  } catch (const std::exception&) {
    return std::nullopt;
  }
}
}  // namespace

ControlDesk::ControlDesk(const RunContext& ctx) : bus_(ctx, "coordinator", {channel::control}) {}

std::optional<ControlRequest> ControlDesk::take() {
  std::optional<ControlRequest> fresh;
  bus_.poll(0, [&](const Received& msg) {
    const auto decoded = as_control(msg);
    if (!decoded) return;
    const auto& m = *decoded;
    if (m.action != "restart" && m.action != "swap") return;  // an answer, ours or another coordinator's
    if (auto it = answers_.find(m.request_id); it != answers_.end()) {
      bus_.publish(channel::control, it->second, msg.envelope.step);  // the answer was lost: again
      return;
    }
    if (taken_.count(m.request_id) || fresh) return;  // being acted on; or one at a time
    ControlRequest r{m.request_id, m.action, m.node, m.command};
    taken_.insert(r.id);
    if (!is_node(r.node))
      answer(r, false, fmt::format("no node named '{}' (fluid or particles)", r.node));
    else if (r.action == "swap" && r.command.empty())
      answer(r, false, "a swap needs the command that takes the node's place");
    else
      fresh = r;
  });
  return fresh;
}

void ControlDesk::answer(const ControlRequest& request, bool done, const std::string& detail) {
  control_t a;
  a.request_id = request.id;
  a.action = done ? "done" : "refused";
  a.node = request.node;
  a.command = request.command;
  a.detail = detail;
  answers_[request.id] = a;
  bus_.publish(channel::control, a, 0);
}

control_t ask_coordinator(const RunContext& ctx, const ControlRequest& request, double timeout_s) {
  Bus bus(ctx, fmt::format("control-{}", getpid()), {channel::control});
  control_t ask;
  ask.request_id = request.id;
  ask.action = request.action;
  ask.node = request.node;
  ask.command = request.command;
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  auto last_sent = Clock::now() - std::chrono::hours(1);
  std::optional<control_t> answer;
  while (!answer && Clock::now() < deadline) {
    // Again every second: UDP may drop it, and the coordinator acts on a request id once.
    if (Clock::now() - last_sent > std::chrono::seconds(1)) {
      bus.publish(channel::control, ask, 0);
      last_sent = Clock::now();
    }
    bus.poll(0.1, [&](const Received& msg) {
      const auto m = as_control(msg);
      if (m && m->request_id == request.id && (m->action == "done" || m->action == "refused")) answer = *m;
    });
  }
  if (!answer)
    throw std::runtime_error(
        fmt::format("no answer from the run's coordinator within {:.0f} s: is the run going?", timeout_s));
  return *answer;
}

}  // namespace hemo
