// SPDX-License-Identifier: GPL-3.0-or-later
#include "bus.h"

#include "bus_crypto.h"
#include "run_files.h"

#include <hemo/control_t.hpp>
#include <hemo/feedback_partition_t.hpp>
#include <hemo/fluid_decomposition_t.hpp>
#include <hemo/fluid_partition_t.hpp>
#include <hemo/fluid_state_t.hpp>
#include <hemo/heartbeat_t.hpp>
#include <hemo/hello_t.hpp>
#include <hemo/mesh_t.hpp>
#include <hemo/particle_domain_t.hpp>
#include <hemo/particle_feedback_t.hpp>
#include <hemo/resend_request_t.hpp>
#include <hemo/step_done_t.hpp>
#include <hemo/step_order_t.hpp>

#include <fmt/format.h>
#include <openssl/core_names.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/params.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <thread>

namespace hemo {

namespace {

using Clock = std::chrono::steady_clock;

std::int64_t wall_clock_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::int64_t wall_clock_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Sequence numbers are the wall clock in microseconds, and strictly increasing: a restarted
// process never reuses a number its predecessor sent (receivers would take it for a replay),
// and a receiver refuses what was sent before it listened (bus.h, kClockSkewAllowanceUs).
std::atomic<std::int64_t>& process_seq() {
  static std::atomic<std::int64_t> seq{0};
  return seq;
}

std::uint32_t read_be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}

std::int64_t read_be64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return static_cast<std::int64_t>(v);
}

void write_be64(std::uint8_t* p, std::int64_t v) {
  for (int i = 7; i >= 0; --i) {
    p[i] = static_cast<std::uint8_t>(v & 0xff);
    v >>= 8;
  }
}

constexpr std::size_t kHashBytes = 8;  // LCM type fingerprint before the fields
constexpr std::size_t kTagBytes = 32;  // HMAC-SHA256
// Sequence numbers are microseconds: remember a sender's for 10 s behind its newest.
constexpr std::int64_t kReplayWindow = 10'000'000;

}  // namespace

void RunContext::add_options(CLI::App& app) {
  app.add_option("--run-id", run_id, "Run id (from the coordinator)")->required();
  app.add_option("--lcm-url", lcm_url, "LCM URL of the run's bus")->required();
  app.add_option("--secret-file", secret_file, "File holding the run's HMAC secret")->required();
  app.add_option("--timeout", timeout_s, "Seconds without any message from the run before giving up")
      ->capture_default_str();
  app.add_option("--ranks", ranks, "MPI ranks to run this node on")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option(
      "--mpi-hosts", mpi_hosts,
      "Hosts and ranks on each for the node's MPI job, as mpirun --host takes them (b:2,c:2; docs/hosts.md)");
  app.add_option("--mpi-starter", mpi_starter,
                 "How the node's ranks start: mpirun, or srun as a step of the Slurm allocation (docs/slurm.md)")
      ->capture_default_str()
      ->check(CLI::IsMember({"mpirun", "srun"}));
  app.add_option("--drop-every", drop_every, "Fault injection: drop every n-th received message")
      ->capture_default_str();
  app.add_flag("--encrypt-bus", encrypt,
               "Encrypt the payload of every message this process publishes (the scene's bus.encrypt)");
  app.add_option("--resume-step", resume_step,
                 "Start from the run's checkpoint of this coupling step (RUN_DIR/checkpoints) instead of from scratch")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
}

void RunContext::load_secret() {
  secret = read_private_file(secret_file, "run secret");  // the user's own, readable by no one else
  if (secret.size() < 16) throw std::runtime_error("run secret " + secret_file + " is shorter than 16 bytes");
}

