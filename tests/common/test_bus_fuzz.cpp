// Fuzzing the bus over real LCM (udpm on loopback, issue #21): random bytes, truncated and
// bit-flipped genuine messages, zero and negative string lengths, other runs' ids, wrong keys,
// replays and recordings from before the receiver started, interleaved with genuine messages.
// Nothing may crash or throw, every genuine message arrives intact, and every datagram is
// counted once under the cause it was sent for.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_fields.h"
#include "test_helpers.h"

#include <hemo/control_t.hpp>
#include <hemo/fluid_state_t.hpp>
#include <hemo/heartbeat_t.hpp>
#include <hemo/hello_t.hpp>
#include <hemo/mesh_t.hpp>
#include <hemo/particle_feedback_t.hpp>
#include <hemo/step_done_t.hpp>
#include <hemo/step_order_t.hpp>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cstring>
#include <map>
#include <random>
#include <thread>

using namespace hemo;

namespace {

struct Datagram {
  std::string kind;
  std::vector<std::uint8_t> bytes;
};

template <class Msg>
std::vector<std::uint8_t> encode(Msg& m, const RunContext& ctx, const std::string& sender, std::int64_t step,
                                 std::int64_t seq) {
  m.envelope.run_id = ctx.run_id;
  m.envelope.sender = sender;
  m.envelope.step = step;
  m.envelope.seq = seq;
  std::memset(m.envelope.tag, 0, sizeof m.envelope.tag);
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sign(buf, ctx.secret);
  return buf;
}

// One genuine message of each kind a node hears, with content that depends on `i`.
Datagram genuine(const RunContext& ctx, int i, std::int64_t seq) {
  switch (i % 6) {
    case 0: {
      step_order_t o{};
      o.time_s = 1e-5 * i;
      o.dt_s = 1e-5;
      return {channel::step, encode(o, ctx, "coordinator", i, seq)};
    }
    case 1: {
      fluid_state_t s{};
      s.mesh_hash = "m" + std::to_string(i);
      s.time_s = i;
      resize_cells(s, 1 + i % 7);
      for (auto& v : s.velocity) v = 0.001 * i;
      for (auto& g : s.velocity_gradient) g = -0.5 * i;
      return {channel::fluid_state, encode(s, ctx, "fluid", i, seq)};
    }
    case 2: {
      particle_feedback_t f{};
      f.mesh_hash = "m";
      resize_cells(f, 1 + i % 5);
      for (auto& v : f.solid_fraction) v = 0.01 * (i % 50);
      f.total_particle_force[2] = i;
      return {channel::particle_feedback, encode(f, ctx, "particles", i, seq)};
    }
    case 3: {
      step_done_t d{};
      d.node = "fluid";
      d.ok = true;
      d.error = "";
      d.n_diagnostics = 2;
      d.names = {"courant_max", "iterations"};
      d.values = {0.01 * i, double(i)};
      return {channel::step_done, encode(d, ctx, "fluid", i, seq)};
    }
    case 4: {
      heartbeat_t h{};
      h.uptime_s = i;
      return {channel::heartbeat, encode(h, ctx, "particles", -1, seq)};
    }
    default: {
      hello_t h{};
      h.role = "fluid";
      h.program = "fuzz";
      h.hostname = "here";
      h.pid = i;
      h.ranks = 1;
      return {channel::hello, encode(h, ctx, "fluid", 0, seq)};
    }
  }
}

void put_be32(std::vector<std::uint8_t>& b, std::size_t at, std::int32_t v) {
  const auto u = static_cast<std::uint32_t>(v);
  for (int k = 0; k < 4; ++k) b[at + k] = static_cast<std::uint8_t>(u >> (24 - 8 * k));
}

// Offsets in an encoded message: run_id's length, sender's length, the first byte after the tag.
std::size_t sender_length_at(const std::vector<std::uint8_t>& b) {
  const std::size_t run_len = (std::size_t(b[8]) << 24) | (std::size_t(b[9]) << 16) | (std::size_t(b[10]) << 8) | b[11];
  return 12 + run_len;
}
std::size_t body_at(const std::vector<std::uint8_t>& b) { return tag_offset(b.data(), b.size()) + 32; }

// Sends datagrams and polls the receiver until it has been handed all of them, so that the
// receiving socket never overflows (the counts must add up exactly).
class Harness {
 public:
  Harness(const RunContext& ctx, Bus& victim) : ctx_(ctx), raw_(ctx.lcm_url), victim_(victim) {}

