// The bus relay of the TCP transport (coordinator/relay.h) with real sockets and real LCM clients
// (Debian's liblcm, `tcpq://` provider) in threads: subscriptions are honoured, many messages
// arrive whole and in order, a client that goes away or sends garbage costs only its own
// connection, and the run's envelope checks stand over it.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "bus.h"
#include "relay.h"
#include "run_directory.h"

#include <hemo/step_order_t.hpp>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <thread>

using namespace hemo;
using namespace std::chrono_literals;

namespace {

bool wait_for(const std::function<bool()>& ok, double seconds = 10) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!ok()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

// An LCM client that records what it receives on the patterns it subscribes, and handles its
// messages in a thread of its own.
class Listener {
 public:
  Listener(const std::string& url, const std::vector<std::string>& patterns) : lcm_(url) {
    for (const auto& p : patterns)
      lcm_.subscribeFunction(
              p,
              +[](const lcm::ReceiveBuffer* rbuf, const std::string& channel, Listener* self) {
                std::lock_guard<std::mutex> lock(self->mutex_);
                const auto* d = static_cast<const std::uint8_t*>(rbuf->data);
                self->got_.push_back({channel, std::vector<std::uint8_t>(d, d + rbuf->data_size)});
              },
              this)
          ->setQueueCapacity(100000);
    thread_ = std::thread([this] {
      while (!stop_)
        if (lcm_.handleTimeout(20) < 0) {
          broken_ = true;
          std::this_thread::sleep_for(20ms);
        }
    });
  }
  ~Listener() {
    stop_ = true;
    thread_.join();
  }
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> got() {
    std::lock_guard<std::mutex> lock(mutex_);
    return got_;
  }
  std::size_t count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return got_.size();
  }
  std::size_t count(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::size_t n = 0;
    for (const auto& g : got_) n += g.first == channel;
    return n;
  }
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    got_.clear();
  }
  lcm::LCM& lcm() { return lcm_; }

 private:
  lcm::LCM lcm_;
  std::mutex mutex_;
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> got_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> broken_{false};
  std::thread thread_;
};

void publish(lcm::LCM& lcm, const std::string& channel, const std::string& text) {
  ASSERT_EQ(lcm.publish(channel, text.data(), static_cast<unsigned>(text.size())), 0);
}

// Subscriptions travel on each client's own connection, so a client knows the relay has its
// subscriptions once a message it publishes to itself comes back.
void settle(Listener& l, const std::string& own_channel) {
  const auto before = l.count(own_channel);
  publish(l.lcm(), own_channel, "sync");
  ASSERT_TRUE(wait_for([&] { return l.count(own_channel) > before; })) << own_channel;
}

// A raw TCP connection to the relay, for what no LCM client would send.
struct RawClient {
  int fd = -1;
  explicit RawClient(int port) {
    fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, "127.0.0.1", &sa.sin_addr);
    EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa), 0);
  }
  ~RawClient() {
    if (fd >= 0) ::close(fd);
  }
  void send_words(const std::vector<std::uint32_t>& words) {
    std::vector<std::uint8_t> b;
    for (auto w : words)
      for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<std::uint8_t>(w >> s));
    send_bytes(b);
  }
  void send_bytes(const std::vector<std::uint8_t>& b) {
    ASSERT_EQ(::send(fd, b.data(), b.size(), MSG_NOSIGNAL), static_cast<ssize_t>(b.size()));
  }
  void send_text(const std::string& s) { send_bytes(std::vector<std::uint8_t>(s.begin(), s.end())); }
  // True once the relay has closed this connection (reads drain what it sent before).
  bool closed_by_peer(double seconds = 5) {
    timeval tv{0, 100000};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    char buf[4096];
    while (std::chrono::steady_clock::now() < end) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n == 0) return true;
      if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) return true;
    }
    return false;
  }
};

// What the run's bus does to its LCM connections (common/bus.cpp): without it, each message
// paced by a reply waits for delayed acknowledgements.
void no_delay(lcm::LCM& lcm) {
  const int one = 1;
  ASSERT_EQ(::setsockopt(lcm.getFileno(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one), 0);
}

std::vector<std::uint8_t> payload(std::size_t i, std::size_t size) {
  std::vector<std::uint8_t> p(size);
  for (std::size_t k = 0; k < size; ++k) p[k] = static_cast<std::uint8_t>((i * 131 + k * 7) & 0xff);
  for (std::size_t k = 0; k < 8 && k < size; ++k) p[k] = static_cast<std::uint8_t>(i >> (8 * k));
  return p;
}

}  // namespace