std::optional<RawEnvelope> parse_envelope(const std::uint8_t* buf, std::size_t len) noexcept {
  try {
    RawEnvelope raw;
    std::size_t pos = kHashBytes;
    for (std::string* field : {&raw.envelope.run_id, &raw.envelope.sender}) {
      if (len < pos + 4) return std::nullopt;
      // int32 length including the NUL: zero or negative (the crash of issue #21), or past the
      // end of the bytes, is no envelope.
      const auto n = static_cast<std::int32_t>(read_be32(buf + pos));
      pos += 4;
      if (n < 1 || static_cast<std::size_t>(n) > kMaxEnvelopeString || len - pos < static_cast<std::size_t>(n))
        return std::nullopt;
      if (buf[pos + static_cast<std::size_t>(n) - 1] != 0) return std::nullopt;
      field->assign(reinterpret_cast<const char*>(buf + pos), static_cast<std::size_t>(n) - 1);
      pos += static_cast<std::size_t>(n);
    }
    if (len - pos < 24 + kTagBytes) return std::nullopt;
    raw.envelope.step = read_be64(buf + pos);
    raw.envelope.seq = read_be64(buf + pos + 8);
    raw.envelope.sent_unix_ns = read_be64(buf + pos + 16);
    pos += 24;
    raw.tag_offset = pos;
    std::memcpy(raw.envelope.tag, buf + pos, kTagBytes);
    return raw;
  } catch (...) {  // std::string's allocation
    return std::nullopt;
  }
}

std::size_t tag_offset(const std::uint8_t* buf, std::size_t len) {
  const auto raw = parse_envelope(buf, len);
  if (!raw) throw std::runtime_error("truncated or malformed envelope");
  return raw->tag_offset;
}

// HMAC-SHA256 of the message as if its tag bytes were zero, without copying the message.
static std::array<std::uint8_t, kTagBytes> compute_tag(const std::uint8_t* buf, std::size_t len, std::size_t off,
                                                       const std::vector<std::uint8_t>& secret) {
  static const std::uint8_t zeros[kTagBytes] = {0};
  std::array<std::uint8_t, kTagBytes> tag{};
  struct Ctx {
    EVP_MAC* mac = EVP_MAC_fetch(nullptr, "HMAC", nullptr);
    EVP_MAC_CTX* ctx = mac ? EVP_MAC_CTX_new(mac) : nullptr;
    ~Ctx() {
      EVP_MAC_CTX_free(ctx);
      EVP_MAC_free(mac);
    }
  } c;
  char digest[] = "SHA256";
  OSSL_PARAM params[] = {OSSL_PARAM_construct_utf8_string("digest", digest, 0), OSSL_PARAM_construct_end()};
  std::size_t n = 0;
  if (!c.ctx || !EVP_MAC_init(c.ctx, secret.data(), secret.size(), params) || !EVP_MAC_update(c.ctx, buf, off) ||
      !EVP_MAC_update(c.ctx, zeros, kTagBytes) ||
      !EVP_MAC_update(c.ctx, buf + off + kTagBytes, len - off - kTagBytes) ||
      !EVP_MAC_final(c.ctx, tag.data(), &n, tag.size()))
    throw std::runtime_error("HMAC-SHA256 unavailable from OpenSSL");
  return tag;
}

void sign(std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret) {
  const auto off = tag_offset(buf.data(), buf.size());
  const auto tag = compute_tag(buf.data(), buf.size(), off, secret);
  std::memcpy(buf.data() + off, tag.data(), kTagBytes);
}

// The send time is written into the encoded bytes rather than set before encoding: a large
// message takes a while to encode, and that is the sender's work, not the exchange's latency.
static void stamp(std::vector<std::uint8_t>& buf) {
  const auto off = tag_offset(buf.data(), buf.size());
  write_be64(buf.data() + off - 8, wall_clock_ns());
}

void stamp_and_sign(std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret) {
  stamp(buf);
  sign(buf, secret);
}

