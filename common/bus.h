// The message bus a hemocosim process sees: LCM with the run's envelope, HMAC tags,
// replay and foreign-run rejection, and a cache of what it published so that a message
// lost by UDP can be published again on request (docs/design.md, "Lost messages" and "Security").
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "traffic.h"
#include "wire.h"

#include <hemo/envelope_t.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <typeindex>
#include <typeinfo>
#include <utility>
#include <vector>

namespace CLI {
class App;
}

namespace hemo {

// Everything a process needs to join a run's bus. The coordinator creates it and hands it to
// nodes on their command line; the secret travels as a file readable only by the user.
struct RunContext {
  std::string run_id;
  std::string lcm_url;
  std::string secret_file;
  std::vector<std::uint8_t> secret;    // loaded from secret_file
  double timeout_s = 30;               // give up waiting for peers after this long
  double retry_s = 0.5;                // ask again for a missing message after this long
  int drop_every = 0;                  // fault injection: drop every n-th received message (0: none)
  int ranks = 1;                       // MPI ranks the node should run on (it launches them itself)
  std::string mpi_hosts;               // where Open MPI places them ("b:2,c:2"; empty: here)
  std::string mpi_starter = "mpirun";  // or "srun": the ranks as a Slurm job step (common/mpi_job.h)
  long resume_step = 0;                // > 0: start from the run's checkpoint of this step
  bool encrypt = false;                // seal what this process publishes (bus.encrypt; bus_crypto.h)

  void add_options(CLI::App& app);  // --run-id --lcm-url --secret-file --timeout --ranks --mpi-hosts --mpi-starter
                                    // --drop-every --resume-step --encrypt-bus
  void load_secret();               // reads secret_file; throws with a one-line reason
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
// The partitioned exchange's start-up (docs/notes/partitioned-exchange.md): the fluid's cell
// owners and the particle ranks' boxes, once each, kept for good like the mesh.
inline constexpr const char* partition = "PARTITION";
inline constexpr const char* domain = "DOMAIN";

// A kind's channel for one of `ranks` ranks of a node (the partitioned exchange, issue #36;
// docs/notes/partitioned-exchange.md): "<KIND>.<rank>", e.g. FLUID_STATE.3, its own publisher's;
// with one rank the kind itself, so that one rank each is today's exchange byte for byte.
// Indices for pairs: of_rank(of_rank(kind, f, nf), p, np) = PARTICLE_FEEDBACK.<f>.<p>.
std::string of_rank(const std::string& kind, int rank, int ranks);
// The kind a channel's messages are of: "FLUID_STATE" for FLUID_STATE and FLUID_STATE.3.
std::string base_kind(const std::string& kind);
// A kind's channel between fluid rank f of nf and particle rank p of np: "<KIND>.<f>.<p>" (its
// publisher's alone), or the kind itself with one rank each. A FLUID_STATE channel of a pair
// carries fluid_partition_t, the state of the cells p takes from f; FLUID_STATE itself, the
// whole mesh's fluid_state_t. A PARTICLE_FEEDBACK channel of a pair carries feedback_partition_t,
// p's partial feedback for those cells; PARTICLE_FEEDBACK itself, the whole mesh's.
std::string of_pair(const std::string& kind, int fluid_rank, int fluid_ranks, int particle_rank, int particle_ranks);

// What rank `rank` (>= 1) of a node on several ranks (`role`: "fluid", "particles") tells the
// coordinator alone, its step reports (STEP_DONE) and heartbeats (HEARTBEAT): on
// "<KIND>.<role>.<rank>", that rank's own channels (common/rank_report.h). Rank 0's are the
// node's, on STEP_DONE and HEARTBEAT.
std::string of_node_rank(const std::string& kind, const std::string& role, int rank);

// Every kind: what the monitor and the tests listen to.
std::vector<std::string> all();
// What each process listens to. LCM drops a datagram of a channel nobody listens to in its
// receive thread, so a process is neither woken nor made to check a tag for the large
// messages meant for another, at the moment the receiving node should start (docs/design.md,
// Messages; today's coupling overhead: docs/performance.md §1).
std::vector<std::string> heard_by_coordinator();  // hello, heartbeat, step done, resend (control: its own bus)
std::vector<std::string> heard_by_fluid();        // step, feedback, heartbeat, resend, hello, domain
std::vector<std::string> heard_by_particles();    // step, mesh, fluid state, heartbeat, resend, hello, partition
}  // namespace channel

// Counters a process keeps about what it received; written to its log at the end, published
// with its heartbeat, shown by `hemocosim monitor`. Every datagram that reaches the bus is
// counted exactly once: accepted, own, injected_drops, or one of the rejected_* causes.
// The checks run in this order, on the raw bytes, before any LCM decoding:
//   short        no well-formed envelope: too short for it, or a string length zero, negative
//                or past the end, or not NUL-terminated
//   foreign      another run's id
//   auth         the HMAC tag does not verify (whatever sender the envelope names)
//   (own)        our own message looped back by multicast (not a rejection)
//   prestart     sequence number (the sender's wall clock in microseconds) from before this
//                bus was opened, less a clock-skew allowance: a recording played back
//   replay       sequence number already seen from that sender
//   (injected)   dropped on purpose by run.drop_every (fault injection, not a rejection): every
//                n-th of the others' authentic, fresh messages but heartbeats
//   undecodable  authentic, but does not decode as its channel's type (or, sealed, does not open)
struct BusCounters {
  std::uint64_t received = 0;  // datagrams handed to the bus by LCM
  std::uint64_t accepted = 0;
  std::uint64_t own = 0;                // our own messages, looped back
  std::uint64_t injected_drops = 0;     // run.drop_every
  std::uint64_t rejected_short = 0;     // no well-formed envelope
  std::uint64_t rejected_foreign = 0;   // another run's id
  std::uint64_t rejected_auth = 0;      // HMAC did not verify
  std::uint64_t rejected_prestart = 0;  // sent before this bus was opened (a replayed recording)
  std::uint64_t rejected_replay = 0;    // sequence number already seen
  std::uint64_t rejected_corrupt = 0;   // authentic but undecodable as its channel's type
  std::uint64_t resent = 0;             // messages we published again on request
  std::uint64_t resend_requests = 0;    // times we asked a peer again
  std::uint64_t rejected() const {
    return rejected_short + rejected_foreign + rejected_auth + rejected_prestart + rejected_replay + rejected_corrupt;
  }
  std::string str() const;  // one line for a log
};

class heartbeat_t;
// The counters a heartbeat carries, from a bus's.
void put_counters(const BusCounters& k, heartbeat_t& hb);

// Bytes of the datagrams a bus published (resends included) and was handed by LCM (every one of
// a channel it listens to, whatever the checks then made of it), by channel kind, since it opened.
// They are also added to the process's RankTraffic (traffic.h).
struct BusTraffic {
  std::map<std::string, std::uint64_t> sent, received;
};

// A received message: channel kind, envelope and raw bytes (tag verified) and, set by the bus,
// the message decoded as its channel's type (so `as` of that type copies instead of decoding).
struct Received {
  std::string kind;
  envelope_t envelope;
  std::vector<std::uint8_t> bytes;
  // Empty until the bus has decoded the bytes; an initializer so that {kind, envelope, bytes}
  // is a complete Received (-Wmissing-field-initializers).
  std::shared_ptr<const void> decoded = nullptr;
  std::type_index decoded_type = typeid(void);
  // When this host received it (LCM's receive time: the kernel's timestamp of the datagram, the
  // last one of a fragmented message; wall clock, µs). With envelope.sent_unix_ns it gives the
  // exchange's latency, meaningful across hosts only as far as their clocks agree.
  std::int64_t received_unix_us = 0;

