// The message bus a hemocosim process sees: LCM with the run's envelope, HMAC tags,
// replay and foreign-run rejection, and a cache of what it published so that a message
// lost by UDP can be published again on request (docs/design.md, "Lost messages" and "Security").
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <hemo/envelope_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace CLI { class App; }

namespace hemo {

// Everything a process needs to join a run's bus. The coordinator creates it and hands it to
// nodes on their command line; the secret travels as a file readable only by the user.
struct RunContext {
  std::string run_id;
  std::string lcm_url;
  std::string secret_file;
  std::vector<std::uint8_t> secret;   // loaded from secret_file
  double timeout_s = 30;              // give up waiting for peers after this long
  double retry_s = 0.5;               // ask again for a missing message after this long
  int drop_every = 0;                 // fault injection: drop every n-th received message (0: none)
  int ranks = 1;                      // MPI ranks the node should run on (it launches them itself)
  long resume_step = 0;               // > 0: start from the run's checkpoint of this step

  void add_options(CLI::App& app);    // --run-id --lcm-url --secret-file --timeout --ranks --drop-every --resume-step
  void load_secret();                 // reads secret_file; throws with a one-line reason
};

// Channel names: "<run-id>/<KIND>".
namespace channel {
inline constexpr const char* hello = "HELLO";
inline constexpr const char* heartbeat = "HEARTBEAT";
inline constexpr const char* step = "STEP";
inline constexpr const char* mesh = "MESH";
inline constexpr const char* fluid_state = "FLUID_STATE";
inline constexpr const char* particle_feedback = "PARTICLE_FEEDBACK";
inline constexpr const char* step_done = "STEP_DONE";
inline constexpr const char* resend = "RESEND";
inline constexpr const char* control = "CONTROL";  // restart / swap requests and answers

// Every kind: what the monitor and the tests listen to.
std::vector<std::string> all();
// What each process listens to. LCM drops a datagram of a channel nobody listens to in its
// receive thread, so a process is neither woken nor made to check a tag for the large
// messages meant for another; at the calibration size those wake-ups, at the moment the
// receiving node should start, were most of the coupling overhead (docs/notes/performance-log.md).
std::vector<std::string> heard_by_coordinator();  // hello, heartbeat, step done, resend (control: its own bus)
std::vector<std::string> heard_by_fluid();        // step, feedback, heartbeat, resend
std::vector<std::string> heard_by_particles();    // step, mesh, fluid state, heartbeat, resend
}  // namespace channel

// Counters a process keeps about what it received; the monitor shows them.
struct BusCounters {
  std::uint64_t accepted = 0;
  std::uint64_t rejected_auth = 0;     // HMAC did not verify
  std::uint64_t rejected_replay = 0;   // sequence number already seen
  std::uint64_t rejected_foreign = 0;  // another run's id
  std::uint64_t rejected_corrupt = 0;  // did not decode
  std::uint64_t resent = 0;            // messages we published again on request
  std::uint64_t resend_requests = 0;   // times we asked a peer again
};

// A received message before typing: channel kind, envelope and raw bytes (tag verified).
struct Received {
  std::string kind;
  envelope_t envelope;
  std::vector<std::uint8_t> bytes;

  template <class Msg>
  Msg as() const {
    Msg m;
    if (m.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0)
      throw std::runtime_error("message on " + kind + " does not decode as its type");
    return m;
  }
};

class Bus {
 public:
  // Listens to the run's channels of the given kinds.
  Bus(const RunContext& ctx, std::string sender, const std::vector<std::string>& kinds = channel::all());
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  const std::string& sender() const { return sender_; }
  const RunContext& context() const { return ctx_; }
  std::string topic(const std::string& kind) const { return ctx_.run_id + "/" + kind; }

  // Stamps the envelope (run id, sender, step, fresh seq, tag) and publishes on <run>/<kind>.
  // With `keep`, the encoded message is cached so a RESEND for (kind, step) publishes it again.
  template <class Msg>
  void publish(const std::string& kind, Msg& msg, std::int64_t step, bool keep = false) {
    msg.envelope.run_id = ctx_.run_id;
    msg.envelope.sender = sender_;
    msg.envelope.step = step;
    std::vector<std::uint8_t> buf;
    msg.envelope.seq = next_seq();
    std::fill(std::begin(msg.envelope.tag), std::end(msg.envelope.tag), 0);
    buf.resize(static_cast<std::size_t>(msg.getEncodedSize()));
    msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    publish_encoded(kind, step, std::move(buf), keep);
  }

  // Asks the publisher of (kind, step) to publish it again.
  void request_resend(const std::string& kind, std::int64_t step);

  // Drops kept messages of steps before `step` (the mesh and hello are kept for good).
  void forget_before(std::int64_t step);

  // Process-wide sequence numbers, also used by the heartbeat thread.
  static std::int64_t next_seq();

  // Waits up to `timeout_s` for messages and hands each verified one to `on_message`.
  // RESEND requests for messages this bus kept are answered here, not passed on.
  // Returns the number of messages handled.
  int poll(double timeout_s, const std::function<void(const Received&)>& on_message);

  const BusCounters& counters() const { return counters_; }

 private:
  void publish_encoded(const std::string& kind, std::int64_t step, std::vector<std::uint8_t> buf,
                       bool keep);
  void on_raw(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  bool accept_seq(const std::string& sender, std::int64_t seq);

  RunContext ctx_;
  std::string sender_;
  lcm::LCM lcm_;
  std::mutex publish_mutex_;
  BusCounters counters_;
  std::map<std::string, std::map<std::int64_t, std::vector<std::uint8_t>>> kept_;  // kind -> step -> bytes
  std::map<std::string, std::pair<std::int64_t, std::set<std::int64_t>>> seen_;    // sender -> (max, recent)
  std::vector<Received> inbox_;
  std::uint64_t received_for_drop_ = 0;
};

// HMAC-SHA256 tag handling on an encoded message (exposed for tests and the monitor).
// The tag sits at a fixed place after the envelope's variable-length strings.
std::size_t tag_offset(const std::uint8_t* buf, std::size_t len);  // throws if malformed
void sign(std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret);
bool verify(const std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret);
std::optional<envelope_t> peek_envelope(const std::uint8_t* buf, std::size_t len);

// Publishes a heartbeat on its own LCM instance from a background thread while alive.
class Heartbeat {
 public:
  Heartbeat(const RunContext& ctx, std::string sender, double period_s = 0.5);
  ~Heartbeat();
  Heartbeat(const Heartbeat&) = delete;
  Heartbeat& operator=(const Heartbeat&) = delete;

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace hemo