// What goes on the wire: stamped, sealed when asked, then signed (the tag covers the sealed
// bytes, so receivers check it before opening anything). `buf` stays as encoded, unsigned when
// sealed: a tag of the plaintext would let an observer confirm a guess of it.
static std::vector<std::uint8_t> wire_bytes(std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret,
                                            const std::vector<std::uint8_t>* seal_with) {
  if (!seal_with) {
    stamp_and_sign(buf, secret);
    return {};
  }
  stamp(buf);
  auto sealed = seal(*seal_with, buf.data(), buf.size(), tag_offset(buf.data(), buf.size()) + kTagBytes);
  sign(sealed, secret);
  return sealed;
}

// The tag at `off` (an envelope's, parsed) against the one computed with `secret`.
static bool tag_verifies(const std::uint8_t* buf, std::size_t len, std::size_t off,
                         const std::vector<std::uint8_t>& secret) noexcept {
  try {
    const auto tag = compute_tag(buf, len, off, secret);
    return CRYPTO_memcmp(tag.data(), buf + off, kTagBytes) == 0;
  } catch (...) {
    return false;
  }
}

bool verify(const std::uint8_t* buf, std::size_t len, const std::vector<std::uint8_t>& secret) noexcept {
  const auto raw = parse_envelope(buf, len);
  return raw && tag_verifies(buf, len, raw->tag_offset, secret);
}

bool verify(const std::vector<std::uint8_t>& buf, const std::vector<std::uint8_t>& secret) {
  return verify(buf.data(), buf.size(), secret);
}

std::optional<envelope_t> peek_envelope(const std::uint8_t* buf, std::size_t len) {
  auto raw = parse_envelope(buf, len);
  if (!raw) return std::nullopt;
  return raw->envelope;
}

void put_counters(const BusCounters& k, heartbeat_t& hb) {
  hb.accepted = static_cast<std::int64_t>(k.accepted);
  hb.rejected_short = static_cast<std::int64_t>(k.rejected_short);
  hb.rejected_foreign = static_cast<std::int64_t>(k.rejected_foreign);
  hb.rejected_auth = static_cast<std::int64_t>(k.rejected_auth);
  hb.rejected_prestart = static_cast<std::int64_t>(k.rejected_prestart);
  hb.rejected_replay = static_cast<std::int64_t>(k.rejected_replay);
  hb.rejected_undecodable = static_cast<std::int64_t>(k.rejected_corrupt);
}

std::string BusCounters::str() const {
  return fmt::format(
      "received {}, accepted {}; dropped: too short/malformed {}, other run {}, bad tag {}, "
      "pre-start {}, replay {}, undecodable {} (own echoes {}, injected drops {}); resent {}, "
      "asked again {}",
      received, accepted, rejected_short, rejected_foreign, rejected_auth, rejected_prestart, rejected_replay,
      rejected_corrupt, own, injected_drops, resent, resend_requests);
}

namespace {
// The message of a channel kind decoded as its type; nothing when it does not decode (LCM's
// decoder throws on a negative length, allocates what a length says: caught here) or leaves
// bytes over.
template <class Msg>
std::pair<std::shared_ptr<const void>, std::type_index> decode_as(const std::vector<std::uint8_t>& bytes) {
  auto m = std::make_shared<Msg>();
  int n = -1;
  try {
    n = m->decode(bytes.data(), 0, static_cast<int>(bytes.size()));
  } catch (...) {
    n = -1;
  }
  if (n < 0 || static_cast<std::size_t>(n) != bytes.size()) return {nullptr, typeid(void)};
  return {std::move(m), typeid(Msg)};
}

std::pair<std::shared_ptr<const void>, std::type_index> decode_kind(const std::string& channel_kind,
                                                                    const std::vector<std::uint8_t>& bytes) {
  const std::string kind = channel::base_kind(channel_kind);
  if (kind == channel::hello) return decode_as<hello_t>(bytes);
  if (kind == channel::heartbeat) return decode_as<heartbeat_t>(bytes);
  if (kind == channel::step) return decode_as<step_order_t>(bytes);
  if (kind == channel::mesh) return decode_as<mesh_t>(bytes);
  if (kind == channel::fluid_state)
    return kind == channel_kind ? decode_as<fluid_state_t>(bytes) : decode_as<fluid_partition_t>(bytes);
  if (kind == channel::partition) return decode_as<fluid_decomposition_t>(bytes);
  if (kind == channel::domain) return decode_as<particle_domain_t>(bytes);
  if (kind == channel::particle_feedback)
    return kind == channel_kind ? decode_as<particle_feedback_t>(bytes) : decode_as<feedback_partition_t>(bytes);
  if (kind == channel::step_done) return decode_as<step_done_t>(bytes);
  if (kind == channel::resend) return decode_as<resend_request_t>(bytes);
  if (kind == channel::control) return decode_as<control_t>(bytes);
  return {nullptr, typeid(void)};
}
}  // namespace