  void send(const Datagram& d) {
    raw_.publish(ctx_.run_id + "/" + d.kind, d.bytes.data(), static_cast<unsigned>(d.bytes.size()));
    ++sent_;
    if (sent_ % 32 == 0) drain();
  }
  void drain() {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (victim_.counters().received < sent_ && std::chrono::steady_clock::now() < deadline)
      victim_.poll(0.01, [&](const Received& r) { got.push_back(r); });
    victim_.poll(0, [&](const Received& r) { got.push_back(r); });
  }
  std::uint64_t sent() const { return sent_; }
  std::vector<Received> got;

 private:
  const RunContext& ctx_;
  lcm::LCM raw_;
  Bus& victim_;
  std::uint64_t sent_ = 0;
};

// The message decoded by the bus, encoded again: must be the bytes that were sent.
std::vector<std::uint8_t> reencoded(const Received& r) {
  auto enc = [](auto m) {
    std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
    m.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  };
  if (r.kind == channel::step) return enc(r.as<step_order_t>());
  if (r.kind == channel::fluid_state) return enc(r.as<fluid_state_t>());
  if (r.kind == channel::particle_feedback) return enc(r.as<particle_feedback_t>());
  if (r.kind == channel::step_done) return enc(r.as<step_done_t>());
  if (r.kind == channel::heartbeat) return enc(r.as<heartbeat_t>());
  if (r.kind == channel::hello) return enc(r.as<hello_t>());
  return {};
}

}  // namespace