  template <class Msg>
  Msg as() const {
    if (decoded && decoded_type == std::type_index(typeid(Msg))) return *static_cast<const Msg*>(decoded.get());
    Msg m;
    int n = -1;
    try {
      n = m.decode(bytes.data(), 0, static_cast<int>(bytes.size()));
    } catch (const std::exception&) {
      n = -1;  // LCM's decoder throws on a zero or negative string length
    }
    if (n < 0) throw std::runtime_error("message on " + kind + " does not decode as its type");
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
  // Returns the bytes published.
  template <class Msg>
  std::size_t publish(const std::string& kind, Msg& msg, std::int64_t step, bool keep = false) {
    msg.envelope.run_id = ctx_.run_id;
    msg.envelope.sender = sender_;
    msg.envelope.step = step;
    std::vector<std::uint8_t> buf;
    msg.envelope.seq = next_seq();
    msg.envelope.sent_unix_ns = 0;  // stamped in the encoded bytes at the last moment
    std::fill(std::begin(msg.envelope.tag), std::end(msg.envelope.tag), 0);
    buf.resize(static_cast<std::size_t>(msg.getEncodedSize()));
    msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    return publish_encoded(kind, step, std::move(buf), keep);
  }

  // Listens to the run's channel of `kind` from now on as well (nothing if it already does). Not
  // from inside LCM's dispatch: from the polling thread, between polls or in poll's handler.
  void listen(const std::string& kind);

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

  // A snapshot (the heartbeat thread reads them while the owner polls).
  BusCounters counters() const;
  BusTraffic traffic() const;
  // Writes the counters to the log, once. A bus destroyed without it logs them only when it
  // dropped something (a command-line tool's answer stays one line).
  void log_counters(bool even_if_clean = true);
  // How far `sender`'s clock was behind this host's in its last message refused as pre-start
  // (receipt minus its send time, s; nothing: none refused): what names a clock skew in errors.
  std::optional<double> prestart_lag_s(const std::string& sender) const;
  ~Bus();

 private:
  void count(std::uint64_t BusCounters::*field);
  std::size_t publish_encoded(const std::string& kind, std::int64_t step, std::vector<std::uint8_t> buf, bool keep);
  // A copy of a message this bus was handed already (its channel, sender and step), or a resend
  // request: what loss cost it (RankTraffic::received_again).
  bool received_again(const std::string& channel, const envelope_t& envelope);
  void on_raw(const std::uint8_t* data, std::size_t len, const std::string& channel,
              std::int64_t recv_utime);  // never throws
  void handle_raw(const std::uint8_t* data, std::size_t len, const std::string& channel, std::int64_t recv_utime);
  bool accept_seq(const std::string& sender, std::int64_t seq);

  RunContext ctx_;
  std::string sender_;
  std::unique_ptr<Wire> wire_;
  std::set<std::string> listening_;  // the kinds subscribed to
  std::vector<std::uint8_t> seal_key_;  // opens sealed messages, whether this process seals or not
  std::mutex publish_mutex_;
  mutable std::mutex counters_mutex_;
  BusCounters counters_;
  BusTraffic traffic_;  // counters_mutex_
  bool counters_logged_ = false;
  std::int64_t opened_us_ = 0;  // wall clock when the bus subscribed; older sequence numbers are pre-start
  std::map<std::string, double> prestart_lag_s_;  // sender -> its last pre-start message's lag (counters_mutex_)
  // A rank's own bus may answer resends from a thread while its owner publishes (fluid ranks of a
  // partitioned exchange: fluidLink.H): what it keeps is under its own lock.
  mutable std::mutex kept_mutex_;
  struct Kept {
    std::vector<std::uint8_t> bytes;
    std::int64_t published_us = 0;  // this host's wall clock at its last publish (resends too)
  };
  std::map<std::string, std::map<std::int64_t, Kept>> kept_;  // kind -> step -> message
  std::map<std::string, std::pair<std::int64_t, std::set<std::int64_t>>> seen_;    // sender -> (max, recent)
  // "<channel> <sender>" -> (the latest step, the recent steps) of the messages handed to it
  std::map<std::string, std::pair<std::int64_t, std::set<std::int64_t>>> had_;
  std::vector<Received> inbox_;
  std::uint64_t received_for_drop_ = 0;
};

// Sequence numbers are the sender's wall clock in microseconds (strictly increasing per
// process), so a receiver tells a recording played back from live traffic: a message whose
// sequence number is older than the receiver's bus, by more than this allowance for clock skew
// between hosts, is refused as pre-start.
inline constexpr std::int64_t kClockSkewAllowanceUs = 1'000'000;

// The envelope read from the raw bytes of an encoded message, by its fixed layout alone (LCM:
// 8-byte fingerprint, run_id and sender as int32 length with the NUL + bytes + NUL, step, seq
// and sent_unix_ns as int64, the 32-byte tag), every length checked against the bytes: no LCM decoding.
struct RawEnvelope {
  envelope_t envelope;
  std::size_t tag_offset = 0;
};
inline constexpr std::size_t kMaxEnvelopeString = 256;  // run ids and sender names are short
std::optional<RawEnvelope> parse_envelope(const std::uint8_t* buf, std::size_t len) noexcept;

// HMAC-SHA256 tag handling on an encoded message (exposed for tests and the monitor).
// The tag sits at a fixed place after the envelope's variable-length strings.
std::size_t tag_offset(const std::uint8_t* buf, std::size_t len);  // throws if malformed
void sign(std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret);
// Writes the wall clock into the envelope's sent_unix_ns, then signs: what a publish does.
void stamp_and_sign(std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret);
bool verify(const std::uint8_t* buf, std::size_t len, const std::vector<std::uint8_t>& secret) noexcept;
bool verify(const std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret);
std::optional<envelope_t> peek_envelope(const std::uint8_t* buf, std::size_t len);

// Which processes' heartbeats a process hears: the bus check at start-up (docs/hosts.md). The
// heartbeat thread listens itself, so the report does not wait for the process to poll its bus
// (a node may be setting up its engine), and the report travels as a file in the run directory,
// which every host shares, so that it reaches the coordinator when the bus does not.
struct HeardReport {
  bool listen = false;
  std::string file;  // rewritten whenever the set grows: "host=H heard=a,b" (empty: no file)
};
// The file in which `sender` reports what it hears: RUN_DIR/bus-check/<sender> (the run
// directory is where the secret file is).
std::string heard_report_file(const RunContext& ctx, const std::string& sender);
struct HeardReportLine {
  std::string host;
  std::set<std::string> heard;
};
std::optional<HeardReportLine> read_heard_report(const std::string& file);

// Publishes a heartbeat on its own LCM instance from a background thread while alive.
class Heartbeat {
 public:
  // With `counters`, each heartbeat carries what they return (the process's bus counters).
  Heartbeat(const RunContext& ctx, std::string sender, double period_s = 0.5,
            std::function<BusCounters()> counters = {}, HeardReport report = {});
  ~Heartbeat();
  Heartbeat(const Heartbeat&) = delete;
  Heartbeat& operator=(const Heartbeat&) = delete;
  // The senders whose authentic heartbeats of this run it heard (with report.listen).
  std::set<std::string> heard() const;

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace hemo