namespace channel {
std::string of_rank(const std::string& kind, int rank, int ranks) {
  return ranks <= 1 ? kind : kind + "." + std::to_string(rank);
}
std::string base_kind(const std::string& kind) { return kind.substr(0, kind.find('.')); }
std::string of_pair(const std::string& kind, int fluid_rank, int fluid_ranks, int particle_rank, int particle_ranks) {
  if (fluid_ranks * particle_ranks <= 1) return kind;
  return kind + "." + std::to_string(fluid_rank) + "." + std::to_string(particle_rank);
}
std::string of_node_rank(const std::string& kind, const std::string& role, int rank) {
  return kind + "." + role + "." + std::to_string(rank);
}
std::vector<std::string> all() {
  return {hello, heartbeat, step, mesh, fluid_state, particle_feedback, step_done, resend, control, partition, domain};
}
std::vector<std::string> heard_by_coordinator() { return {hello, heartbeat, step_done, resend}; }
// Each node hears the other's hello (its rank count decides whether the exchange is partitioned)
// and the other's half of the overlap map's inputs.
std::vector<std::string> heard_by_fluid() { return {step, particle_feedback, heartbeat, resend, hello, domain}; }
std::vector<std::string> heard_by_particles() {
  return {step, mesh, fluid_state, heartbeat, resend, hello, partition};
}
}  // namespace channel

Bus::Bus(const RunContext& ctx, std::string sender, const std::vector<std::string>& kinds)
    : ctx_(ctx), sender_(std::move(sender)) {
  if (ctx_.secret.empty()) throw std::runtime_error("bus opened without the run secret");
  wire_ = Wire::open(ctx.lcm_url, ctx.secret);
  seal_key_ = seal_key(ctx_.secret);
  opened_us_ = wall_clock_us();
  // LCM keeps at most 30 unhandled messages per subscription and silently discards the rest at
  // receipt: a burst of junk while a node computes a step would push genuine messages out
  // uncounted. Room for a flood of several seconds instead (kSubscriptionQueue), so that whatever
  // arrives is handled here and counted by cause; bounded, so that a flood cannot take all memory.
  for (const auto& kind : kinds) listen(kind);
}

void Bus::listen(const std::string& kind) {
  if (!listening_.insert(kind).second) return;
  wire_->subscribe(topic(kind), [this](const std::uint8_t* data, std::size_t len, const std::string& chan,
                                       std::int64_t recv_utime) { on_raw(data, len, chan, recv_utime); });
}

Bus::~Bus() { log_counters(/*even_if_clean=*/false); }

BusCounters Bus::counters() const {
  std::lock_guard<std::mutex> lock(counters_mutex_);
  return counters_;
}

BusTraffic Bus::traffic() const {
  std::lock_guard<std::mutex> lock(counters_mutex_);
  return traffic_;
}

void Bus::count(std::uint64_t BusCounters::*field) {
  std::lock_guard<std::mutex> lock(counters_mutex_);
  ++(counters_.*field);
}