TEST(ChannelPattern, TakesNamesDotsAndDotStarAndRefusesTheRestOfRegex) {
  EXPECT_TRUE(ChannelPattern("hc1/STEP").matches("hc1/STEP"));
  EXPECT_FALSE(ChannelPattern("hc1/STEP").matches("hc1/STEPS"));
  EXPECT_FALSE(ChannelPattern("hc1/STEP").matches("hc1/STE"));
  EXPECT_FALSE(ChannelPattern("hc1/STEP").matches("xhc1/STEP"));
  EXPECT_TRUE(ChannelPattern(".*").matches(""));
  EXPECT_TRUE(ChannelPattern(".*").matches("anything/at/all"));
  EXPECT_TRUE(ChannelPattern("hc1/.*").matches("hc1/FLUID_STATE"));
  EXPECT_FALSE(ChannelPattern("hc1/.*").matches("hc2/FLUID_STATE"));
  EXPECT_TRUE(ChannelPattern("^a.c$").matches("abc"));
  EXPECT_FALSE(ChannelPattern("^a.c$").matches("abbc"));
  EXPECT_TRUE(ChannelPattern(".*_STATE").matches("hc1/FLUID_STATE"));
  EXPECT_FALSE(ChannelPattern(".*_STATE").matches("hc1/FLUID_STATES"));
  EXPECT_TRUE(ChannelPattern("a.*b.*c").matches("aXbYbZc"));
  EXPECT_FALSE(ChannelPattern("a.*b.*c").matches("aXcYb"));
  EXPECT_TRUE(ChannelPattern("a\\.b").matches("a.b"));
  EXPECT_FALSE(ChannelPattern("a\\.b").matches("aXb"));
  for (const char* refused : {"a|b", "[ab]", "(x)", "a+", "a?", "a{2}", "a*", "x\\"}) {
    EXPECT_FALSE(ChannelPattern(refused).valid()) << refused;
    EXPECT_FALSE(ChannelPattern(refused).matches("a")) << refused;
  }
}

TEST(Relay, ForwardsEachMessageOnlyToTheClientsSubscribedToItsChannel) {
  Relay relay({});
  Listener a(relay.url(), {"run/A", "a-sync"}), b(relay.url(), {"run/B", "b-sync"}), all(relay.url(), {".*"}),
      both(relay.url(), {"run/A", "run/.*"});
  for (auto [l, c] : {std::pair{&a, "a-sync"}, {&b, "b-sync"}, {&all, "all-sync"}, {&both, "run/sync"}}) settle(*l, c);

  lcm::LCM publisher(relay.url());
  const auto copies_before = relay.stats().forwarded;
  for (int i = 0; i < 20; ++i) publish(publisher, i % 2 ? "run/B" : "run/A", std::to_string(i));
  publish(publisher, "run/C", "c");
  auto of_run = [](Listener& l) { return l.count("run/A") + l.count("run/B") + l.count("run/C"); };
  // `both` hands run/A to each of its two handlers: LCM's client dispatches per subscription.
  ASSERT_TRUE(wait_for([&] { return of_run(all) == 21 && of_run(both) == 31; }))
      << of_run(all) << " " << of_run(both) << " " << relay.stats().str();
  ASSERT_TRUE(wait_for([&] { return a.count("run/A") == 10 && b.count("run/B") == 10; }));
  std::this_thread::sleep_for(200ms);  // nothing more comes
  EXPECT_EQ(a.count("run/A"), 10u);
  EXPECT_EQ(a.count(), a.count("run/A") + a.count("a-sync"));
  EXPECT_EQ(b.count("run/B"), 10u);
  EXPECT_EQ(b.count(), b.count("run/B") + b.count("b-sync"));
  EXPECT_EQ(all.count("run/C"), 1u);
  EXPECT_EQ(of_run(all), 21u);
  EXPECT_EQ(of_run(both), 31u);
  // One copy per subscribed client, however many of its subscriptions match (as lcm-java's
  // TCPService sends): a 10 + b 10 + all 21 + both 21.
  EXPECT_EQ(relay.stats().forwarded - copies_before, 62u);
  // In the order published.
  std::vector<std::string> order;
  for (const auto& [channel, bytes] : all.got())
    if (channel == "run/A" || channel == "run/B") order.emplace_back(bytes.begin(), bytes.end());
  ASSERT_EQ(order.size(), 20u);
  for (int i = 0; i < 20; ++i) EXPECT_EQ(order[static_cast<std::size_t>(i)], std::to_string(i));
}

