// Requests to restart or swap a node of a running run (`hemocosim restart`, `hemocosim swap`;
// docs/design.md "Checkpoint, restart, swap"), heard on the run's CONTROL channel. Like every
// message of the run they carry its HMAC: only someone who can read RUN_DIR/secret can ask.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"

#include <hemo/control_t.hpp>

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>

namespace hemo {

struct ControlRequest {
  std::int64_t id = 0;
  std::string action;   // "restart" or "swap"
  std::string node;     // "fluid" or "particles"
  std::string command;  // swap: the program (and arguments) that takes the node's place
};

// Thrown out of the lockstep once the step a request came in is done and checkpointed: the
// coordinator stops both nodes and starts them again from that checkpoint.
struct RestartRequested : std::runtime_error {
  explicit RestartRequested(ControlRequest r) : std::runtime_error("restart requested"), request(std::move(r)) {}
  ControlRequest request;
};

// The coordinator's side: takes requests, answers them once acted on.
class ControlDesk {
 public:
  explicit ControlDesk(const RunContext& ctx);

  // A request that came since the last call, if any. A repeat of a request taken before is not
  // new (it is answered again once answered); a malformed one is refused here.
  std::optional<ControlRequest> take();
  // Answers a request, and every repeat of it from now on.
  void answer(const ControlRequest& request, bool done, const std::string& detail);

 private:
  Bus bus_;
  std::set<std::int64_t> taken_;
  std::map<std::int64_t, control_t> answers_;  // by request id
};

// The requester's side: publishes the request until the coordinator answers it (or `timeout_s`
// passes: no coordinator runs the run). Returns the answer.
control_t ask_coordinator(const RunContext& ctx, const ControlRequest& request, double timeout_s);

}  // namespace hemo