void Bus::log_counters(bool even_if_clean) {
  if (counters_logged_) return;
  try {
    const auto k = counters();
    if (!even_if_clean && k.rejected() == 0) return;
    counters_logged_ = true;
    if (k.rejected() > 0)
      spdlog::warn("{} bus: {}", sender_, k.str());
    else
      spdlog::info("{} bus: {}", sender_, k.str());
  } catch (...) {
  }
}

std::optional<double> Bus::prestart_lag_s(const std::string& sender) const {
  std::lock_guard<std::mutex> lock(counters_mutex_);
  const auto it = prestart_lag_s_.find(sender);
  if (it == prestart_lag_s_.end()) return std::nullopt;
  return it->second;
}

std::size_t Bus::publish_encoded(const std::string& kind, std::int64_t step, std::vector<std::uint8_t> buf, bool keep) {
  const auto sealed = wire_bytes(buf, ctx_.secret, ctx_.encrypt ? &seal_key_ : nullptr);
  const auto& out = ctx_.encrypt ? sealed : buf;
  {
    std::lock_guard<std::mutex> lock(publish_mutex_);
    wire_->publish(topic(kind), out.data(), out.size());
  }
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    traffic_.sent[kind] += out.size();
  }
  const std::size_t bytes = out.size();
  RankTraffic::sent(bytes);
  if (keep) {
    std::lock_guard<std::mutex> lock(kept_mutex_);
    kept_[kind][step] = {std::move(buf), wall_clock_us()};
  }
  return bytes;
}

void Bus::request_resend(const std::string& kind, std::int64_t step) {
  resend_request_t req;
  req.channel = kind;
  req.wanted_step = step;
  RankTraffic::resent(publish(channel::resend, req, step));
  count(&BusCounters::resend_requests);
}

void Bus::forget_before(std::int64_t step) {
  std::lock_guard<std::mutex> lock(kept_mutex_);
  for (auto& [kind, by_step] : kept_) {
    if (kind == channel::mesh || kind == channel::hello || kind == channel::partition || kind == channel::domain)
      continue;  // wanted by late joiners
    by_step.erase(by_step.begin(), by_step.lower_bound(step));
  }
}

bool Bus::received_again(const std::string& chan, const envelope_t& env) {
  if (chan.compare(chan.rfind('/') + 1, std::string::npos, channel::resend) == 0) return true;
  // Steps come in order, a resend at most a few behind: the last 16 steps of a channel suffice.
  constexpr std::int64_t kStepsRemembered = 16;
  auto& [latest, steps] = had_[chan + ' ' + env.sender];
  if (steps.empty() || env.step > latest) latest = env.step;
  if (!steps.insert(env.step).second) return true;
  while (!steps.empty() && *steps.begin() < latest - kStepsRemembered) steps.erase(steps.begin());
  return false;
}

bool Bus::accept_seq(const std::string& sender, std::int64_t seq) {
  auto& [max_seq, recent] = seen_[sender];
  if (seq <= max_seq - kReplayWindow || recent.count(seq)) return false;
  recent.insert(seq);
  if (seq > max_seq) max_seq = seq;
  while (!recent.empty() && *recent.begin() <= max_seq - kReplayWindow) recent.erase(recent.begin());
  return true;
}

// Runs inside LCM's C dispatch: nothing may be thrown through it (an exception there left
// LCM's receive buffer allocated, and the next message aborted the process in
// lcm_ringbuf_dealloc; issue #21).
void Bus::on_raw(const std::uint8_t* data, std::size_t len, const std::string& chan, std::int64_t recv_utime) {
  try {
    handle_raw(data, len, chan, recv_utime);
  } catch (...) {
    count(&BusCounters::rejected_corrupt);
  }
}

