// The bus: signed messages arrive; tampered, foreign, replayed and corrupt ones are counted and dropped.
// (tests/common/test_bus_fuzz.cpp sends it ten thousand hostile datagrams.)
// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_fields.h"
#include "test_helpers.h"

#include <hemo/feedback_partition_t.hpp>
#include <hemo/fluid_partition_t.hpp>
#include <hemo/fluid_state_t.hpp>
#include <hemo/heartbeat_t.hpp>
#include <hemo/step_done_t.hpp>
#include <hemo/step_order_t.hpp>

#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

using namespace hemo;

namespace {
std::vector<Received> collect(Bus& bus, double seconds, std::size_t want) {
  std::vector<Received> got;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (got.size() < want && std::chrono::steady_clock::now() < end)
    bus.poll(0.05, [&](const Received& r) { got.push_back(r); });
  return got;
}

std::vector<std::uint8_t> encoded_order(const RunContext& ctx, std::int64_t seq, double time) {
  step_order_t o{};
  o.envelope.run_id = ctx.run_id;
  o.envelope.sender = "intruder";
  o.envelope.step = 3;
  o.envelope.seq = seq;
  o.time_s = time;
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(o.getEncodedSize()));
  o.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}
}  // namespace

TEST(Signing, TagVerifiesAndAnyFlippedByteBreaksIt) {
  auto ctx = test::make_context("sig");
  auto buf = encoded_order(ctx, 7, 1.5);
  sign(buf, ctx.secret);
  EXPECT_TRUE(verify(buf, ctx.secret));
  for (std::size_t i = 0; i < buf.size(); ++i) {
    auto bad = buf;
    bad[i] ^= 0x01;
    EXPECT_FALSE(verify(bad, ctx.secret)) << "flipped byte " << i;
  }
  auto other = ctx.secret;
  other[0] ^= 1;
  EXPECT_FALSE(verify(buf, other));
}

TEST(Signing, TruncatedMessageIsRejectedNotCrashed) {
  auto ctx = test::make_context("trunc");
  auto buf = encoded_order(ctx, 1, 0);
  sign(buf, ctx.secret);
  for (std::size_t n = 0; n < buf.size(); ++n) {
    std::vector<std::uint8_t> cut(buf.begin(), buf.begin() + static_cast<long>(n));
    EXPECT_FALSE(verify(cut, ctx.secret));
  }
}

TEST(Bus, DeliversSignedMessagesAndDropsForgedReplayedForeign) {
  auto ctx = test::make_context("bus");
  Bus alice(ctx, "alice"), bob(ctx, "bob");
  step_order_t o{};
  o.time_s = 0.25;
  alice.publish(channel::step, o, 4);
  auto got = collect(bob, 3, 1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].kind, channel::step);
  EXPECT_EQ(got[0].envelope.sender, "alice");
  EXPECT_EQ(got[0].envelope.step, 4);
  EXPECT_DOUBLE_EQ(got[0].as<step_order_t>().time_s, 0.25);

  lcm::LCM raw(ctx.lcm_url);
  // Forged: a valid message signed with another key.
  auto forged = encoded_order(ctx, 99, 9.0);
  auto wrong_key = ctx.secret;
  wrong_key[5] ^= 0xff;
  sign(forged, wrong_key);
  raw.publish(ctx.run_id + "/STEP", forged.data(), static_cast<unsigned>(forged.size()));
  // Replayed: the same correctly signed message twice.
  auto genuine = encoded_order(ctx, Bus::next_seq(), 2.0);  // sequence numbers are the sender's clock
  sign(genuine, ctx.secret);
  raw.publish(ctx.run_id + "/STEP", genuine.data(), static_cast<unsigned>(genuine.size()));
  raw.publish(ctx.run_id + "/STEP", genuine.data(), static_cast<unsigned>(genuine.size()));
  // Corrupt: garbage bytes.
  std::vector<std::uint8_t> junk(5, 0xab);
  raw.publish(ctx.run_id + "/STEP", junk.data(), static_cast<unsigned>(junk.size()));
  // Foreign: another run's id on our channel.
  auto foreign_ctx = ctx;
  foreign_ctx.run_id = "other";
  auto foreign = encoded_order(foreign_ctx, 5, 3.0);
  sign(foreign, ctx.secret);
  raw.publish(ctx.run_id + "/STEP", foreign.data(), static_cast<unsigned>(foreign.size()));

  got = collect(bob, 2, 5);
  ASSERT_EQ(got.size(), 1u);  // only the first copy of the genuine one
  EXPECT_DOUBLE_EQ(got[0].as<step_order_t>().time_s, 2.0);
  EXPECT_EQ(bob.counters().rejected_auth, 1u);
  EXPECT_EQ(bob.counters().rejected_replay, 1u);
  EXPECT_EQ(bob.counters().rejected_short, 1u);  // 5 bytes hold no envelope
  EXPECT_EQ(bob.counters().rejected_corrupt, 0u);
  EXPECT_EQ(bob.counters().rejected_foreign, 1u);
}

