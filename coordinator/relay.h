// The bus without multicast (docs/hosts.md, "Without multicast: the TCP transport"): LCM's
// `tcpq://host:port` provider connects every process to one server that hands each published
// message to every client subscribed to its channel. LCM ships that server only in Java; this is
// ours. The coordinator runs it in a thread for the length of a run; nodes, the monitor and
// `hemocosim restart` connect to it as LCM clients that make the relay's handshake first
// (common/wire.h, authenticate_to_relay).
//
// The relay serves only clients that prove they hold the run's secret (common/bus_crypto.h, the
// handshake), so a stranger on the network can neither read the run through it nor fill it; it
// bounds what it holds for slow or half-sent clients. It does not check the messages themselves:
// the run's HMAC, replay and run-id checks (common/bus.h) stand over it as they do on multicast.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace hemo {

// The tcpq wire protocol of LCM 1.3 (lcm/lcm_tcpq.c, lcm-java's TCPService), all integers
// 32-bit big-endian:
//   client -> server, once:  kTcpqMagicClient, version
//   server -> client, once:  kTcpqMagicServer, version
//   client -> server:        kTcpqPublish, channel length, channel, data length, data
//                            kTcpqSubscribe | kTcpqUnsubscribe, pattern length, pattern
//   server -> client:        kTcpqPublish, channel length, channel, data length, data
// A subscription is LCM's channel regular expression, matched against the whole channel.
inline constexpr std::uint32_t kTcpqMagicServer = 0x287617fa;
inline constexpr std::uint32_t kTcpqMagicClient = 0x287617fb;
inline constexpr std::uint32_t kTcpqVersion = 0x0100;
inline constexpr std::uint32_t kTcpqPublish = 1;
inline constexpr std::uint32_t kTcpqSubscribe = 2;
inline constexpr std::uint32_t kTcpqUnsubscribe = 3;

// A subscription pattern as the relay understands it: literal characters, `\x` for a literal x,
// `.` for any one character and `.*` for any run, with optional `^` and `$` at the ends. That is
// every pattern our processes, lcm-logger and lcm-spy send (channel names, ".*"); anything else
// (classes, alternation, groups, other repeats) is refused rather than run through a regex engine
// that a client could make backtrack for ever. `valid` is false for a refused pattern.
class ChannelPattern {
 public:
  explicit ChannelPattern(const std::string& pattern);
  bool valid() const { return valid_; }
  bool matches(const std::string& channel) const;
  const std::string& text() const { return text_; }

 private:
  enum class Kind { literal, any_one, any_run };
  struct Token {
    Kind kind;
    char c;
  };
  std::string text_;
  std::vector<Token> tokens_;
  bool valid_ = true;
};

struct RelayOptions {
  std::string address = "127.0.0.1";  // IPv4 address to listen on (LCM 1.3's tcpq takes no host names)
  int port = 0;                       // 0: a free port, chosen by the kernel
  // Only channels that begin with this are forwarded (the run's "<run-id>/"); empty: all.
  std::string channel_prefix;
  // The run's secret: a client is served only once it has proved that it holds it
  // (bus_crypto.h, the handshake). Required.
  std::vector<std::uint8_t> secret;
  // A publish larger than this is a malformed frame: near the run's largest message
  // (sized_for). LCM's tcpq sends a message as one frame, unfragmented.
  std::size_t max_frame_bytes = std::size_t{64} << 20;
  // Bytes queued for one client that reads too slowly: a client over it is disconnected (counted
  // in RelayStats::slow_clients), as is the slowest client when all clients' queues and half-
  // received frames together would pass max_held_bytes. Nothing is buffered without bound.
  std::size_t max_queued_bytes = std::size_t{64} << 20;
  std::size_t max_held_bytes = std::size_t{256} << 20;
  // Authenticated clients (a run has about ten connections: nodes, their heartbeats, the
  // coordinator's, a monitor, a `hemocosim restart`). Connections still in their handshake are
  // held apart, at most max_pending of them, each for at most handshake_timeout_s; a new one
  // takes the place of the oldest, so a crowd of strangers cannot keep a node out.
  int max_clients = 64;
  int max_pending = 16;
  double handshake_timeout_s = 5;

  // The limits for a run whose largest message (the mesh, the fluid state or the feedback) has
  // this many bytes: frames up to twice it, a client's queue up to eight of them.
  void sized_for(std::size_t largest_message);
};

// What the relay did, for its log line and the tests.
struct RelayStats {
  std::uint64_t clients_accepted = 0;
  std::uint64_t clients_connected = 0;  // now, authenticated or in their handshake
  std::uint64_t authenticated = 0;      // clients that proved they hold the secret
  std::uint64_t subscriptions = 0;      // now, over all clients
  std::uint64_t published = 0;          // publish frames received from authenticated clients
  std::uint64_t forwarded = 0;          // copies handed to subscribers
  std::uint64_t bytes_forwarded = 0;
  std::uint64_t dropped_foreign = 0;  // channel outside channel_prefix
  // Disconnected, each for one reason:
  std::uint64_t slow_clients = 0;      // queue over max_queued_bytes, or the slowest over max_held_bytes
  std::uint64_t malformed = 0;         // a bad tcpq greeting or frame
  std::uint64_t refused_auth = 0;      // a wrong handshake answer, or anything but the handshake before it
  std::uint64_t handshake_timeouts = 0;
  std::uint64_t evicted_pending = 0;   // in their handshake, made room for a newer connection
  std::uint64_t refused_clients = 0;   // authenticated over max_clients
  std::uint64_t refused_patterns = 0;  // subscriptions ChannelPattern does not take (the connection stays)
  // Bytes the relay holds for its clients: queued to send plus half-received frames; and the most
  // it ever held (the figure max_held_bytes bounds, up to one frame being read per client).
  std::uint64_t held_bytes = 0;
  std::uint64_t peak_held_bytes = 0;
  std::uint64_t turned_away() const {
    return slow_clients + malformed + refused_auth + handshake_timeouts + evicted_pending + refused_clients;
  }
  std::string str() const;  // one line
};

class Relay {
 public:
  // Listens at once (so that clients may connect as soon as this returns) and serves from a
  // thread of its own. Throws std::runtime_error with one line when it cannot listen.
  explicit Relay(RelayOptions options);
  ~Relay();  // stops: closes every connection (clients see the bus end)
  Relay(const Relay&) = delete;
  Relay& operator=(const Relay&) = delete;

  int port() const { return port_; }
  const std::string& address() const { return options_.address; }
  std::string url() const;  // tcpq://address:port
  RelayStats stats() const;

 private:
  struct Impl;
  void serve();

  RelayOptions options_;
  int port_ = 0;
  std::unique_ptr<Impl> impl_;
};

// The largest message of a run of this scene, in bytes as encoded: the mesh (its O-grid's points,
// faces and cells), the fluid state (15 doubles a cell) or the particles' feedback (5 a cell).
struct Scene;
std::size_t largest_bus_message(const Scene& scene);

// The IPv4 address of this host that the given hosts reach it by: the source address the
// routing table picks toward each host, the first that is not a loopback address; 127.0.0.1 when
// there are no hosts or every one is this host. Throws one line naming a host it cannot resolve.
std::string local_address_toward(const std::vector<std::string>& hosts);

}  // namespace hemo
