// The surface between a node and the bus: three calls, as in preCICE's adapter API.
//
//   initialize  announce the node; the fluid publishes its mesh, the particles receive it
//   advance     publish this node's result of the current step and report it done; then wait
//               for the coordinator's next order and the inputs that step needs
//   finalize    report the end and leave the bus
//
// A node is nothing more than a loop over `advance`, so any program that speaks the messages
// in messages/ can take a node's place.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"
#include "liveness.h"

#include <hemo/fluid_state_t.hpp>
#include <hemo/mesh_t.hpp>
#include <hemo/particle_feedback_t.hpp>
#include <hemo/step_order_t.hpp>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace hemo {

// Named scalar diagnostics reported with each step (residuals, Courant number, counts...).
using Diagnostics = std::vector<std::pair<std::string, double>>;

// Diagnostics the coordinator's clock reads from the particle node (coordinator/coupling_clock.h):
// the shortest drag relaxation time m / beta of its particles over the step (at start-up: at
// rest), and the physical time it is at (a resumed run's, from its checkpoint).
inline constexpr const char* kRelaxationDiagnostic = "min_relaxation_time_s";
inline constexpr const char* kTimeDiagnostic = "time_s";
// Reported with a failure when the node gave up waiting for a silent coordinator (the seconds
// of silence): a coordinator that reads it was paused, and restarts the nodes.
inline constexpr const char* kCoordinatorSilentDiagnostic = "coordinator_silent_s";

struct StepTimes {
  double compute_s = 0;
  double wait_s = 0;
};

// What the fluid node gets for a step: the order and the particles' feedback of the step before.
struct FluidStep {
  step_order_t order;
  particle_feedback_t feedback;
};

// What the particle node gets for a step: the order and the fluid state it runs in (the step's
// own in the serial scheme, the step before's in the parallel one).
struct ParticleStep {
  step_order_t order;
  fluid_state_t fluid;
};

class NodePort {
 public:
  // Joins the bus listening to `kinds` (channel::heard_by_*), says hello.
  NodePort(const RunContext& ctx, std::string role, std::string program, int ranks,
           const std::vector<std::string>& kinds);
  ~NodePort();

  Bus& bus() { return *bus_; }
  std::int64_t step() const { return step_; }

  // How many MPI ranks the other node runs on (its hello says; waited for, asked again): whether
  // the exchange is partitioned (common/partition_exchange.h) depends on both nodes' counts.
  int peer_ranks();
  // A message of `kind` kept for good by the other node (PARTITION, DOMAIN), waited for.
  Received wait_for_kept(const std::string& kind, const char* what) { return wait_for(kind, 0, what); }
  // The same of a later step: the particle ranks' boxes after they moved (DOMAIN of the step from
  // which they hold, docs/notes/partitioned-exchange.md).
  Received wait_for_kept(const std::string& kind, std::int64_t step, const char* what) {
    return wait_for(kind, step, what);
  }
  // Handles what has reached the bus, without waiting: answers the requests to publish again
  // what this port kept (its feedback, say) and keeps what a later wait wants. For a node whose
  // ranks wait on channels of their own (the partitioned exchange) while the port's peers may
  // be waiting for a resend from it.
  void serve() {
    bus_->poll(0.0, [this](const Received& msg) { keep_pending(msg); });
  }

  // Reports the end of the run (finalize) or a failure of the current step (one line) to the
  // coordinator. Either one is the node's last word: its heartbeat stops, because the process
  // may exit (MPI_Abort, UPstream::exit, LIGGGHTS's exit) without unwinding, and a heartbeat
  // still signing while OpenSSL is torn down at exit crashes the process after a good run.
  void finalize();
  void fail(const std::string& error);
  // A wait for this step's input that happened after advance() returned (the partitioned
  // exchange's ranks take their parts themselves): counted as waiting, not computing.
  void count_as_waiting(double seconds) {
    times_.wait_s += seconds;
    step_started_ += seconds;
  }
  // The step's computing ends now, before the node's ranks publish their parts themselves (the
  // partitioned exchange): publishing counts as coupling, as advance()'s own publishing does.
  void end_computing() { computing_ended_at_ = now(); }