// Every check on the raw bytes first; only an authentic, fresh message is decoded.
void Bus::handle_raw(const std::uint8_t* data, std::size_t len, const std::string& chan, std::int64_t recv_utime) {
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    ++counters_.received;
    traffic_.received[chan.substr(chan.rfind('/') + 1)] += len;
  }
  RankTraffic::received(len);
  auto raw = parse_envelope(data, len);
  if (!raw) return count(&BusCounters::rejected_short);
  const auto& env = raw->envelope;
  if (env.run_id != ctx_.run_id) return count(&BusCounters::rejected_foreign);
  // Nothing of the envelope is believed before its tag verifies: a datagram in our own name is
  // our echo only when it is authentic.
  if (!tag_verifies(data, len, raw->tag_offset, ctx_.secret)) return count(&BusCounters::rejected_auth);
  if (received_again(chan, env)) RankTraffic::received_again(len);
  if (env.sender == sender_) return count(&BusCounters::own);  // multicast loops our own messages back to us
  if (env.seq < opened_us_ - kClockSkewAllowanceUs) {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    prestart_lag_s_[env.sender] = 1e-6 * static_cast<double>(recv_utime - env.sent_unix_ns / 1000);
    ++counters_.rejected_prestart;
    return;
  }
  if (!accept_seq(env.sender, env.seq)) return count(&BusCounters::rejected_replay);
  // Fault injection: as if UDP had lost it. Only others' authentic, fresh messages count towards
  // every n-th, so that hostile datagrams in between do not change which genuine ones are lost.
  if (ctx_.drop_every > 0 && chan.find(channel::heartbeat) == std::string::npos &&
      ++received_for_drop_ % static_cast<std::uint64_t>(ctx_.drop_every) == 0)
    return count(&BusCounters::injected_drops);
  const auto slash = chan.rfind('/');
  Received msg{chan.substr(slash + 1), env, {}};
  if (is_sealed(data, len)) {
    auto plain = unseal(seal_key_, data, len, raw->tag_offset + kTagBytes);
    if (!plain) return count(&BusCounters::rejected_corrupt);
    msg.bytes = std::move(*plain);
  } else {
    msg.bytes.assign(data, data + len);
  }
  auto [decoded, type] = decode_kind(msg.kind, msg.bytes);
  if (!decoded) return count(&BusCounters::rejected_corrupt);
  msg.decoded = std::move(decoded);
  msg.decoded_type = type;
  msg.received_unix_us = recv_utime;
  count(&BusCounters::accepted);
  inbox_.push_back(std::move(msg));
}

int Bus::poll(double timeout_s, const std::function<void(const Received&)>& on_message) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (inbox_.empty()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) break;
    if (wire_->handle(static_cast<int>(left)) < 0) {
      if (errno == EINTR) break;  // a signal: let the caller look at it
      if (is_tcpq(ctx_.lcm_url))
        throw std::runtime_error("lost the connection to the bus relay at " + ctx_.lcm_url.substr(7) +
                                 " (the coordinator's relay ends with its run)");
      throw std::runtime_error("LCM receive failed on " + ctx_.lcm_url);
    }
  }
  while (wire_->handle(0) > 0) {
  }  // drain what is already queued
  std::vector<Received> batch;
  batch.swap(inbox_);
  int handled = 0;
  for (const auto& msg : batch) {
    if (msg.kind == channel::resend) {
      const auto req = msg.as<resend_request_t>();  // decoded on arrival
      std::optional<std::vector<std::uint8_t>> kept;
      bool answered = false;
      {
        std::lock_guard<std::mutex> lock(kept_mutex_);
        const auto kind = kept_.find(req.channel);
        if (kind != kept_.end()) {
          const auto it = kind->second.find(req.wanted_step);
          if (it != kind->second.end()) {
            // A request that reached this host before the message's last publish is answered by
            // that publish: the requests a busy node finds queued after it publishes (the other
            // node asks every retry interval while it waits) would each send it again.
            answered = msg.received_unix_us > 0 && msg.received_unix_us < it->second.published_us;
            if (!answered) kept = it->second.bytes;
          }
        }
      }
      if (answered) continue;
      if (kept) {
        // Publish the same content again with a fresh sequence number and tag.
        auto buf = std::move(*kept);
        write_be64(buf.data() + tag_offset(buf.data(), buf.size()) - 16, next_seq());
        RankTraffic::resent(publish_encoded(req.channel, req.wanted_step, std::move(buf), true));
        count(&BusCounters::resent);
        continue;
      }
      // Someone else's to answer: passed on like any message (the monitor counts them).
    }
    on_message(msg);
    ++handled;
  }
  return handled;
}