TEST(Bus, KeptMessageIsPublishedAgainOnRequest) {
  auto ctx = test::make_context("resend");
  Bus alice(ctx, "alice"), bob(ctx, "bob");
  step_order_t o{};
  o.time_s = 0.5;
  alice.publish(channel::step, o, 7, /*keep=*/true);
  collect(bob, 1, 1);  // bob takes the first copy; pretend it was lost
  bob.request_resend(channel::step, 7);
  collect(alice, 1, 1);  // alice answers the request while polling
  auto got = collect(bob, 3, 1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].envelope.step, 7);
  EXPECT_DOUBLE_EQ(got[0].as<step_order_t>().time_s, 0.5);
  EXPECT_EQ(alice.counters().resent, 1u);
}

// What a loss costs is counted apart in the process's traffic (common/traffic.h): the first
// publish and its first receipt by each bus are not, the request, the answer and every copy a bus
// is handed again are, whole (in one process both buses add to the same counters).
TEST(Bus, ResendsAreCountedApartFromFirstPublishes) {
  auto ctx = test::make_context("resent");
  Bus alice(ctx, "alice"), bob(ctx, "bob");
  auto drain = [&] {
    collect(alice, 0.3, 100);
    collect(bob, 0.3, 100);
  };
  RankTraffic::take();
  step_order_t o{};
  alice.publish(channel::step, o, 7, /*keep=*/true);
  drain();
  const TrafficBytes first = RankTraffic::take();
  EXPECT_GT(first.sent, 0u);
  EXPECT_GT(first.received, 0u);
  EXPECT_EQ(first.resent, 0u);
  EXPECT_EQ(first.received_again, 0u);

  bob.request_resend(channel::step, 7);  // as if the first copy had been lost
  drain();
  const TrafficBytes again = RankTraffic::take();
  EXPECT_EQ(alice.counters().resent, 1u);
  EXPECT_GT(again.sent, first.sent);  // the request and the message again
  EXPECT_EQ(again.resent, again.sent);
  EXPECT_GE(again.received, first.received);
  EXPECT_EQ(again.received_again, again.received);

  alice.publish(channel::step, o, 8, /*keep=*/true);  // the next step: a first publish again
  drain();
  const TrafficBytes next = RankTraffic::take();
  EXPECT_EQ(next.sent, first.sent);
  EXPECT_EQ(next.resent, 0u);
  EXPECT_EQ(next.received_again, 0u);
}

// A request is answered by the bus that kept the message and passed on by every other (so that
// `hemocosim monitor` sees the requests; it used to swallow them and always showed 0).
TEST(Bus, ARequestSomeoneElseKeepsIsPassedOn) {
  auto ctx = test::make_context("passon");
  Bus alice(ctx, "alice"), bob(ctx, "bob"), carol(ctx, "carol");
  step_order_t o{};
  alice.publish(channel::step, o, 5, /*keep=*/true);
  collect(bob, 1, 1);
  collect(carol, 1, 1);
  bob.request_resend(channel::step, 5);
  const auto at_alice = collect(alice, 1, 1);
  EXPECT_TRUE(at_alice.empty());  // answered, not handed to alice's code
  EXPECT_EQ(alice.counters().resent, 1u);
  const auto at_carol = collect(carol, 2, 2);
  ASSERT_EQ(at_carol.size(), 2u);
  EXPECT_EQ(at_carol[0].kind, channel::resend);
  EXPECT_EQ(at_carol[0].envelope.sender, "bob");
  EXPECT_EQ(at_carol[1].kind, channel::step);  // and the answer
  EXPECT_EQ(carol.counters().resent, 0u);
}

