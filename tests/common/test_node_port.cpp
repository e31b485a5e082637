// The node-port protocol over real LCM: lockstep order of data, and recovery from lost datagrams.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_fields.h"
#include "node_port.h"
#include "test_helpers.h"

#include <hemo/heartbeat_t.hpp>
#include <hemo/step_done_t.hpp>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <lcm/lcm-cpp.hpp>

#include <csignal>
#include <fstream>

#include <atomic>
#include <condition_variable>
#include <future>
#include <limits>
#include <mutex>
#include <thread>

using namespace hemo;

namespace {

// Stand-ins for the engines: the fluid's velocity is 10 x (feedback it saw) + 1; the particles'
// feedback is what they saw. Any break of the Gauss-Seidel order changes the recorded numbers.
// Both node threads open their ports (and so listen) before either speaks: without it the
// fluid's mesh could go out before the particle port had subscribed, and the particle port would
// ask for it again after retry_s (1 run in 8 on an idle machine) -- a start-up race, not a loss
// (LostDatagramsDoNotChangeTheResult covers recovering what was missed).
class StartLine {
 public:
  explicit StartLine(int parties) : waiting_(parties) {}
  void arrive_and_wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    if (--waiting_ == 0) all_here_.notify_all();
    all_here_.wait(lock, [&] { return waiting_ == 0; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable all_here_;
  int waiting_;
};

struct Trace {
  std::vector<double> fluid_saw, particles_saw;
  std::uint64_t resend_requests = 0;  // by both nodes
};

void run_fluid(const RunContext& ctx, Trace& trace, StartLine& start) {
  FluidPort port(ctx, "fluid", "test fluid");
  start.arrive_and_wait();
  mesh_t mesh{};
  mesh.mesh_hash = "m1";
  port.initialize(mesh);
  fluid_state_t state{};
  state.mesh_hash = "m1";
  resize_cells(state, 1);
  velocity_of(state, 0)[0] = 1.0;
  while (auto step = port.advance(state, {{"courant_max", 0.1}})) {
    const double seen = step->feedback.solid_fraction.at(0);
    trace.fluid_saw.push_back(seen);
    velocity_of(state, 0)[0] = 10 * seen + 1;
  }
  trace.resend_requests += port.bus().counters().resend_requests;
  port.finalize();
}

void run_particles(const RunContext& ctx, Trace& trace, bool parallel, StartLine& start) {
  ParticlePort port(ctx, "particles", "test particles", 1, parallel);
  start.arrive_and_wait();
  const mesh_t mesh = port.initialize();
  ASSERT_EQ(mesh.mesh_hash, "m1");
  particle_feedback_t fb{};
  fb.mesh_hash = "m1";
  resize_cells(fb, 1);
  while (auto step = port.advance(fb)) {
    const double seen = velocity_of(step->fluid, 0)[0];
    trace.particles_saw.push_back(seen);
    fb.solid_fraction[0] = seen;
  }
  trace.resend_requests += port.bus().counters().resend_requests;
  port.finalize();
}

// Drives `steps` coupling steps the way the coordinator does.
void coordinate(Bus& bus, const RunContext& ctx, int steps) {
  std::map<std::string, long> done;
  auto await = [&](long k) {
    double asked = 0;
    for (int i = 0; i < 400 && !(done["fluid"] >= k && done["particles"] >= k); ++i) {
      bus.poll(0.05, [&](const Received& m) {
        if (m.kind == channel::step_done)
          done[m.as<step_done_t>().node] = std::max(done[m.as<step_done_t>().node], long(m.envelope.step));
      });
      if ((asked += 0.05) > ctx.retry_s) {
        bus.request_resend(channel::step_done, k);
        asked = 0;
      }
    }
    ASSERT_TRUE(done["fluid"] >= k && done["particles"] >= k) << "step " << k << " never finished";
  };
  done["fluid"] = done["particles"] = -1;
  await(0);
  for (long k = 1; k <= steps + 1; ++k) {
    step_order_t o{};
    o.dt_s = 1e-5;
    o.stop = k > steps;
    bus.publish(channel::step, o, k, /*keep=*/true);
    if (o.stop) {
      for (int i = 0; i < 40; ++i) bus.poll(0.05, [](const Received&) {});  // answer late resend requests
      break;
    }
    await(k);
  }
}

Trace run_protocol(RunContext ctx, int steps, bool parallel = false) {
  Trace trace;
  // The coordinator listens before the nodes start (as hemocosim does): their first step-done
  // reports must not go out before anyone hears them.
  Bus bus(ctx, "coordinator");
  StartLine start(2);
  std::thread fluid([&] { run_fluid(ctx, trace, start); });
  std::thread particles([&] { run_particles(ctx, trace, parallel, start); });
  coordinate(bus, ctx, steps);
  fluid.join();
  particles.join();
  return trace;
}

}  // namespace

TEST(NodePort, SerialLockstepOrdersTheData) {
  auto ctx = test::make_context("ls");
  // A resend is asked for after retry_s without the message: 0.2 s (the helpers' value) is
  // shorter than a busy CI machine can stall a thread, which made a slow message look lost. With
  // 5 s only a message that never came (or was dropped instead of kept) is asked for again.
  ctx.retry_s = 5;
  const Trace t = run_protocol(ctx, 4);
  // particles at step k see the fluid of step k; the fluid at step k sees the feedback of k-1.
  EXPECT_EQ(t.fluid_saw, (std::vector<double>{0, 1, 11, 111}));
  EXPECT_EQ(t.particles_saw, (std::vector<double>{1, 11, 111, 1111}));
  // Without loss nobody has to ask twice: a message that arrives early is kept until needed.
  EXPECT_EQ(t.resend_requests, 0u);
}

// The parallel (Jacobi) scheme: the particles at step k see the fluid of step k - 1, the fluid
// at step k the feedback of k - 1, so neither waits for the other within a step.
TEST(NodePort, ParallelLockstepLagsTheFluidByOneStep) {
  auto ctx = test::make_context("jacobi");
  ctx.retry_s = 5;
  const Trace t = run_protocol(ctx, 4, /*parallel=*/true);
  EXPECT_EQ(t.fluid_saw, (std::vector<double>{0, 1, 1, 11}));
  EXPECT_EQ(t.particles_saw, (std::vector<double>{1, 1, 11, 11}));
  EXPECT_EQ(t.resend_requests, 0u);
}

TEST(NodePort, LostDatagramsDoNotChangeTheResult) {
  auto ctx = test::make_context("lossy");
  ctx.drop_every = 3;  // every process loses every third message it receives
  const Trace t = run_protocol(ctx, 4);
  EXPECT_EQ(t.fluid_saw, (std::vector<double>{0, 1, 11, 111}));
  EXPECT_EQ(t.particles_saw, (std::vector<double>{1, 11, 111, 1111}));
  const Trace p = run_protocol(ctx, 4, /*parallel=*/true);
  EXPECT_EQ(p.fluid_saw, (std::vector<double>{0, 1, 1, 11}));
  EXPECT_EQ(p.particles_saw, (std::vector<double>{1, 1, 11, 11}));
}

// finalize and fail are a node's last word: its heartbeat stops with them. A heartbeat that kept
// signing while the process exits without unwinding (UPstream::exit, MPI_Abort) crashed a
// decomposed fluid node in OpenSSL's torn-down locks after a good run (exit 139 in CI).
TEST(NodePort, HeartbeatStopsWithTheLastWord) {
  const auto ctx = test::make_context("last-word");
  Bus coordinator(ctx, "coordinator");
  // Heartbeats seen within `seconds`, or as soon as `enough` were.
  auto heartbeats_within = [&](double seconds, int enough = std::numeric_limits<int>::max()) {
    int n = 0;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end && n < enough)
      coordinator.poll(0.05, [&](const Received& m) { n += m.kind == channel::heartbeat; });
    return n;
  };
  for (const bool ok : {true, false}) {
    FluidPort port(ctx, "fluid", "test fluid");
    // Its first beat may wait for the node's bus to open, which on a loaded machine took over a
    // second once (CI with two builds and a study beside it).
    EXPECT_GE(heartbeats_within(10.0, 2), 2) << "a live node beats (period 0.5 s)";
    if (ok)
      port.finalize();
    else
      port.fail("a reason");
    heartbeats_within(0.1);  // what was already on its way
    EXPECT_EQ(heartbeats_within(1.2), 0) << (ok ? "after finalize" : "after fail");
  }
}

// A node whose coordinator is gone gives up after its timeout, although its peer still sends
// heartbeats (two orphaned nodes kept each other waiting for ever).
TEST(NodePort, APeersHeartbeatDoesNotKeepANodeWaitingWithoutItsCoordinator) {
  auto ctx = test::make_context("orphan");
  ctx.timeout_s = 1;
  auto peer = std::make_unique<Heartbeat>(ctx, "fluid", 0.1);
  auto waiting = std::async(std::launch::async, [&] {
    ParticlePort port(ctx, "particles", "test particles");
    try {
      port.initialize();  // waits for the fluid's mesh, which never comes
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("initialized");
  });
  const bool gave_up = waiting.wait_for(std::chrono::seconds(5)) == std::future_status::ready;
  peer.reset();  // (so that a node that ignored its timeout ends now)
  EXPECT_TRUE(gave_up) << "still waiting 5 s after a timeout of 1 s";
  EXPECT_NE(waiting.get().find("nothing heard from the coordinator"), std::string::npos);
}

namespace {
// A run directory with the secret file in it, as the coordinator makes one; `coordinator_pid`
// written as the coordinator's process on this host (docs/architecture.md "Liveness").
std::string run_dir_with_coordinator(RunContext& ctx, pid_t coordinator_pid) {
  char name[] = "/tmp/hemo_liveness_XXXXXX";
  const std::string dir = mkdtemp(name);
  ctx.secret_file = dir + "/secret";
  char host[256] = {0};
  gethostname(host, sizeof host - 1);
  std::ofstream(coordinator_process_file(dir)) << "host=" << host << " pid=" << coordinator_pid << "\n";
  return dir;
}

// What ParticlePort::initialize ended with (it waits for a mesh that never comes), and when.
struct Outcome {
  std::string what;
  double after_s = 0;
};
std::future<Outcome> wait_for_a_mesh(const RunContext& ctx) {
  return std::async(std::launch::async, [ctx] {
    const auto start = std::chrono::steady_clock::now();
    ParticlePort port(ctx, "particles", "test particles");
    Outcome o{"initialized"};
    try {
      port.initialize();
    } catch (const std::exception& e) {
      o.what = e.what();
    }
    o.after_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return o;
  });
}
}  // namespace

// A node keeps waiting for a coordinator whose process is stopped (SIGSTOP, a suspended shell),
// however long past its timeout: the coordinator decides once it runs again. A coordinator whose
// process is gone is not waited for beyond the timeout.
TEST(NodePort, ANodeWaitsForAStoppedCoordinatorAndGivesUpOnAGoneOne) {
  auto ctx = test::make_context("stopped-coordinator");
  ctx.timeout_s = 0.5;
  const pid_t coordinator = fork();
  ASSERT_GE(coordinator, 0);
  if (coordinator == 0) {
    pause();
    _exit(0);
  }
  ASSERT_EQ(kill(coordinator, SIGSTOP), 0);
  run_dir_with_coordinator(ctx, coordinator);
  auto waiting = wait_for_a_mesh(ctx);
  // 3 s: six timeouts, fewer than the patience for a running coordinator (10 timeouts).
  EXPECT_EQ(waiting.wait_for(std::chrono::seconds(3)), std::future_status::timeout)
      << "gave up on a stopped coordinator: " << waiting.get().what;
  kill(coordinator, SIGKILL);
  waitpid(coordinator, nullptr, 0);
  ASSERT_EQ(waiting.wait_for(std::chrono::seconds(3)), std::future_status::ready)
      << "still waiting for a coordinator that is gone";
  const Outcome o = waiting.get();
  EXPECT_NE(o.what.find("nothing heard from the coordinator"), std::string::npos) << o.what;
  EXPECT_NE(o.what.find("its process is gone"), std::string::npos) << o.what;
  EXPECT_GE(o.after_s, 3.0) << o.what;
}

// A coordinator whose clock is behind the node's by more than the bus allows: its messages are
// refused as from before the node started, and the node's error names the clock skew and by how much.
TEST(NodePort, AClockSkewThatRefusesTheCoordinatorsMessagesIsNamed) {
  auto ctx = test::make_context("skew");
  ctx.timeout_s = 1;
  run_dir_with_coordinator(ctx, getpid());  // it runs: the node would wait on, but for the skew
  auto waiting = wait_for_a_mesh(ctx);
  lcm::LCM lcm(ctx.lcm_url);
  ASSERT_TRUE(lcm.good());
  const auto behind_us = std::int64_t{5'000'000};
  for (int i = 0; i < 40 && waiting.wait_for(std::chrono::milliseconds(100)) == std::future_status::timeout; ++i) {
    // A heartbeat of the coordinator stamped by a clock 5 s behind: sequence number and send time.
    heartbeat_t h{};
    h.envelope.run_id = ctx.run_id;
    h.envelope.sender = "coordinator";
    const std::int64_t its_clock_us =
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
            .count() -
        behind_us;
    h.envelope.seq = its_clock_us;
    h.envelope.sent_unix_ns = its_clock_us * 1000;
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(h.getEncodedSize()));
    h.encode(buf.data(), 0, static_cast<int>(buf.size()));
    sign(buf, ctx.secret);
    lcm.publish(ctx.run_id + "/" + channel::heartbeat, buf.data(), static_cast<unsigned>(buf.size()));
  }
  ASSERT_EQ(waiting.wait_for(std::chrono::seconds(5)), std::future_status::ready);
  const Outcome o = waiting.get();
  EXPECT_NE(o.what.find("clock skew"), std::string::npos) << o.what;
  const auto at = o.what.find("its clock is ");
  ASSERT_NE(at, std::string::npos) << o.what;
  EXPECT_NEAR(std::stod(o.what.substr(at + 13)), 5.0, 0.5) << o.what;
}