TEST(BusFuzz, TenThousandHostileDatagramsAreCountedByCauseAndGenuineOnesArriveIntact) {
  auto ctx = test::make_context("fuzz");
  std::mt19937_64 rng(20261203);
  auto uniform = [&](std::size_t n) { return static_cast<std::size_t>(rng() % n); };

  // A recording made before the receiver starts: genuine, correctly signed, and 2 s older than
  // its bus (beyond the clock-skew allowance).
  std::vector<Datagram> recording;
  for (int i = 0; i < 600; ++i) recording.push_back(genuine(ctx, i, Bus::next_seq()));
  std::this_thread::sleep_for(std::chrono::microseconds(kClockSkewAllowanceUs + 1'000'000));

  Bus victim(ctx, "victim");
  Harness h(ctx, victim);
  std::map<std::string, std::uint64_t> expected;  // cause -> datagrams sent for it
  std::uint64_t short_or_foreign = 0, short_or_auth = 0, any_rejection = 0;
  std::vector<std::vector<std::uint8_t>> genuine_sent;
  std::vector<Datagram> sent_genuine_datagrams;
  const std::vector<std::string> kinds = channel::all();
  auto other_ctx = ctx;
  other_ctx.run_id = ctx.run_id + "x";
  auto wrong_key = ctx;
  wrong_key.secret[3] ^= 0x5a;

  int next = 0;
  auto fresh = [&] { return genuine(ctx, next++, Bus::next_seq()); };
  auto send_genuine = [&] {
    auto d = fresh();
    genuine_sent.push_back(d.bytes);
    sent_genuine_datagrams.push_back(d);
    h.send(d);
  };

  for (int round = 0; round < 600; ++round) {
    send_genuine();
    // Random bytes of random length, on a random channel (a run id is never matched by chance).
    for (int k = 0; k < 4; ++k) {
      Datagram d{kinds[uniform(kinds.size())], std::vector<std::uint8_t>(uniform(400))};
      for (auto& b : d.bytes) b = static_cast<std::uint8_t>(rng());
      h.send(d), ++short_or_foreign;
    }
    // Truncated genuine messages: cut before the tag's end the envelope is short, after it the tag fails.
    for (int k = 0; k < 3; ++k) {
      auto d = fresh();
      d.bytes.resize(uniform(d.bytes.size()));
      h.send(d), ++short_or_auth;
    }
    // Bit-flipped genuine messages: 1 to 8 bits anywhere; never accepted.
    for (int k = 0; k < 4; ++k) {
      auto d = fresh();
      const auto original = d.bytes;
      while (d.bytes == original)  // flips of the same bit could cancel out
        for (std::size_t f = 0, n = 1 + uniform(8); f < n; ++f)
          d.bytes[uniform(d.bytes.size())] ^= std::uint8_t(1u << uniform(8));
      h.send(d), ++any_rejection;
    }
    // Zero, negative and oversized string lengths in the envelope (the crash of issue #21).
    for (std::int32_t len : {0, -1, -2147483647 - 1, int(-1 - uniform(1000)), 0x7fffffff, 100000}) {
      auto d = fresh();
      put_be32(d.bytes, (uniform(2) == 0) ? 8 : sender_length_at(d.bytes), len);
      h.send(d), ++expected["short"];
    }
    // The same in the body, re-signed with the run's key (a buggy peer): authentic but undecodable.
    {
      auto d = fresh();
      put_be32(d.bytes, body_at(d.bytes),
               round % 2 ? 0 : -int(1 + uniform(100000)));  // first string or count of the body
      if (d.kind == channel::step || d.kind == channel::heartbeat)
        d.bytes.resize(d.bytes.size() - 3);  // no string there: cut
      sign(d.bytes, ctx.secret);
      h.send(d), ++expected["undecodable"];
    }
    // Another run's id, signed with our key; and ours signed with a wrong key.
    {
      auto d = genuine(other_ctx, next++, Bus::next_seq());
      h.send(d), ++expected["foreign"];
      auto w = genuine(wrong_key, next++, Bus::next_seq());
      h.send(w), ++expected["auth"];
    }
    // A replay of a genuine message already accepted.
    h.send(sent_genuine_datagrams[uniform(sent_genuine_datagrams.size())]), ++expected["replay"];
    // A recording from before the receiver opened its bus.
    h.send(recording[static_cast<std::size_t>(round)]), ++expected["prestart"];
  }
  h.drain();

  const auto k = victim.counters();
  ASSERT_GE(h.sent(), 10000u);
  EXPECT_EQ(k.received, h.sent()) << k.str();
  EXPECT_EQ(k.accepted, genuine_sent.size()) << k.str();
  EXPECT_EQ(k.accepted + k.rejected() + k.own + k.injected_drops, k.received) << k.str();
  EXPECT_EQ(k.rejected_prestart, expected["prestart"]) << k.str();
  EXPECT_EQ(k.rejected_replay, expected["replay"]) << k.str();
  EXPECT_EQ(k.rejected_corrupt, expected["undecodable"]) << k.str();
  // Causes that share categories: each category's datagrams are all rejected, by its causes.
  EXPECT_GE(k.rejected_short, expected["short"]) << k.str();
  EXPECT_GE(k.rejected_foreign, expected["foreign"]) << k.str();
  EXPECT_GE(k.rejected_auth, expected["auth"]) << k.str();
  EXPECT_EQ(
      k.rejected_short + k.rejected_foreign + k.rejected_auth,
      expected["short"] + expected["foreign"] + expected["auth"] + short_or_foreign + short_or_auth + any_rejection)
      << k.str();

  // Every genuine message arrived once, bit for bit, and decodes to what was sent.
  ASSERT_EQ(h.got.size(), genuine_sent.size());
  for (std::size_t i = 0; i < h.got.size(); ++i) {
    EXPECT_EQ(h.got[i].bytes, genuine_sent[i]) << i;
    EXPECT_EQ(reencoded(h.got[i]), genuine_sent[i]) << i << " " << h.got[i].kind;
  }
}