// The partitioned exchange's channels (docs/notes/partitioned-exchange.md): each rank publishes
// its own, a receiver hears only the ranks it subscribed to, decodes them as their kind (a pair's
// FLUID_STATE as the partition message, the plain one as the whole mesh's; a pair's
// PARTICLE_FEEDBACK as the partial sums' message), asks the one keeper of a channel again and
// refuses a replay of it; one rank each is today's channel.
TEST(Bus, PerRankChannelsKeepTheirOwnKeeperAndReplayWindow) {
  EXPECT_EQ(channel::of_rank(channel::fluid_state, 0, 1), channel::fluid_state);
  EXPECT_EQ(channel::of_rank(channel::fluid_state, 1, 2), std::string(channel::fluid_state) + ".1");
  EXPECT_EQ(channel::of_pair(channel::fluid_state, 0, 1, 0, 1), channel::fluid_state);
  const std::string state1 = channel::of_pair(channel::fluid_state, 1, 2, 0, 1);
  EXPECT_EQ(state1, std::string(channel::fluid_state) + ".1.0");
  EXPECT_EQ(channel::of_pair(channel::particle_feedback, 0, 1, 1, 2), std::string(channel::particle_feedback) + ".0.1");
  const std::string pair = channel::of_rank(channel::of_rank(channel::particle_feedback, 2, 4), 1, 3);
  EXPECT_EQ(pair, std::string(channel::particle_feedback) + ".2.1");
  for (const std::string& kind : {state1, pair, std::string(channel::fluid_state)})
    EXPECT_EQ(channel::base_kind(kind), kind.substr(0, kind.find('.'))) << kind;

  auto ctx = test::make_context("ranks");
  Bus fluid0(ctx, "fluid.0", {channel::resend}), fluid1(ctx, "fluid.1", {channel::resend});
  Bus particles0(ctx, "particles.0", {state1, channel::resend});
  fluid_partition_t s0{}, s1{};
  s0.time_s = 0.5;
  s1.time_s = 1.5;
  s1.n_cells = 2;
  s1.cells = {4, 7};
  fluid0.publish(channel::of_pair(channel::fluid_state, 0, 2, 0, 1), s0, 3, /*keep=*/true);
  fluid1.publish(state1, s1, 3, /*keep=*/true);
  auto got = collect(particles0, 2, 2);
  ASSERT_EQ(got.size(), 1u) << "only the subscribed rank's state";
  EXPECT_EQ(got[0].kind, state1);
  EXPECT_EQ(got[0].envelope.sender, "fluid.1");
  const auto decoded = got[0].as<fluid_partition_t>();  // decoded on arrival as its kind's type
  EXPECT_EQ(got[0].decoded_type, std::type_index(typeid(fluid_partition_t)));
  EXPECT_DOUBLE_EQ(decoded.time_s, 1.5);
  EXPECT_EQ(decoded.cells, (std::vector<std::int32_t>{4, 7}));

  // Asked again: the rank that kept that channel answers, the other does not.
  particles0.request_resend(state1, 3);
  collect(fluid0, 1, 1);
  collect(fluid1, 1, 1);
  EXPECT_EQ(fluid0.counters().resent, 0u);
  EXPECT_EQ(fluid1.counters().resent, 1u);
  const auto again = collect(particles0, 2, 1);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].kind, state1);
  EXPECT_GT(again[0].envelope.seq, got[0].envelope.seq);

  // The first copy's bytes played again: refused by its sender's replay window.
  lcm::LCM raw(ctx.lcm_url);
  raw.publish(ctx.run_id + "/" + state1, got[0].bytes.data(), static_cast<unsigned>(got[0].bytes.size()));
  EXPECT_TRUE(collect(particles0, 1, 1).empty());
  EXPECT_EQ(particles0.counters().rejected_replay, 1u);

  // A whole-mesh state on a pair's channel is not its kind's message: refused, not handed on.
  fluid_state_t whole{};
  resize_cells(whole, 3);
  fluid1.publish(state1, whole, 4);
  EXPECT_TRUE(collect(particles0, 1, 1).empty());
  EXPECT_EQ(particles0.counters().rejected_corrupt, 1u);

  // The feedback back on a pair's channel: decoded as the partial sums' message; the whole
  // mesh's feedback there is refused likewise.
  Bus fluid1_in(ctx, "fluid.1", {pair});
  Bus particles1(ctx, "particles.1", {channel::resend});
  feedback_partition_t partial{};
  partial.fluid_rank = 2;
  partial.particle_rank = 1;
  partial.n_cells = 1;
  partial.cells = {5};
  partial.solid_fraction = {0.25};
  partial.drag_coefficient = {3.0};
  partial.n_source_values = 3;
  partial.source_explicit = {1, 2, 3};
  particles1.publish(pair, partial, 6, /*keep=*/true);
  const auto fed = collect(fluid1_in, 2, 1);
  ASSERT_EQ(fed.size(), 1u);
  EXPECT_EQ(fed[0].decoded_type, std::type_index(typeid(feedback_partition_t)));
  EXPECT_EQ(fed[0].as<feedback_partition_t>().solid_fraction, std::vector<double>{0.25});
  particle_feedback_t whole_feedback{};
  resize_cells(whole_feedback, 1);
  particles1.publish(pair, whole_feedback, 7);
  EXPECT_TRUE(collect(fluid1_in, 1, 1).empty());
  EXPECT_EQ(fluid1_in.counters().rejected_corrupt, 1u);
}