 protected:
  // Publishes `kind` for the current step (kept for resends) and STEP_DONE, in the order that
  // shortens the step: first what the run waits on (`report_first`: the report, when this
  // node's is the last the coordinator needs before it orders the next step, so the order
  // travels while the output does). Waits for the next order and for `input_kind` at step
  // `order.step + input_offset`.
  template <class Out>
  std::optional<std::pair<step_order_t, Received>> advance_with(const std::string& out_kind, Out& out,
                                                                const std::string& input_kind, int input_offset,
                                                                const Diagnostics& diag, bool report_first) {
    // Publishing counts as coupling, not computing.
    times_.compute_s = (computing_ended_at_ ? *computing_ended_at_ : now()) - step_started_;
    computing_ended_at_.reset();
    const Diagnostics reported = with_bus_traffic(diag);
    if (report_first) report_done(true, "", reported);
    // No `out_kind`: the node's ranks published their parts themselves (the partitioned exchange).
    if (!out_kind.empty()) bus_->publish(out_kind, out, step_, /*keep=*/true);
    if (!report_first) report_done(true, "", reported);
    bus_->forget_before(step_ - 1);
    const double wait_start = now();
    const auto order_msg = wait_for(channel::step, step_ + 1, "the coordinator's next step order");
    auto order = order_msg.as<step_order_t>();
    if (order.stop) return std::nullopt;
    // No `input_kind`: the node's ranks receive their parts themselves.
    Received input;
    if (!input_kind.empty()) input = wait_for(input_kind, step_ + 1 + input_offset, input_kind.c_str());
    step_ = order.envelope.step;
    times_.wait_s = now() - wait_start;
    step_started_ = now();
    return std::make_pair(order, std::move(input));
  }
  // Keeps a message a wait may want (an order, an input, the other node's hello...).
  void keep_pending(const Received& msg);
  // Waits for (kind, step), asking again every retry interval; throws when the coordinator is
  // silent for longer than it may be (liveness.h), naming why.
  Received wait_for(const std::string& kind, std::int64_t step, const char* what);
  // Why a silence of the coordinator this long ends the wait (nothing: wait on).
  std::optional<std::string> coordinator_silence(double silent) const;
  std::string coordinator_whereabouts() const;  // for the log: whether its process is seen, and how
  void report_done(bool ok, const std::string& error, const Diagnostics& diag);
  // `diag` and, per channel kind, the bytes this node's bus sent and received since the last
  // report (bus_sent_<kind>_B, bus_received_<kind>_B; kinds without any left out): one window a
  // step, from the publishing of one step's result to the next's.
  Diagnostics with_bus_traffic(const Diagnostics& diag);
  static double now();

  std::map<std::pair<std::string, std::int64_t>, Received> pending_;

  std::unique_ptr<Bus> bus_;
  std::unique_ptr<Heartbeat> heartbeat_;
  std::string role_;
  std::string run_dir_;         // where the coordinator says where it runs (liveness.h)
  double gave_up_after_s_ = 0;  // the coordinator's silence the node gave up after (0: it did not)
  std::int64_t step_ = 0;
  std::optional<int> peer_ranks_;  // the other node's hello's, once heard
  StepTimes times_;
  BusTraffic traffic_reported_;  // the bus's totals at the last report
  double step_started_ = 0;
  std::optional<double> computing_ended_at_;  // end_computing's, for the step's report
};

class FluidPort : public NodePort {
 public:
  FluidPort(const RunContext& ctx, std::string role, std::string program, int ranks = 1)
      : NodePort(ctx, std::move(role), std::move(program), ranks, channel::heard_by_fluid()) {}
  // Says hello and publishes the mesh (kept for anyone who asks again).
  void initialize(mesh_t& mesh);
  // Publishes the state of the current step; returns the next step's order and feedback,
  // or nothing when the coordinator says stop.
  std::optional<FluidStep> advance(fluid_state_t& state, const Diagnostics& diag = {});
  // The same when the fluid's ranks publish their partitions of the state and take their
  // readers' partial feedback themselves: only the order (`feedback` left empty).
  std::optional<FluidStep> advance_partitioned(const Diagnostics& diag = {});
};

class ParticlePort : public NodePort {
 public:
  // The coupling scheme (docs/design.md "Lockstep coupling") is decided here, by which fluid state
  // a step waits for. Serial (Gauss-Seidel): step k runs in the fluid state of step k, after the
  // fluid has computed it. Parallel (Jacobi, `lagged_fluid`): step k runs in the state of step
  // k - 1, so both nodes compute step k at once. The fluid node is the same for both: it always
  // uses the feedback of step k - 1.
  ParticlePort(const RunContext& ctx, std::string role, std::string program, int ranks = 1, bool lagged_fluid = false)
      : NodePort(ctx, std::move(role), std::move(program), ranks, channel::heard_by_particles()),
        fluid_lag_(lagged_fluid ? 1 : 0) {}
  // Says hello and waits for the fluid mesh.
  mesh_t initialize();
  // Publishes the feedback of the current step; returns the next order and the fluid state,
  // or nothing when the coordinator says stop.
  std::optional<ParticleStep> advance(particle_feedback_t& feedback, const Diagnostics& diag = {});
  // The same when the particle ranks publish their partial feedback and receive their
  // partitions of the fluid state themselves: only the report out and the order in (`fluid` left
  // empty).
  std::optional<ParticleStep> advance_partitioned(const Diagnostics& diag = {});
  // Steps between the fluid state used and the step computed (0 serial, 1 parallel scheme).
  int fluid_lag() const { return fluid_lag_; }

 private:
  int fluid_lag_ = 0;  // steps between the fluid state used and the step computed
};

}  // namespace hemo
