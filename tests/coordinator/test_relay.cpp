// The bus relay of the TCP transport (coordinator/relay.h) with real sockets and real LCM clients
// (Debian's liblcm, `tcpq://` provider) in threads: subscriptions are honoured, many messages
// arrive whole and in order, a client that goes away or sends garbage costs only its own
// connection, only holders of the run's secret are served, what the relay holds stays bounded,
// and the run's envelope checks stand over it.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "bus.h"
#include "bus_crypto.h"
#include "relay.h"
#include "run_directory.h"
#include "scene.h"
#include "vessel_mesh.h"

#include <hemo/fluid_state_t.hpp>
#include <hemo/mesh_t.hpp>
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
#include <iterator>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <thread>

using namespace hemo;
using namespace std::chrono_literals;

namespace {

const Bytes& secret() {
  static const Bytes s(32, 0x5a);
  return s;
}

// A relay's options for a run of secret().
RelayOptions options() {
  RelayOptions o;
  o.secret = secret();
  return o;
}

// An LCM client of the relay that has done the handshake.
struct Client : lcm::LCM {
  explicit Client(const std::string& url) : lcm::LCM(url) { authenticate_to_relay(*this, secret(), url); }
};

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
  // With `key` empty, a stranger: subscribes without the handshake.
  Listener(const std::string& url, const std::vector<std::string>& patterns, const Bytes& key = secret()) : lcm_(url) {
    if (!key.empty()) authenticate_to_relay(lcm_, key, url);
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
        // LCM's client selects on its socket even when the connection ended (-1: an abort).
        if (lcm_.getFileno() < 0 || lcm_.handleTimeout(20) < 0) {
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
  // Sends up to `n` bytes, until the relay ends the connection; how many went.
  std::size_t send_until_refused(std::size_t n) {
    const Bytes block(65536, 7);
    std::size_t sent = 0;
    while (sent < n) {
      const ssize_t k = ::send(fd, block.data(), std::min(block.size(), n - sent), MSG_NOSIGNAL);
      if (k <= 0) break;
      sent += static_cast<std::size_t>(k);
    }
    return sent;
  }
  void send_frame(std::uint32_t type, const std::string& channel, const Bytes* data = nullptr) {
    send_words({type, static_cast<std::uint32_t>(channel.size())});
    send_text(channel);
    if (data) {
      send_words({static_cast<std::uint32_t>(data->size())});
      send_bytes(*data);
    }
  }
  // Exactly n bytes, or fewer when the connection ends or nothing comes for 2 s.
  Bytes read_bytes(std::size_t n) {
    timeval tv{2, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    Bytes b(n);
    std::size_t got = 0;
    while (got < n) {
      const ssize_t k = ::recv(fd, b.data() + got, n - got, 0);
      if (k <= 0) break;
      got += static_cast<std::size_t>(k);
    }
    b.resize(got);
    return b;
  }
  std::uint32_t read_word() {
    const auto b = read_bytes(4);
    if (b.size() < 4) return 0;
    return (std::uint32_t(b[0]) << 24) | (std::uint32_t(b[1]) << 16) | (std::uint32_t(b[2]) << 8) | b[3];
  }
  // A publish frame from the relay: its channel and data (empty channel: none came).
  std::pair<std::string, Bytes> read_publish() {
    if (read_word() != kTcpqPublish) return {};
    const auto channel = read_bytes(read_word());
    return {std::string(channel.begin(), channel.end()), read_bytes(read_word())};
  }
  // The greeting both ways: true when the relay answered as a tcpq server.
  bool greet() {
    send_words({kTcpqMagicClient, kTcpqVersion});
    return read_word() == kTcpqMagicServer && read_word() == kTcpqVersion;
  }
  // Asks for the handshake's challenge: the relay's nonce.
  Bytes challenge() {
    send_frame(kTcpqSubscribe, kRelayAuthChannel);
    const auto [channel, data] = read_publish();
    EXPECT_EQ(channel, kRelayAuthChannel);
    EXPECT_EQ(data.size(), 1 + kNonceBytes);
    if (data.size() != 1 + kNonceBytes) return {};
    return Bytes(data.begin() + 1, data.end());
  }
  // The whole handshake with `key`: the answer sent (what an eavesdropper would record).
  Bytes authenticate(const Bytes& key = secret()) {
    EXPECT_TRUE(greet());
    const Bytes answer = handshake_answer(handshake_key(key), challenge(), random_bytes(kNonceBytes));
    send_frame(kTcpqPublish, kRelayAuthChannel, &answer);
    return answer;
  }
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
  Relay relay(options());
  Listener a(relay.url(), {"run/A", "a-sync"}), b(relay.url(), {"run/B", "b-sync"}), all(relay.url(), {".*"}),
      both(relay.url(), {"run/A", "run/.*"});
  for (auto [l, c] : {std::pair{&a, "a-sync"}, {&b, "b-sync"}, {&all, "all-sync"}, {&both, "run/sync"}}) settle(*l, c);

  Client publisher(relay.url());
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
  Relay relay(options());
  Listener keep(relay.url(), {"run/X"});
  std::atomic<int> got{0};
  Client leaver(relay.url());
  auto* sub = leaver.subscribeFunction(
      "run/X", +[](const lcm::ReceiveBuffer*, const std::string&, std::atomic<int>* n) { ++*n; }, &got);
  Client publisher(relay.url());
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
  Relay relay(options());
  Listener sink(relay.url(), {"run/DATA", "sink-sync"});
  settle(sink, "sink-sync");
  sink.clear();
  Client publisher(relay.url());
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
  EXPECT_EQ(s.slow_clients, 0u);
  EXPECT_GT(total, 20u << 20);
}

TEST(Relay, ClientThatDisconnectsCostsOnlyItsOwnConnection) {
  Relay relay(options());
  Listener stays(relay.url(), {"run/S", "stays-sync"});
  settle(stays, "stays-sync");
  stays.clear();
  Client publisher(relay.url());
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
    half.authenticate();
    half.send_words({kTcpqPublish, 5});
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
  RelayOptions opt = options();
  opt.max_frame_bytes = 1 << 20;
  Relay relay(opt);
  Listener sink(relay.url(), {"run/M", "m-sync"});
  settle(sink, "m-sync");
  Client publisher(relay.url());
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
    c.authenticate();
    c.send_words({77, 3});
    expect_closed(c, "an unknown message type");
  }
  {
    RawClient c(relay.port());
    c.authenticate();
    c.send_words({kTcpqPublish, 0xffffffffu});
    expect_closed(c, "a 4-GB channel name");
  }
  {
    RawClient c(relay.port());
    c.authenticate();
    c.send_words({kTcpqSubscribe, 100000});
    expect_closed(c, "a 100-kB subscription");
  }
  {
    RawClient c(relay.port());
    c.authenticate();
    c.send_words({kTcpqPublish, 5});
    c.send_text("run/M");
    c.send_words({0x7fffffffu});
    expect_closed(c, "a 2-GB message");
  }
  {
    std::mt19937 rng(3);
    RawClient c(relay.port());
    c.authenticate();
    std::vector<std::uint8_t> junk(4096);
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng() | 0x80);  // never a valid type word
    c.send_bytes(junk);
    expect_closed(c, "random bytes");
  }
  {
    // A pattern the relay does not serve is refused, the connection kept.
    RawClient c(relay.port());
    c.authenticate();
    c.send_words({kTcpqSubscribe, 5});
    c.send_text("(a|b)");
    EXPECT_TRUE(wait_for([&] { return relay.stats().refused_patterns == 1; }));
    EXPECT_FALSE(c.closed_by_peer(0.3));
    still_relays("a refused pattern");
  }
  EXPECT_EQ(relay.stats().malformed, 6u);
}

// A reader that falls behind is disconnected, whether over its own queue's bound or the relay's
// whole one, by the relay's own accounting: four readers that never read cost the relay about
// its bound, not what was published to them (80 MB here; on main they took it to 2.1 GB).
TEST(Relay, SlowReadersAreDisconnectedAndWhatTheRelayHoldsStaysBounded) {
  for (const bool whole_bound : {false, true}) {
    SCOPED_TRACE(whole_bound ? "over the relay's bound" : "over a client's bound");
    RelayOptions opt = options();
    opt.max_queued_bytes = whole_bound ? 8 << 20 : 1 << 20;
    opt.max_held_bytes = whole_bound ? 3 << 20 : 64 << 20;
    Relay relay(opt);
    Listener fast(relay.url(), {"run/F", "fast-sync"});
    settle(fast, "fast-sync");
    fast.clear();
    // Subscribed and never reading: their socket buffers fill, then the relay's queues for them.
    std::vector<std::unique_ptr<RawClient>> slow;
    for (int i = 0; i < 4; ++i) {
      slow.push_back(std::make_unique<RawClient>(relay.port()));
      const int small = 65536;
      ::setsockopt(slow.back()->fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
      slow.back()->authenticate();
      slow.back()->send_frame(kTcpqSubscribe, "run/F");
    }
    ASSERT_TRUE(wait_for([&] { return relay.stats().subscriptions == 6; })) << relay.stats().str();
    Client publisher(relay.url());
    no_delay(publisher);
    // Paced by the fast client, which then never falls behind: only the slow ones can be cut.
    for (std::size_t i = 0; i < 200; ++i) {
      const auto p = payload(i, 100000);
      ASSERT_EQ(publisher.publish("run/F", p.data(), static_cast<unsigned>(p.size())), 0);
      ASSERT_TRUE(wait_for([&] { return fast.count() == i + 1; })) << fast.count() << " " << relay.stats().str();
    }
    const auto s = relay.stats();
    EXPECT_EQ(s.slow_clients, 4u) << s.str();
    for (auto& c : slow) EXPECT_TRUE(c->closed_by_peer());
    // Held: the queues, and at most one read (256 kB) of the publisher's input beyond the bound.
    const std::size_t bound = whole_bound ? opt.max_held_bytes : 4 * (opt.max_queued_bytes + 100100);
    EXPECT_LE(s.peak_held_bytes, bound + (256u << 10)) << s.str();
    EXPECT_GT(s.peak_held_bytes, 1u << 20) << s.str();
    const auto got = fast.got();
    for (std::size_t i = 0; i < 200; ++i) ASSERT_TRUE(got[i].second == payload(i, 100000)) << i;
  }
}

TEST(Relay, ChannelsOutsideTheRunAreNotForwarded) {
  RelayOptions opt = options();
  opt.channel_prefix = "hc42/";
  Relay relay(opt);
  Listener all(relay.url(), {".*"});
  settle(all, "hc42/sync");
  all.clear();
  Client publisher(relay.url());
  publish(publisher, "other/STEP", "no");
  publish(publisher, "hc42/STEP", "yes");
  ASSERT_TRUE(wait_for([&] { return all.count() == 1; }));
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(all.count(), 1u);
  EXPECT_EQ(all.got().at(0).first, "hc42/STEP");
  EXPECT_EQ(relay.stats().dropped_foreign, 1u);
}

// Without the run's secret a client is served nothing: what it subscribes to never reaches it,
// what it publishes reaches no one, and the relay ends its connection.
TEST(RelayAuth, ClientWithoutTheSecretReceivesNothingAndCannotPublish) {
  Relay relay(options());
  Listener member(relay.url(), {"run/.*", "member-sync"});
  settle(member, "member-sync");
  member.clear();
  Listener stranger(relay.url(), {".*"}, Bytes{});  // LCM's stock client, as lcm-spy would be
  lcm::LCM stranger_publisher(relay.url());
  publish(stranger_publisher, "run/STEP", "forged by a stranger");
  Client publisher(relay.url());
  for (int i = 0; i < 20; ++i) publish(publisher, "run/STEP", "genuine " + std::to_string(i));
  ASSERT_TRUE(wait_for([&] { return member.count() == 20; })) << member.count();
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(stranger.count(), 0u);
  for (const auto& [channel, bytes] : member.got())
    EXPECT_EQ(std::string(bytes.begin(), bytes.end()).rfind("genuine", 0), 0u) << "the stranger's message came through";
  ASSERT_TRUE(wait_for([&] { return relay.stats().refused_auth == 2; })) << relay.stats().str();
  EXPECT_EQ(relay.stats().authenticated, 2u);
  EXPECT_EQ(relay.stats().published, 21u);  // member-sync and 20: the stranger's was never taken for a message
}

TEST(RelayAuth, WrongSecretIsRefusedAndTheClientSaysSoInOneLine) {
  Relay relay(options());
  lcm::LCM wrong(relay.url());
  try {
    authenticate_to_relay(wrong, Bytes(32, 0x5b), relay.url());
    FAIL() << "a client with another secret was let in";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    EXPECT_NE(what.find("closed the connection"), std::string::npos) << what;
  }
  EXPECT_EQ(relay.stats().refused_auth, 1u);
  EXPECT_EQ(relay.stats().authenticated, 0u);
  // The run's bus without the secret (no RUN_DIR/secret) does not open either.
  RunContext ctx;
  ctx.run_id = "run";
  ctx.lcm_url = relay.url();
  ctx.secret.assign(32, 0x11);
  EXPECT_THROW(Bus(ctx, "impostor"), std::runtime_error);
  EXPECT_EQ(relay.stats().refused_auth, 2u);
}

// An eavesdropper that recorded a whole handshake cannot replay its answer: each connection's
// challenge is fresh. A garbled answer, or one sent before any challenge, is refused too.
TEST(RelayAuth, ReplayedOrForgedHandshakeIsRefused) {
  Relay relay(options());
  RawClient genuine(relay.port());
  ASSERT_TRUE(genuine.greet());
  const Bytes first_challenge = genuine.challenge();
  const Bytes recorded = handshake_answer(handshake_key(secret()), first_challenge, random_bytes(kNonceBytes));
  genuine.send_frame(kTcpqPublish, kRelayAuthChannel, &recorded);
  const auto [channel, proof] = genuine.read_publish();
  ASSERT_EQ(channel, kRelayAuthChannel);
  ASSERT_EQ(proof.size(), 33u);
  EXPECT_EQ(proof[0], kAuthAccepted);
  ASSERT_TRUE(wait_for([&] { return relay.stats().authenticated == 1; }));

  RawClient replayer(relay.port());
  ASSERT_TRUE(replayer.greet());
  EXPECT_NE(replayer.challenge(), first_challenge);
  replayer.send_frame(kTcpqPublish, kRelayAuthChannel, &recorded);
  EXPECT_TRUE(replayer.closed_by_peer());

  RawClient garbler(relay.port());
  ASSERT_TRUE(garbler.greet());
  Bytes garbled = handshake_answer(handshake_key(secret()), garbler.challenge(), random_bytes(kNonceBytes));
  garbled.back() ^= 1;
  garbler.send_frame(kTcpqPublish, kRelayAuthChannel, &garbled);
  EXPECT_TRUE(garbler.closed_by_peer());

  RawClient early(relay.port());
  ASSERT_TRUE(early.greet());
  early.send_frame(kTcpqPublish, kRelayAuthChannel, &recorded);  // no challenge asked for
  EXPECT_TRUE(early.closed_by_peer());

  ASSERT_TRUE(wait_for([&] { return relay.stats().refused_auth == 3; })) << relay.stats().str();
  EXPECT_EQ(relay.stats().authenticated, 1u);
}

// Strangers cannot hold the relay's memory: nothing but a handshake is read from them, and a
// member's frame may not pass the run's largest message twice over (on main, three half-sent
// 1-GB frames took the coordinator to 1.6 GB).
TEST(RelayLimits, HalfSentHugeFramesCostTheRelayNothing) {
  RelayOptions opt = options();
  opt.sized_for(1 << 20);
  Relay relay(opt);
  EXPECT_EQ(opt.max_frame_bytes, 2u << 20);
  Listener sink(relay.url(), {"run/H", "h-sync"});
  settle(sink, "h-sync");
  std::vector<std::unique_ptr<RawClient>> clients;
  for (int i = 0; i < 3; ++i) {
    clients.push_back(std::make_unique<RawClient>(relay.port()));  // strangers
    clients.back()->send_words({kTcpqMagicClient, kTcpqVersion, kTcpqPublish, 5});
    clients.back()->send_text("run/H");
    clients.back()->send_words({1u << 30});
  }
  for (int i = 0; i < 3; ++i) {
    clients.push_back(std::make_unique<RawClient>(relay.port()));  // members, over the frame bound
    clients.back()->authenticate();
    clients.back()->send_words({kTcpqPublish, 5});
    clients.back()->send_text("run/H");
    clients.back()->send_words({1u << 30});
  }
  // Half of each frame follows, as far as the relay lets it: it ends the connection at the length.
  for (auto& c : clients) EXPECT_LT(c->send_until_refused(std::size_t{512} << 20), std::size_t{64} << 20);
  for (auto& c : clients) EXPECT_TRUE(c->closed_by_peer());
  const auto s = relay.stats();
  EXPECT_EQ(s.refused_auth, 3u) << s.str();
  EXPECT_EQ(s.malformed, 3u) << s.str();
  // At most what one read brought in with the length (256 kB) before it was refused.
  EXPECT_LE(s.peak_held_bytes, 256u << 10) << s.str();
  Client publisher(relay.url());
  publish(publisher, "run/H", "still relays");
  EXPECT_TRUE(wait_for([&] { return sink.count("run/H") == 1; }));
}

// Connections in their handshake are few and timed out, and a new one evicts the oldest: with
// every such place taken by strangers that never answer, the monitor and a restarted node still
// join the run (on main one client holding all 256 places kept them out and ended the run).
TEST(RelayLimits, MonitorAndRestartedNodeJoinWhileStrangersHoldEveryHandshakePlace) {
  RelayOptions opt = options();
  opt.max_pending = 4;
  opt.handshake_timeout_s = 30;  // longer than the test: only eviction makes room
  opt.channel_prefix = "hcslots/";
  Relay relay(opt);
  std::vector<std::unique_ptr<RawClient>> strangers;
  for (int i = 0; i < 12; ++i) {
    strangers.push_back(std::make_unique<RawClient>(relay.port()));
    strangers.back()->send_words({kTcpqMagicClient, kTcpqVersion});
  }
  ASSERT_TRUE(wait_for([&] { return relay.stats().clients_accepted == 12; }));
  EXPECT_EQ(relay.stats().clients_connected, 4u);
  RunContext ctx;
  ctx.run_id = "hcslots";
  ctx.lcm_url = relay.url();
  ctx.secret = secret();
  Bus monitor(ctx, "monitor");
  for (int i = 0; i < 12; ++i) {  // the strangers come back as fast as they are evicted
    strangers.push_back(std::make_unique<RawClient>(relay.port()));
    strangers.back()->send_words({kTcpqMagicClient, kTcpqVersion});
  }
  auto node = std::make_unique<Bus>(ctx, "particles");
  node.reset();  // the node dies and is started again
  for (int i = 0; i < 12; ++i) {
    strangers.push_back(std::make_unique<RawClient>(relay.port()));
    strangers.back()->send_words({kTcpqMagicClient, kTcpqVersion});
  }
  Bus restarted(ctx, "particles");
  step_order_t o{};
  o.time_s = 1.5;
  std::vector<Received> got;
  ASSERT_TRUE(wait_for([&] {
    restarted.publish(channel::step, o, 1);
    monitor.poll(0.05, [&](const Received& r) { got.push_back(r); });
    return !got.empty();
  }));
  EXPECT_EQ(got[0].envelope.sender, "particles");
  EXPECT_GE(relay.stats().evicted_pending, 30u) << relay.stats().str();
}

// The frame bound follows the run: largest_bus_message is no smaller than the fluid node's real
// mesh message and fluid state (with the pressure gradient) for the scene's mesh, and not much
// larger, from the paper's 1,536 cells to 100,000.
TEST(RelayLimits, LargestMessageIsTheRunsRealLargestWithLittleMargin) {
  for (const MeshSpec& spec : {MeshSpec{4, 3, 24}, MeshSpec{10, 6, 100}, MeshSpec{20, 10, 125}}) {
    Scene scene;
    scene.vessel.diameter = 100e-6;
    scene.vessel.length = 600e-6;
    scene.mesh = spec;
    const auto poly = make_vessel_mesh(scene.vessel, spec);
    mesh_t mesh{};
    fill_mesh_message(poly, compute_geometry(poly), scene.vessel, mesh);
    mesh.envelope.run_id = "hc0123456789";
    mesh.envelope.sender = "fluid";
    fluid_state_t state{};
    state.mesh_hash = mesh.mesh_hash;
    state.n_cells = spec.cells();
    state.n_velocity_values = state.n_pressure_gradient_values = 3 * spec.cells();
    state.n_gradient_values = 9 * spec.cells();
    state.envelope = mesh.envelope;
    const auto real = static_cast<std::size_t>(std::max(mesh.getEncodedSize(), state.getEncodedSize()));
    const auto bound = largest_bus_message(scene);
    SCOPED_TRACE(std::to_string(spec.cells()) + " cells, real " + std::to_string(real));
    EXPECT_GE(bound, real + kSealOverhead);
    EXPECT_LE(bound, real + real / 4 + 1024);
    RelayOptions o;
    o.sized_for(bound);
    EXPECT_GE(o.max_frame_bytes, 2 * bound);
  }
}

TEST(RelayLimits, HandshakeNotMadeInTimeEndsTheConnection) {
  RelayOptions opt = options();
  opt.handshake_timeout_s = 0.3;
  Relay relay(opt);
  RawClient silent(relay.port());
  ASSERT_TRUE(silent.greet());
  EXPECT_TRUE(silent.closed_by_peer(3));
  EXPECT_EQ(relay.stats().handshake_timeouts, 1u);
  Client member(relay.url());  // a handshake done in time stays
  std::this_thread::sleep_for(600ms);
  EXPECT_EQ(relay.stats().clients_connected, 1u);
}

TEST(Relay, RefusesAnAddressThatIsNotIpv4AndAPortInUse) {
  RelayOptions opt = options();
  opt.address = "localhost";
  try {
    Relay r(opt);
    FAIL() << "a host name was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not an IPv4 address"), std::string::npos) << e.what();
  }
  Relay first(options());
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
// dropped by the receiving bus, exactly as on multicast (the relay checks who connects, not what
// they send).
TEST(RelayBus, EnvelopeChecksStandOverTheRelay) {
  Relay relay(options());
  RunContext ctx;
  ctx.run_id = "hcrelay1";
  ctx.lcm_url = relay.url();
  ctx.secret = secret();
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

  // A member of the relay (it holds the relay's secret) publishing what it signed with another
  // key: the relay forwards it, the bus drops it.
  Client raw(relay.url());
  step_order_t forged{};
  forged.envelope.run_id = ctx.run_id;
  forged.envelope.sender = "mallory";
  forged.envelope.seq = Bus::next_seq();
  std::vector<std::uint8_t> forged_buf(static_cast<std::size_t>(forged.getEncodedSize()));
  forged.encode(forged_buf.data(), 0, static_cast<int>(forged_buf.size()));
  sign(forged_buf, Bytes(32, 6));
  raw.publish(ctx.run_id + "/STEP", forged_buf.data(), static_cast<unsigned>(forged_buf.size()));
  // Another run's message, signed with this run's key, on this run's channel.
  step_order_t foreign{};
  foreign.envelope.run_id = "hcother";
  foreign.envelope.sender = "stranger";
  foreign.envelope.seq = Bus::next_seq();
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(foreign.getEncodedSize()));
  foreign.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sign(buf, ctx.secret);
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
    Relay gone(options());
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

// The start-up bus check over the relay: each process's heartbeat thread hears the others'; one
// without the run's secret is not even let in.
TEST(RelayBus, HeartbeatsOfTheBusCheckHearEachOtherOverTheRelay) {
  Relay relay(options());
  RunContext ctx;
  ctx.run_id = "hcbeat";
  ctx.lcm_url = relay.url();
  ctx.secret = secret();
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
  h.transport = Transport::tcp;
  h.relay_address = "10.0.0.7";
  h.relay_port = 7711;
  dir.record_transport(h);
  dir.record_bus_url("tcpq://10.0.0.7:7711");
  const auto [again, again_ctx] = RunDirectory::open(path);
  EXPECT_TRUE(again.transport_recorded);
  EXPECT_EQ(again.placement.transport, Transport::tcp);
  EXPECT_EQ(again.placement.relay_address, "10.0.0.7");
  EXPECT_EQ(again.placement.relay_port, 7711);
  EXPECT_EQ(again_ctx.lcm_url, "tcpq://10.0.0.7:7711");
  EXPECT_EQ(again_ctx.run_id, ctx.run_id);

  // A run.toml naming a transport there is none of is refused in one line naming the known ones.
  std::string info;
  {
    std::ifstream in(path + "/run.toml");
    info.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto at = info.find("transport = 'tcp'");
  ASSERT_NE(at, std::string::npos) << info;
  info.replace(at, 17, "transport = 'udp'");
  std::ofstream(path + "/run.toml") << info;
  try {
    RunDirectory::open(path);
    ADD_FAILURE() << "a run.toml with transport 'udp' was opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("hosts.transport 'udp' is none of multicast, tcp"), std::string::npos)
        << e.what();
  }
  std::filesystem::remove_all(path);
  std::filesystem::remove(scene);
}