namespace {
std::int64_t unix_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}
}  // namespace

// The envelope carries the wall clock of the publish and the receiver the time it got the
// datagram: together the exchange latency `hemocosim monitor` shows (issue #23). A resend is a
// new publish, with a new send time.
TEST(Bus, StampsSendAndReceiptTimesAResendAgain) {
  auto ctx = test::make_context("stamp");
  Bus alice(ctx, "alice"), bob(ctx, "bob");
  step_order_t o{};
  const auto before = unix_ns();
  alice.publish(channel::step, o, 2, /*keep=*/true);
  const auto after = unix_ns();
  auto got = collect(bob, 3, 1);
  const auto received_by = unix_ns();
  ASSERT_EQ(got.size(), 1u);
  const auto sent = got[0].envelope.sent_unix_ns;
  EXPECT_GE(sent, before);
  EXPECT_LE(sent, after);
  // LCM's receive time has microseconds: one host's clock, so never before the send.
  EXPECT_GE(got[0].received_unix_us, sent / 1000);
  EXPECT_LE(got[0].received_unix_us, received_by / 1000 + 1);

  bob.request_resend(channel::step, 2);
  collect(alice, 1, 1);
  auto again = collect(bob, 3, 1);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_GT(again[0].envelope.sent_unix_ns, sent);
  EXPECT_GE(again[0].received_unix_us, again[0].envelope.sent_unix_ns / 1000);
}