TEST(Relay, UnsubscribedChannelIsNoLongerForwarded) {
  Relay relay({});
  Listener keep(relay.url(), {"run/X"});
  std::atomic<int> got{0};
  lcm::LCM leaver(relay.url());
  auto* sub = leaver.subscribeFunction(
      "run/X", +[](const lcm::ReceiveBuffer*, const std::string&, std::atomic<int>* n) { ++*n; }, &got);
  lcm::LCM publisher(relay.url());
  ASSERT_TRUE(wait_for([&] {
    publish(publisher, "run/X", "1");
    while (leaver.handleTimeout(10) > 0) {
    }
    return got > 0;
  }));
  leaver.unsubscribe(sub);
  publish(leaver, "run/X", "after unsubscribe");  // on the same connection: the relay has the unsubscribe first
  ASSERT_TRUE(wait_for([&] {
    const auto g = keep.got();
    return !g.empty() && std::string(g.back().second.begin(), g.back().second.end()) == "after unsubscribe";
  }));
  const int before = got;
  for (int i = 0; i < 50; ++i) EXPECT_LE(leaver.handleTimeout(2), 0);
  EXPECT_EQ(got, before);
}

TEST(Relay, ManyMessagesOfAllSizesArriveWholeAndInOrder) {
  Relay relay({});
  Listener sink(relay.url(), {"run/DATA", "sink-sync"});
  settle(sink, "sink-sync");
  sink.clear();
  lcm::LCM publisher(relay.url());
  const auto before = relay.stats();
  std::mt19937 rng(7);
  std::vector<std::size_t> sizes;
  std::size_t total = 0;
  for (std::size_t i = 0; i < 3000; ++i) {
    // Mostly small, some of a fluid state's size (several MB) and some empty.
    const std::size_t size = i % 500 == 3 ? (4u << 20) + i : i % 97 == 0 ? 0 : 8 + rng() % 70000;
    sizes.push_back(size);
    total += size;
    const auto p = payload(i, size);
    ASSERT_EQ(publisher.publish("run/DATA", p.data(), static_cast<unsigned>(p.size())), 0);
  }
  ASSERT_TRUE(wait_for([&] { return sink.count() == sizes.size(); }, 60)) << sink.count() << " of " << sizes.size();
  const auto got = sink.got();
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    ASSERT_EQ(got[i].second.size(), sizes[i]) << "message " << i;
    ASSERT_TRUE(got[i].second == payload(i, sizes[i])) << "message " << i << " differs or is out of order";
  }
  const auto s = relay.stats();
  EXPECT_EQ(s.published - before.published, sizes.size());
  EXPECT_EQ(s.forwarded - before.forwarded, sizes.size());
  EXPECT_EQ(s.dropped_slow, 0u);
  EXPECT_GT(total, 20u << 20);
}

TEST(Relay, ClientThatDisconnectsCostsOnlyItsOwnConnection) {
  Relay relay({});
  Listener stays(relay.url(), {"run/S", "stays-sync"});
  settle(stays, "stays-sync");
  stays.clear();
  lcm::LCM publisher(relay.url());
  {
    // Subscribed, then gone without unsubscribing, while messages for it are under way.
    auto leaver = std::make_unique<Listener>(relay.url(), std::vector<std::string>{"run/S", "leaver-sync"});
    settle(*leaver, "leaver-sync");
    for (int i = 0; i < 100; ++i) publish(publisher, "run/S", std::string(50000, 'x'));
    leaver.reset();
  }
  {
    // Gone in the middle of a message: the half frame is dropped with the connection.
    RawClient half(relay.port());
    half.send_words({kTcpqMagicClient, kTcpqVersion, kTcpqPublish, 5});
    half.send_text("run/S");
    half.send_words({1000});
    half.send_text("only part of it");
  }
  for (int i = 0; i < 100; ++i) publish(publisher, "run/S", "after " + std::to_string(i));
  ASSERT_TRUE(wait_for([&] { return stays.count() == 200; })) << stays.count();
  const auto got = stays.got();
  EXPECT_EQ(std::string(got.back().second.begin(), got.back().second.end()), "after 99");
  // The listener, the publisher: the others are gone.
  ASSERT_TRUE(wait_for([&] { return relay.stats().clients_connected == 2; })) << relay.stats().str();
  EXPECT_EQ(relay.stats().malformed, 0u);
}