std::int64_t Bus::next_seq() {
  auto& seq = process_seq();
  std::int64_t prev = seq.load();
  std::int64_t next;
  do {
    next = std::max(prev + 1, wall_clock_us());
  } while (!seq.compare_exchange_weak(prev, next));
  return next;
}

struct Heartbeat::Impl {
  std::atomic<bool> stop{false};
  std::thread thread;
  mutable std::mutex heard_mutex;
  std::set<std::string> heard;

  // The thread's work until stopped: a heartbeat every period, the heard report rewritten when
  // the set grew, and in between the heartbeats of others received (when listening).
  void run(const RunContext& ctx, const std::string& sender, double period_s,
           const std::function<BusCounters()>& counters, const HeardReport& report);
  // Subscribes to the run's heartbeats; false when the transport cannot listen here.
  bool listen(Wire& wire, const std::string& channel, const RunContext& ctx, const std::string& self);
  // Until the next heartbeat is due, handling what arrives meanwhile (when listening), then
  // `after_hearing`.
  void wait(Wire* listening, double period_s, const std::function<void()>& after_hearing) const;
  std::set<std::string> heard_senders() const {
    std::lock_guard<std::mutex> lock(heard_mutex);
    return heard;
  }
};

std::string heard_report_file(const RunContext& ctx, const std::string& sender) {
  if (ctx.secret_file.empty()) return "";
  const auto slash = ctx.secret_file.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : ctx.secret_file.substr(0, slash);
  return dir + "/bus-check/" + sender;
}

std::optional<HeardReportLine> read_heard_report(const std::string& file) {
  std::ifstream in(file);
  std::string host, heard;
  if (!(in >> host >> heard) || host.rfind("host=", 0) != 0 || heard.rfind("heard=", 0) != 0) return std::nullopt;
  HeardReportLine r;
  r.host = host.substr(5);
  std::istringstream list(heard.substr(6));
  for (std::string s; std::getline(list, s, ',');)
    if (!s.empty()) r.heard.insert(s);
  return r;
}

namespace {
// Atomically (a reader on another host never sees half a file): written aside, then renamed.
void write_heard_report(const std::string& file, const std::set<std::string>& heard) {
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(file).parent_path(), ec);
  char host[256] = "?";
  ::gethostname(host, sizeof host - 1);
  std::string list;
  for (const auto& s : heard) list += (list.empty() ? "" : ",") + s;
  const std::string tmp = file + ".tmp";
  std::ofstream(tmp) << "host=" << host << " heard=" << list << "\n";
  std::filesystem::rename(tmp, file, ec);
}
// A heartbeat of `sender`, encoded and signed.
std::vector<std::uint8_t> signed_heartbeat(const RunContext& ctx, const std::string& sender, double uptime_s,
                                           const std::function<BusCounters()>& counters,
                                           const std::vector<std::uint8_t>& seal_key) {
  heartbeat_t hb;
  hb.envelope.run_id = ctx.run_id;
  hb.envelope.sender = sender;
  hb.envelope.step = -1;
  hb.envelope.seq = Bus::next_seq();
  hb.envelope.sent_unix_ns = 0;
  std::fill(std::begin(hb.envelope.tag), std::end(hb.envelope.tag), 0);
  hb.uptime_s = uptime_s;
  put_counters(counters ? counters() : BusCounters{}, hb);
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(hb.getEncodedSize()));
  hb.encode(buf.data(), 0, static_cast<int>(buf.size()));
  auto sealed = wire_bytes(buf, ctx.secret, ctx.encrypt ? &seal_key : nullptr);
  return ctx.encrypt ? sealed : buf;
}
}  // namespace