// Each process hears only its channels: the coordinator is not woken by the large fluid state
// (nor made to check its tag), the particle node hears it. LCM drops the datagrams of channels
// a process does not listen to before they reach the bus, so they are not even counted.
TEST(Bus, EachProcessHearsOnlyWhatIsMeantForIt) {
  auto ctx = test::make_context("heard");
  Bus fluid(ctx, "fluid", channel::heard_by_fluid());
  Bus coordinator(ctx, "coordinator", channel::heard_by_coordinator());
  Bus particles(ctx, "particles", channel::heard_by_particles());
  fluid_state_t state{};
  resize_cells(state, 2000);  // a few datagrams, as at the paper's mesh
  for (int c = 0; c < 2000; ++c) {
    double* u = velocity_of(state, c);
    u[0] = 0.1, u[1] = 0.2, u[2] = 0.3;
  }
  fluid.publish(channel::fluid_state, state, 1);
  step_done_t done{};
  done.node = "fluid";
  done.ok = true;
  fluid.publish(channel::step_done, done, 1);

  const auto heard_by_particles = collect(particles, 3, 1);
  ASSERT_EQ(heard_by_particles.size(), 1u);
  EXPECT_EQ(heard_by_particles[0].kind, channel::fluid_state);
  EXPECT_EQ(velocity_of(heard_by_particles[0].as<fluid_state_t>(), 1999)[2], 0.3);

  const auto heard_by_coordinator = collect(coordinator, 3, 2);
  ASSERT_EQ(heard_by_coordinator.size(), 1u);
  EXPECT_EQ(heard_by_coordinator[0].kind, channel::step_done);
  EXPECT_EQ(coordinator.counters().accepted, 1u);
  EXPECT_EQ(particles.counters().accepted, 1u);
}

// The in-memory transport (inproc://NAME) that the runtime's unit tests run on: the same bus
// above it, so the same deliveries, echoes and refusals as over LCM.
TEST(InProcessBus, DeliversToEveryBusOfItsNameWithTheSameChecksAsLcm) {
  auto ctx = test::make_context("inproc");
  ctx.lcm_url = "inproc://" + ctx.run_id;
  auto elsewhere = ctx;
  elsewhere.lcm_url = "inproc://" + ctx.run_id + "-other";
  Bus alice(ctx, "alice"), bob(ctx, "bob"), carol(elsewhere, "carol");
  step_order_t o{};
  o.time_s = 0.5;
  alice.publish(channel::step, o, 2);
  auto got = collect(bob, 1, 1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].envelope.sender, "alice");
  EXPECT_DOUBLE_EQ(got[0].as<step_order_t>().time_s, 0.5);
  EXPECT_TRUE(collect(carol, 0.2, 1).empty());  // another name: another hub
  collect(alice, 0.2, 1);
  EXPECT_EQ(alice.counters().own, 1u);  // its own message comes back, as multicast loops it back

  // A raw datagram on the hub goes through the same checks: a wrong key is a bad tag.
  auto raw = Wire::open(ctx.lcm_url);
  auto forged = encoded_order(ctx, 99, 9.0);
  auto wrong_key = ctx.secret;
  wrong_key[3] ^= 0x40;
  sign(forged, wrong_key);
  raw->publish(bob.topic(channel::step), forged.data(), forged.size());
  const std::vector<std::uint8_t> junk = {1, 2, 3};
  raw->publish(bob.topic(channel::step), junk.data(), junk.size());
  EXPECT_TRUE(collect(bob, 0.2, 1).empty());
  EXPECT_EQ(bob.counters().rejected_auth, 1u);
  EXPECT_EQ(bob.counters().rejected_short, 1u);
  EXPECT_EQ(bob.counters().accepted, 1u);
}

TEST(InProcessBus, WaitsForADatagramAndKeepsAtMostTheQueueBound) {
  auto raw = Wire::open("inproc://bound-test");
  int handled = 0;
  raw->subscribe("ch", [&](const std::uint8_t*, std::size_t, const std::string&, std::int64_t) { ++handled; });
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(raw->handle(100), 0);  // nothing: it waits out the timeout
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(90));
  const std::uint8_t byte = 7;
  for (int i = 0; i < kSubscriptionQueue + 5; ++i) raw->publish("ch", &byte, 1);
  raw->publish("not-listened", &byte, 1);
  while (raw->handle(0) > 0) {
  }
  EXPECT_EQ(handled, kSubscriptionQueue);
  EXPECT_THROW(Wire::open("inproc://"), std::runtime_error);
}