TEST(Relay, MalformedInputClosesThatConnectionAndTheRelayGoesOn) {
  RelayOptions opt;
  opt.max_frame_bytes = 1 << 20;
  Relay relay(opt);
  Listener sink(relay.url(), {"run/M", "m-sync"});
  settle(sink, "m-sync");
  lcm::LCM publisher(relay.url());
  std::uint64_t malformed = 0;
  auto still_relays = [&](const std::string& what) {
    const auto before = sink.count("run/M");
    publish(publisher, "run/M", what);
    EXPECT_TRUE(wait_for([&] { return sink.count("run/M") == before + 1; })) << "after " << what;
  };
  auto expect_closed = [&](RawClient& c, const std::string& what) {
    EXPECT_TRUE(c.closed_by_peer()) << what;
    EXPECT_TRUE(wait_for([&] { return relay.stats().malformed == malformed + 1; })) << what;
    malformed = relay.stats().malformed;
    still_relays(what);
  };
  {
    RawClient c(relay.port());
    c.send_text("GET / HTTP/1.1\r\nHost: x\r\n\r\n");
    expect_closed(c, "an HTTP request");
  }
  {
    RawClient c(relay.port());
    c.send_words({kTcpqMagicClient, kTcpqVersion, 77, 3});
    expect_closed(c, "an unknown message type");
  }
  {
    RawClient c(relay.port());
    c.send_words({kTcpqMagicClient, kTcpqVersion, kTcpqPublish, 0xffffffffu});
    expect_closed(c, "a 4-GB channel name");
  }
  {
    RawClient c(relay.port());
    c.send_words({kTcpqMagicClient, kTcpqVersion, kTcpqSubscribe, 100000});
    expect_closed(c, "a 100-kB subscription");
  }
  {
    RawClient c(relay.port());
    c.send_words({kTcpqMagicClient, kTcpqVersion, kTcpqPublish, 5});
    c.send_text("run/M");
    c.send_words({0x7fffffffu});
    expect_closed(c, "a 2-GB message");
  }
  {
    std::mt19937 rng(3);
    RawClient c(relay.port());
    c.send_words({kTcpqMagicClient, kTcpqVersion});
    std::vector<std::uint8_t> junk(4096);
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng() | 0x80);  // never a valid type word
    c.send_bytes(junk);
    expect_closed(c, "random bytes");
  }
  {
    // A pattern the relay does not serve is refused, the connection kept.
    RawClient c(relay.port());
    c.send_words({kTcpqMagicClient, kTcpqVersion, kTcpqSubscribe, 5});
    c.send_text("(a|b)");
    EXPECT_TRUE(wait_for([&] { return relay.stats().refused_patterns == 1; }));
    EXPECT_FALSE(c.closed_by_peer(0.3));
    still_relays("a refused pattern");
  }
  EXPECT_EQ(relay.stats().malformed, 6u);
}

