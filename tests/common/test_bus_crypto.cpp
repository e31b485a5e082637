// Sealed messages (bus.encrypt; common/bus_crypto.h) over real multicast LCM: they round-trip,
// every process opens them whether it seals its own or not, a lost one is resent sealed, and an
// eavesdropper on the network finds none of the plaintext in the datagrams (which it does when the
// bus is not encrypted). Also the keys: one per purpose, none of them the secret.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "bus_crypto.h"
#include "test_helpers.h"

#include <hemo/fluid_state_t.hpp>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <cstring>

using namespace hemo;

namespace {

std::vector<Received> collect(Bus& bus, double seconds, std::size_t want) {
  std::vector<Received> got;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (got.size() < want && std::chrono::steady_clock::now() < end)
    bus.poll(0.05, [&](const Received& r) { got.push_back(r); });
  return got;
}

// A value no encoding would produce by chance, and its bytes as LCM writes a double (big-endian).
constexpr double kKnown = 0.1234567890123;
Bytes known_bytes() {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &kKnown, 8);
  Bytes b(8);
  for (int i = 0; i < 8; ++i) b[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(bits >> (56 - 8 * i));
  return b;
}
const std::string kKnownHash = "mesh-hash-an-observer-knows";

fluid_state_t known_state(int cells) {
  fluid_state_t s{};
  s.mesh_hash = kKnownHash;
  s.time_s = 0.25;
  s.n_cells = cells;
  s.n_velocity_values = 3 * cells;
  s.velocity.assign(static_cast<std::size_t>(s.n_velocity_values), kKnown);
  s.n_gradient_values = 9 * cells;
  s.velocity_gradient.assign(static_cast<std::size_t>(s.n_gradient_values), 2.5);
  s.n_pressure_gradient_values = 0;
  return s;
}

bool contains(const Bytes& hay, const Bytes& needle) {
  return std::search(hay.begin(), hay.end(), needle.begin(), needle.end()) != hay.end();
}

// Every datagram of the run's FLUID_STATE channel as it travels: what a host on the network sees.
struct Eavesdropper {
  explicit Eavesdropper(const RunContext& ctx) : lcm(ctx.lcm_url) {
    lcm.subscribeFunction(
        ctx.run_id + "/FLUID_STATE",
        +[](const lcm::ReceiveBuffer* rbuf, const std::string&, std::vector<Bytes>* out) {
          const auto* d = static_cast<const std::uint8_t*>(rbuf->data);
          out->emplace_back(d, d + rbuf->data_size);
        },
        &seen);
  }
  void drain(double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) lcm.handleTimeout(20);
  }
  lcm::LCM lcm;
  std::vector<Bytes> seen;
};

}  // namespace

TEST(Sealing, OpensOnlyWithTheKeyAndTheEnvelopeItWasSealedUnder) {
  auto ctx = test::make_context("seal");
  auto state = known_state(4);
  state.envelope.run_id = ctx.run_id;
  state.envelope.sender = "fluid";
  state.envelope.step = 7;
  Bytes plain(static_cast<std::size_t>(state.getEncodedSize()));
  state.encode(plain.data(), 0, static_cast<int>(plain.size()));
  const std::size_t body = tag_offset(plain.data(), plain.size()) + 32;
  const Bytes key = seal_key(ctx.secret);
  const Bytes sealed = seal(key, plain.data(), plain.size(), body);
  EXPECT_EQ(sealed.size(), plain.size() + kSealOverhead);
  EXPECT_TRUE(is_sealed(sealed.data(), sealed.size()));
  EXPECT_FALSE(is_sealed(plain.data(), plain.size()));
  const auto opened = unseal(key, sealed.data(), sealed.size(), body);
  ASSERT_TRUE(opened);
  EXPECT_EQ(*opened, plain);
  // Each sealing draws its own nonce: the same message never looks the same twice.
  EXPECT_NE(seal(key, plain.data(), plain.size(), body), sealed);
  EXPECT_FALSE(unseal(seal_key(Bytes(32, 1)), sealed.data(), sealed.size(), body));
  for (const std::size_t at : {body + 3, body + 12 + 5, sealed.size() - 1, std::size_t{20}}) {
    Bytes bad = sealed;
    bad[at] ^= 0x01;  // the nonce, the ciphertext, the GCM tag, the envelope (associated data)
    EXPECT_FALSE(unseal(key, bad.data(), bad.size(), body)) << "flipped byte " << at;
  }
  // One key per purpose, none the secret itself.
  EXPECT_NE(seal_key(ctx.secret), handshake_key(ctx.secret));
  EXPECT_NE(Bytes(seal_key(ctx.secret)), ctx.secret);
  EXPECT_EQ(seal_key(ctx.secret), key);
}