Heartbeat::Heartbeat(const RunContext& ctx, std::string sender, double period_s, std::function<BusCounters()> counters,
                     HeardReport report)
    : impl_(new Impl) {
  // The first report, empty, before the thread: once its owner is up, the coordinator can tell a
  // process that reports from one that never will (another program swapped in).
  if (!report.file.empty()) write_heard_report(report.file, {});
  impl_->thread = std::thread([impl = impl_, ctx, sender = std::move(sender), period_s, counters = std::move(counters),
                               report = std::move(report)] { impl->run(ctx, sender, period_s, counters, report); });
}

void Heartbeat::Impl::run(const RunContext& ctx, const std::string& sender, double period_s,
                          const std::function<BusCounters()>& counters, const HeardReport& report) {
  // A transport that cannot be opened here was reported by the process's bus; the thread then
  // publishes nothing and stops with its owner.
  std::unique_ptr<Wire> wire;
  try {
    wire = Wire::open(ctx.lcm_url, ctx.secret);
  } catch (const std::exception&) {
  }
  const std::string channel = ctx.run_id + "/" + channel::heartbeat;
  const bool listening = report.listen && wire && listen(*wire, channel, ctx, sender);
  const auto key = seal_key(ctx.secret);
  std::size_t reported = 0;  // heard senders in the file so far (the constructor wrote none)
  // At once when the set grows, not at the next heartbeat: a short run may end before that.
  const auto report_heard = [&] {
    if (report.file.empty()) return;
    const auto now_heard = heard_senders();
    if (now_heard.size() == reported) return;
    write_heard_report(report.file, now_heard);
    reported = now_heard.size();
  };
  const auto start = Clock::now();
  while (!stop.load()) {
    const auto buf =
        signed_heartbeat(ctx, sender, std::chrono::duration<double>(Clock::now() - start).count(), counters, key);
    if (wire) {
      wire->publish(channel, buf.data(), buf.size());
      RankTraffic::sent(buf.size());
    }
    report_heard();
    wait(listening ? wire.get() : nullptr, period_s, report_heard);
  }
}

bool Heartbeat::Impl::listen(Wire& wire, const std::string& channel, const RunContext& ctx,
                             const std::string& self) {
  // Authentic heartbeats of this run only: a forger without the secret cannot make a broken bus
  // look whole.
  try {
    wire.subscribe(channel, [this, &ctx, &self](const std::uint8_t* data, std::size_t len, const std::string&,
                                               std::int64_t) {
      const auto raw = parse_envelope(data, len);
      if (!raw || raw->envelope.run_id != ctx.run_id || raw->envelope.sender == self) return;
      if (!verify(data, len, ctx.secret)) return;
      std::lock_guard<std::mutex> lock(heard_mutex);
      heard.insert(raw->envelope.sender);
    });
    return true;
  } catch (const std::exception&) {
    return false;  // LCM's self test failed: the bus check will say what this host does not hear
  }
}

void Heartbeat::Impl::wait(Wire* listening, double period_s, const std::function<void()>& after_hearing) const {
  const auto next = Clock::now() + std::chrono::duration<double>(period_s);
  while (!stop.load() && Clock::now() < next) {
    if (!listening || listening->handle(50) < 0)  // < 0: the connection ended, the owner's bus says so
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    else
      after_hearing();
  }
}

std::set<std::string> Heartbeat::heard() const { return impl_->heard_senders(); }

Heartbeat::~Heartbeat() {
  impl_->stop = true;
  if (impl_->thread.joinable()) impl_->thread.join();
  delete impl_;
}

}  // namespace hemo