TEST(Relay, SlowClientLosesWholeMessagesAndOthersGetEverything) {
  RelayOptions opt;
  opt.max_queued_bytes = 1 << 20;
  Relay relay(opt);
  Listener fast(relay.url(), {"run/F", "fast-sync"});
  settle(fast, "fast-sync");
  fast.clear();
  // Subscribes and never reads: its socket buffers fill, then the relay's queue for it.
  RawClient slow(relay.port());
  const int small = 65536;  // small enough to fill; not so small that reading it back trickles
  ::setsockopt(slow.fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  slow.send_words({kTcpqMagicClient, kTcpqVersion, kTcpqSubscribe, 5});
  slow.send_text("run/F");
  ASSERT_TRUE(wait_for([&] { return relay.stats().subscriptions == 3; })) << relay.stats().str();
  lcm::LCM publisher(relay.url());
  no_delay(publisher);
  // Paced by the fast client, which then never falls behind: only the slow one can lose any.
  for (std::size_t i = 0; i < 200; ++i) {
    const auto p = payload(i, 100000);
    ASSERT_EQ(publisher.publish("run/F", p.data(), static_cast<unsigned>(p.size())), 0);
    ASSERT_TRUE(wait_for([&] { return fast.count() == i + 1; })) << fast.count() << " " << relay.stats().str();
  }
  EXPECT_GT(relay.stats().dropped_slow, 0u) << relay.stats().str();
  // What the slow client does get is whole frames: greeting, then publish frames that parse.
  timeval tv{1, 0};
  ::setsockopt(slow.fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  std::vector<std::uint8_t> in;
  std::uint8_t buf[65536];
  for (ssize_t n; (n = ::recv(slow.fd, buf, sizeof buf, 0)) > 0;) in.insert(in.end(), buf, buf + n);
  auto word = [&](std::size_t at) {
    return (std::uint32_t(in[at]) << 24) | (std::uint32_t(in[at + 1]) << 16) | (std::uint32_t(in[at + 2]) << 8) |
           in[at + 3];
  };
  ASSERT_GE(in.size(), 8u);
  EXPECT_EQ(word(0), kTcpqMagicServer);
  std::size_t at = 8, frames = 0;
  while (at < in.size()) {
    ASSERT_LE(at + 8, in.size());
    ASSERT_EQ(word(at), kTcpqPublish);
    ASSERT_EQ(word(at + 4), 5u);
    const std::size_t len = word(at + 13);
    ASSERT_LE(at + 17 + len, in.size()) << "a frame cut short";
    at += 17 + len;
    ++frames;
  }
  EXPECT_GT(frames, 0u);
  EXPECT_LT(frames, 200u);
}

TEST(Relay, ChannelsOutsideTheRunAreNotForwarded) {
  RelayOptions opt;
  opt.channel_prefix = "hc42/";
  Relay relay(opt);
  Listener all(relay.url(), {".*"});
  settle(all, "hc42/sync");
  all.clear();
  lcm::LCM publisher(relay.url());
  publish(publisher, "other/STEP", "no");
  publish(publisher, "hc42/STEP", "yes");
  ASSERT_TRUE(wait_for([&] { return all.count() == 1; }));
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(all.count(), 1u);
  EXPECT_EQ(all.got().at(0).first, "hc42/STEP");
  EXPECT_EQ(relay.stats().dropped_foreign, 1u);
}

TEST(Relay, RefusesAnAddressThatIsNotIpv4AndAPortInUse) {
  RelayOptions opt;
  opt.address = "localhost";
  try {
    Relay r(opt);
    FAIL() << "a host name was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not an IPv4 address"), std::string::npos) << e.what();
  }
  Relay first({});
  opt.address = "127.0.0.1";
  opt.port = first.port();
  try {
    Relay second(opt);
    FAIL() << "a port in use was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot listen on 127.0.0.1:"), std::string::npos) << e.what();
  }
}

TEST(Relay, LocalAddressTowardHostsSkipsLoopback) {
  EXPECT_EQ(local_address_toward({}), "127.0.0.1");
  EXPECT_EQ(local_address_toward({"127.0.0.1"}), "127.0.0.1");
  EXPECT_THROW(local_address_toward({"no-such-host.invalid"}), std::runtime_error);
}

// The run's bus over the relay: signed messages of the run arrive; forged and foreign ones are
// dropped by the receiving bus, exactly as on multicast (the relay itself checks nothing).
TEST(RelayBus, EnvelopeChecksStandOverTheRelay) {
  Relay relay({});
  RunContext ctx;
  ctx.run_id = "hcrelay1";
  ctx.lcm_url = relay.url();
  ctx.secret.assign(32, 5);
  Bus alice(ctx, "alice"), bob(ctx, "bob");
  // The subscriptions of bob's bus may still be on the way: publish until one arrives.
  std::vector<Received> got;
  step_order_t o{};
  o.time_s = 0.5;
  ASSERT_TRUE(wait_for([&] {
    alice.publish(channel::step, o, 4);
    bob.poll(0.05, [&](const Received& r) { got.push_back(r); });
    return !got.empty();
  }));
  EXPECT_EQ(got[0].envelope.sender, "alice");
  EXPECT_DOUBLE_EQ(got[0].as<step_order_t>().time_s, 0.5);
  const auto accepted = bob.counters().accepted;

  RunContext forger = ctx;
  forger.secret.assign(32, 6);
  Bus mallory(forger, "mallory");
  mallory.publish(channel::step, o, 5);  // signed with another key
  // Another run's message, signed with this run's key, on this run's channel.
  step_order_t foreign{};
  foreign.envelope.run_id = "hcother";
  foreign.envelope.sender = "stranger";
  foreign.envelope.seq = Bus::next_seq();
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(foreign.getEncodedSize()));
  foreign.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sign(buf, ctx.secret);
  lcm::LCM raw(relay.url());
  raw.publish(ctx.run_id + "/STEP", buf.data(), static_cast<unsigned>(buf.size()));
  const std::vector<std::uint8_t> junk{1, 2, 3};
  raw.publish(ctx.run_id + "/STEP", junk.data(), 3);
  ASSERT_TRUE(wait_for([&] {
    bob.poll(0.05, [&](const Received& r) { got.push_back(r); });
    const auto k = bob.counters();
    return k.rejected_auth == 1 && k.rejected_short == 1 && k.rejected_foreign == 1;
  })) << bob.counters().str();
  EXPECT_EQ(bob.counters().accepted, accepted);
}