TEST(SealedBus, RoundTripsOpensForEveryReceiverAndIsResentSealed) {
  auto ctx = test::make_context("sealbus");
  RunContext sealing = ctx;
  sealing.encrypt = true;
  Bus fluid(sealing, "fluid", {channel::resend}), particles(ctx, "particles", {channel::fluid_state});
  Bus monitor(sealing, "monitor", {channel::fluid_state});
  Eavesdropper eve(ctx);
  auto state = known_state(50);
  fluid.publish(channel::fluid_state, state, 3, /*keep=*/true);
  for (Bus* reader : {&particles, &monitor}) {
    const auto got = collect(*reader, 3, 1);
    ASSERT_EQ(got.size(), 1u);
    const auto s = got[0].as<fluid_state_t>();
    EXPECT_EQ(s.velocity, state.velocity);
    EXPECT_EQ(s.velocity_gradient, state.velocity_gradient);
    EXPECT_EQ(s.mesh_hash, kKnownHash);
    EXPECT_EQ(got[0].envelope.sender, "fluid");
    EXPECT_EQ(got[0].envelope.step, 3);
  }
  // Asked again (a lost datagram), it comes sealed again, with a fresh nonce.
  particles.request_resend(channel::fluid_state, 3);
  fluid.poll(1.0, [](const Received&) {});
  const auto again = collect(particles, 3, 1);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].as<fluid_state_t>().velocity, state.velocity);
  EXPECT_EQ(fluid.counters().resent, 1u);
  eve.drain(0.3);
  ASSERT_EQ(eve.seen.size(), 2u);
  EXPECT_TRUE(is_sealed(eve.seen[0].data(), eve.seen[0].size()));
  EXPECT_TRUE(is_sealed(eve.seen[1].data(), eve.seen[1].size()));
  EXPECT_NE(eve.seen[0], eve.seen[1]);
  for (Bus* reader : {&particles, &monitor}) EXPECT_EQ(reader->counters().rejected(), 0u);
}

// What a host on the network captures of a fluid state whose every velocity is a known value: in
// the clear it finds the value and the mesh hash at once; sealed, neither (only the envelope:
// run id, sender, step, times, sizes; docs/hosts.md).
TEST(SealedBus, EavesdropperFindsNoKnownPlaintextInTheDatagrams) {
  for (const bool encrypt : {false, true}) {
    SCOPED_TRACE(encrypt ? "sealed" : "in the clear");
    auto ctx = test::make_context("eve");
    ctx.encrypt = encrypt;
    Eavesdropper eve(ctx);
    Bus fluid(ctx, "fluid", {channel::resend}), particles(ctx, "particles", {channel::fluid_state});
    auto state = known_state(200);
    fluid.publish(channel::fluid_state, state, 1);
    ASSERT_EQ(collect(particles, 3, 1).size(), 1u);
    eve.drain(0.3);
    ASSERT_EQ(eve.seen.size(), 1u);
    const Bytes& captured = eve.seen[0];
    EXPECT_EQ(contains(captured, known_bytes()), !encrypt);
    EXPECT_EQ(contains(captured, Bytes(kKnownHash.begin(), kKnownHash.end())), !encrypt);
    EXPECT_TRUE(contains(captured, Bytes(ctx.run_id.begin(), ctx.run_id.end())));  // the envelope stays clear
  }
}