// The zero-length string of issue #21 on each node's channels, to the node's own bus: the bus
// drops it, counts it, and the next genuine message still arrives.
TEST(BusFuzz, ZeroAndNegativeEnvelopeLengthsOnEveryChannelAreDroppedNotThrown) {
  auto ctx = test::make_context("zerolen");
  Bus fluid(ctx, "fluid", channel::heard_by_fluid());
  Bus particles(ctx, "particles", channel::heard_by_particles());
  Bus coordinator(ctx, "coordinator", channel::heard_by_coordinator());
  lcm::LCM raw(ctx.lcm_url);
  std::uint64_t sent = 0;
  for (const auto& kind : channel::all()) {
    for (std::int32_t len : {0, -1, -1000}) {
      std::vector<std::uint8_t> b(100, 0x41);  // ~100 bytes, as in the issue
      put_be32(b, 8, len);
      raw.publish(ctx.run_id + "/" + kind, b.data(), static_cast<unsigned>(b.size()));
      ++sent;
    }
    std::vector<std::uint8_t> junk(100);
    std::mt19937 rng(7);
    for (auto& x : junk) x = static_cast<std::uint8_t>(rng());
    raw.publish(ctx.run_id + "/" + kind, junk.data(), static_cast<unsigned>(junk.size()));
  }
  auto d = genuine(ctx, 1, Bus::next_seq());  // a fluid state, heard by the particles
  raw.publish(ctx.run_id + "/" + d.kind, d.bytes.data(), static_cast<unsigned>(d.bytes.size()));
  std::vector<Received> got;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (std::chrono::steady_clock::now() < end && got.empty())
    EXPECT_NO_THROW(particles.poll(0.05, [&](const Received& r) { got.push_back(r); }));
  EXPECT_NO_THROW(fluid.poll(0.3, [](const Received&) {}));
  EXPECT_NO_THROW(coordinator.poll(0.3, [](const Received&) {}));
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].bytes, d.bytes);
  EXPECT_EQ(particles.counters().rejected_short, 4u * channel::heard_by_particles().size());
  EXPECT_EQ(fluid.counters().rejected_short, 4u * channel::heard_by_fluid().size());
  EXPECT_EQ(coordinator.counters().rejected_short, 4u * channel::heard_by_coordinator().size());
}

// A process's heartbeat carries its bus counters (the monitor shows them).
TEST(BusFuzz, HeartbeatCarriesTheRejectionCounts) {
  auto ctx = test::make_context("hbcount");
  Bus node(ctx, "fluid", channel::heard_by_fluid());
  Bus watcher(ctx, "monitor");
  lcm::LCM raw(ctx.lcm_url);
  std::vector<std::uint8_t> b(100, 0);  // zero run-id length
  for (int i = 0; i < 5; ++i) raw.publish(ctx.run_id + "/" + channel::step, b.data(), static_cast<unsigned>(b.size()));
  auto forged = genuine(ctx, 0, Bus::next_seq());  // a step order ...
  forged.bytes.back() ^= 1;                        // ... tampered with
  raw.publish(ctx.run_id + "/" + forged.kind, forged.bytes.data(), static_cast<unsigned>(forged.bytes.size()));
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (std::chrono::steady_clock::now() < until && node.counters().received < 6)
    node.poll(0.05, [](const Received&) {});
  ASSERT_EQ(node.counters().rejected_short, 5u);
  ASSERT_EQ(node.counters().rejected_auth, 1u);
  Heartbeat hb(ctx, "fluid", 0.1, [&] { return node.counters(); });
  std::optional<heartbeat_t> heard;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (!heard && std::chrono::steady_clock::now() < end)
    watcher.poll(0.05, [&](const Received& r) {
      if (r.kind == channel::heartbeat && r.envelope.sender == "fluid") heard = r.as<heartbeat_t>();
    });
  ASSERT_TRUE(heard);
  EXPECT_EQ(heard->rejected_short, 5);
  EXPECT_EQ(heard->rejected_auth, 1);
  EXPECT_EQ(heard->rejected_replay, 0);
}

// Received::as of bytes that are not the type: a runtime_error naming the channel, never
// std::length_error out of LCM's string decoder.
TEST(BusFuzz, AsOfMalformedBytesThrowsARuntimeError) {
  Received r{"STEP_DONE", {}, std::vector<std::uint8_t>(100, 0)};
  try {
    r.as<step_done_t>();
    FAIL() << "decoded";
  } catch (const std::length_error&) {
    FAIL() << "length_error escaped";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("STEP_DONE"), std::string::npos);
  }
}