TEST(RelayBus, BusRefusesInOneLineWhenNoRelayListens) {
  int port = 0;
  {
    Relay gone({});
    port = gone.port();
  }
  RunContext ctx;
  ctx.run_id = "hcnorelay";
  ctx.lcm_url = "tcpq://127.0.0.1:" + std::to_string(port);
  ctx.secret.assign(32, 5);
  const auto start = std::chrono::steady_clock::now();
  try {
    Bus bus(ctx, "alone");
    FAIL() << "a bus without its relay opened";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    EXPECT_NE(what.find("cannot reach the bus relay at 127.0.0.1:" + std::to_string(port)), std::string::npos) << what;
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, 15s);
}

// The start-up bus check over the relay: each process's heartbeat thread hears the others', and
// only those signed with the run's secret.
TEST(RelayBus, HeartbeatsOfTheBusCheckHearEachOtherOverTheRelay) {
  Relay relay({});
  RunContext ctx;
  ctx.run_id = "hcbeat";
  ctx.lcm_url = relay.url();
  ctx.secret.assign(32, 9);
  RunContext forger = ctx;
  forger.secret.assign(32, 8);
  Heartbeat coordinator(ctx, "coordinator", 0.1, {}, HeardReport{true, ""});
  Heartbeat fluid(ctx, "fluid", 0.1, {}, HeardReport{true, ""});
  Heartbeat particles(ctx, "particles", 0.1);
  Heartbeat impostor(forger, "impostor", 0.1);
  ASSERT_TRUE(wait_for([&] {
    return coordinator.heard() == std::set<std::string>{"fluid", "particles"} &&
           fluid.heard() == std::set<std::string>{"coordinator", "particles"};
  })) << coordinator.heard().size()
      << " " << fluid.heard().size();
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(coordinator.heard(), (std::set<std::string>{"fluid", "particles"}));  // never the impostor
}

// A run directory keeps the transport for `hemocosim resume`, and the relay's URL once it listens.
TEST(RelayBus, RunDirectoryKeepsTheTransportForResume) {
  const std::string path = "/tmp/hemo_relay_rundir_" + std::to_string(::getpid());
  std::filesystem::remove_all(path);
  const std::string scene = path + ".toml";
  std::ofstream(scene) << "# empty\n";
  auto [dir, ctx] = RunDirectory::create(path, scene);
  EXPECT_FALSE(RunDirectory::open(path).first.transport_recorded);
  HostPlacement h;
  h.transport = "tcp";
  h.relay_address = "10.0.0.7";
  h.relay_port = 7711;
  dir.record_transport(h);
  dir.record_bus_url("tcpq://10.0.0.7:7711");
  const auto [again, again_ctx] = RunDirectory::open(path);
  EXPECT_TRUE(again.transport_recorded);
  EXPECT_EQ(again.placement.transport, "tcp");
  EXPECT_EQ(again.placement.relay_address, "10.0.0.7");
  EXPECT_EQ(again.placement.relay_port, 7711);
  EXPECT_EQ(again_ctx.lcm_url, "tcpq://10.0.0.7:7711");
  EXPECT_EQ(again_ctx.run_id, ctx.run_id);
  std::filesystem::remove_all(path);
  std::filesystem::remove(scene);
}