namespace {
// A step order from `sender`, signed with `key`; published raw, as anyone on the LAN can.
std::vector<std::uint8_t> order_from(const RunContext& ctx, const std::string& sender, double time,
                                     const std::vector<std::uint8_t>& key) {
  auto buf = encoded_order(ctx, Bus::next_seq(), time);
  step_order_t o{};
  o.decode(buf.data(), 0, static_cast<int>(buf.size()));
  o.envelope.sender = sender;
  buf.assign(static_cast<std::size_t>(o.getEncodedSize()), 0);
  o.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sign(buf, key);
  return buf;
}

// Polls until `bus` has counted `n` datagrams (or 3 s went by).
std::vector<Received> until_received(Bus& bus, std::uint64_t n) {
  std::vector<Received> got;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (bus.counters().received < n && std::chrono::steady_clock::now() < end)
    bus.poll(0.05, [&](const Received& r) { got.push_back(r); });
  return got;
}
}  // namespace

// Nothing unauthenticated is believed of an envelope: a forged datagram that carries the
// receiver's own sender name is a bad tag, not the receiver's own echo (issue #21). Only an
// authentic one is an echo.
TEST(Bus, AForgedDatagramInTheReceiversNameIsABadTagNotItsOwnEcho) {
  auto ctx = test::make_context("ownname");
  Bus fluid(ctx, "fluid", channel::heard_by_fluid());
  lcm::LCM raw(ctx.lcm_url);
  auto wrong_key = ctx.secret;
  wrong_key[0] ^= 0x80;
  const auto forged = order_from(ctx, "fluid", 1.0, wrong_key);
  raw.publish(fluid.topic(channel::step), forged.data(), static_cast<unsigned>(forged.size()));
  auto got = until_received(fluid, 1);
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(fluid.counters().rejected_auth, 1u) << fluid.counters().str();
  EXPECT_EQ(fluid.counters().own, 0u) << fluid.counters().str();

  const auto echo = order_from(ctx, "fluid", 2.0, ctx.secret);  // as if it had published it
  raw.publish(fluid.topic(channel::step), echo.data(), static_cast<unsigned>(echo.size()));
  got = until_received(fluid, 2);
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(fluid.counters().own, 1u) << fluid.counters().str();
  EXPECT_EQ(fluid.counters().rejected_auth, 1u) << fluid.counters().str();
}

// run.drop_every simulates UDP losing others' genuine messages: every n-th of them is dropped,
// whatever hostile datagrams (forged, in its own name, replays, foreign) come in between, so
// that the genuine traffic loses the same messages with and without them.
TEST(Bus, InjectedDropsCountOnlyOthersGenuineMessages) {
  auto ctx = test::make_context("dropevery");
  ctx.drop_every = 3;
  Bus fluid(ctx, "fluid", channel::heard_by_fluid());
  lcm::LCM raw(ctx.lcm_url);
  auto wrong_key = ctx.secret;
  wrong_key[0] ^= 0x80;
  auto publish = [&](const std::vector<std::uint8_t>& b) {
    raw.publish(fluid.topic(channel::step), b.data(), static_cast<unsigned>(b.size()));
  };
  std::uint64_t sent = 0;
  std::vector<double> genuine;
  for (int i = 0; i < 9; ++i) {
    const auto g = order_from(ctx, "coordinator", i, ctx.secret);
    publish(g), ++sent;
    genuine.push_back(i);
    publish(g), ++sent;                                                   // a replay
    publish(order_from(ctx, "coordinator", 100 + i, wrong_key)), ++sent;  // forged
    publish(order_from(ctx, "fluid", 200 + i, wrong_key)), ++sent;        // forged in its name
    publish(order_from(ctx, "fluid", 300 + i, ctx.secret)), ++sent;       // its own echo
  }
  const auto got = until_received(fluid, sent);
  std::vector<double> times;
  for (const auto& r : got) times.push_back(r.as<step_order_t>().time_s);
  EXPECT_EQ(times, (std::vector<double>{0, 1, 3, 4, 6, 7})) << fluid.counters().str();
  const auto k = fluid.counters();
  EXPECT_EQ(k.injected_drops, 3u) << k.str();
  EXPECT_EQ(k.rejected_replay, 9u) << k.str();
  EXPECT_EQ(k.rejected_auth, 18u) << k.str();
  EXPECT_EQ(k.own, 9u) << k.str();
  EXPECT_EQ(k.received, sent) << k.str();
}
