// SPDX-License-Identifier: GPL-3.0-or-later
#include "relay.h"

#include "bus_crypto.h"
#include "scene.h"

#include <hemo/fluid_state_t.hpp>
#include <hemo/mesh_t.hpp>
#include <hemo/particle_feedback_t.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace hemo {

namespace {
// LCM's UDP provider allows 63 characters; the tcpq provider has no bound, so a length word from
// the network must meet one here before anything is allocated for it.
constexpr std::uint32_t kMaxChannel = 255;
// Bounds the matching work one message can cost: subscriptions of a client, each at most
// kMaxChannel long (ChannelPattern is O(pattern × channel) at worst).
constexpr std::size_t kMaxSubscriptions = 64;
// Read at most this much from one client before serving the others.
constexpr std::size_t kReadBurst = std::size_t{16} << 20;
// What a client in its handshake may have sent and not yet been parsed: the handshake's frames
// are smaller; a stranger holds no more of the relay's memory than this.
constexpr std::size_t kMaxHandshakeInput = 4096;

using SteadyClock = std::chrono::steady_clock;

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}
void put_be32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

std::string errno_text() { return std::strerror(errno); }

using Frame = std::shared_ptr<const std::vector<std::uint8_t>>;

struct Client {
  int fd = -1;
  std::string peer;
  SteadyClock::time_point since;  // accepted
  std::vector<std::uint8_t> in;   // received, not yet parsed from in_pos on
  std::size_t in_pos = 0;
  bool greeted = false;        // the client's magic word and version have arrived
  Bytes nonce;                 // the handshake's challenge, once sent
  bool authenticated = false;  // the handshake's answer verified: served from then on
  std::vector<ChannelPattern> subscriptions;
  std::deque<std::pair<Frame, std::size_t>> out;  // frames to send, and how much of the first went
  std::size_t queued = 0;                         // bytes in `out` not yet sent
  bool closed = false;
};
}  // namespace

ChannelPattern::ChannelPattern(const std::string& pattern) : text_(pattern) {
  std::size_t i = 0, end = pattern.size();
  if (i < end && pattern[i] == '^') ++i;
  if (end > i && pattern[end - 1] == '$' && (end < 2 || pattern[end - 2] != '\\')) --end;
  for (; i < end; ++i) {
    const char c = pattern[i];
    if (c == '\\') {
      if (++i == end) {
        valid_ = false;
        return;
      }
      tokens_.push_back({Kind::literal, pattern[i]});
    } else if (c == '.') {
      if (i + 1 < end && pattern[i + 1] == '*') {
        ++i;
        if (tokens_.empty() || tokens_.back().kind != Kind::any_run) tokens_.push_back({Kind::any_run, 0});
      } else {
        tokens_.push_back({Kind::any_one, 0});
      }
    } else if (std::strchr("[](){}|*+?^$", c) != nullptr) {
      valid_ = false;
      return;
    } else {
      tokens_.push_back({Kind::literal, c});
    }
  }
}

// Wildcard matching with one backtrack point (the last `.*`): each `.*` only ever needs to
// stretch, so the work is bounded by pattern × channel without recursion.
bool ChannelPattern::matches(const std::string& channel) const {
  if (!valid_) return false;
  std::size_t t = 0, c = 0;
  std::size_t star = std::string::npos, star_c = 0;
  while (c < channel.size()) {
    if (t < tokens_.size() && tokens_[t].kind == Kind::any_run) {
      star = t++;
      star_c = c;
    } else if (t < tokens_.size() &&
               (tokens_[t].kind == Kind::any_one || (tokens_[t].kind == Kind::literal && tokens_[t].c == channel[c]))) {
      ++t;
      ++c;
    } else if (star != std::string::npos) {
      t = star + 1;
      c = ++star_c;
    } else {
      return false;
    }
  }
  while (t < tokens_.size() && tokens_[t].kind == Kind::any_run) ++t;
  return t == tokens_.size();
}

std::string RelayStats::str() const {
  return fmt::format(
      "{} clients ({} authenticated, {} now), {} messages in, {} copies out ({:.1f} MB), at most {:.1f} MB held; "
      "dropped: other channels {}; disconnected: slow {}, malformed {}, failed handshake {}, no handshake in time {}, "
      "evicted in handshake {}, over the client limit {}; refused subscriptions {}",
      clients_accepted, authenticated, clients_connected, published, forwarded, bytes_forwarded / 1e6,
      peak_held_bytes / 1e6, dropped_foreign, slow_clients, malformed, refused_auth, handshake_timeouts,
      evicted_pending, refused_clients, refused_patterns);
}

void RelayOptions::sized_for(std::size_t largest_message) {
  max_frame_bytes = std::max(std::size_t{1} << 20, 2 * largest_message);
  max_queued_bytes = std::max(std::size_t{16} << 20, 8 * max_frame_bytes);
  max_held_bytes = std::max(std::size_t{64} << 20, 4 * max_queued_bytes);
}

// The sizes as LCM encodes them (from the array lengths alone: nothing is allocated), with an
// envelope of long names, plus what sealing adds.
std::size_t largest_bus_message(const Scene& scene) {
  const auto& m = scene.mesh;
  const std::int32_t cells = m.cells();
  // The O-grid's cross-section is a planar graph of V points, E edges and F cells (V - E + F = 1);
  // the mesh is it extruded over axial_cells layers: points on every plane, a side face per edge
  // and layer, an end face per cell and plane, four points a face.
  const std::int32_t section_cells = cells / std::max(1, m.axial_cells);
  const std::int32_t section_points = (m.core_cells + 1) * (m.core_cells + 1) + 4 * m.core_cells * m.ring_cells;
  const std::int32_t section_edges = section_points + section_cells - 1;
  mesh_t mesh{};
  mesh.n_points = section_points * (m.axial_cells + 1);
  mesh.n_faces = section_edges * m.axial_cells + section_cells * (m.axial_cells + 1);
  mesh.n_face_points = 4 * mesh.n_faces;
  mesh.n_internal_faces = mesh.n_faces;  // at most
  mesh.n_cells = cells;
  mesh.mesh_hash = std::string(64, 'x');
  mesh.n_patches = 3;
  mesh.patch_names.assign(3, std::string(64, 'x'));
  mesh.patch_types.assign(3, std::string(16, 'x'));
  fluid_state_t state{};
  state.mesh_hash = std::string(64, 'x');
  state.n_cells = cells;
  state.n_velocity_values = 3 * cells;
  state.n_gradient_values = 9 * cells;
  state.n_pressure_gradient_values = 3 * cells;
  particle_feedback_t feedback{};
  feedback.mesh_hash = state.mesh_hash;
  feedback.n_cells = cells;
  feedback.n_source_values = 3 * cells;
  for (auto* e : {&mesh.envelope, &state.envelope, &feedback.envelope}) {
    e->run_id = std::string(64, 'x');
    e->sender = std::string(64, 'x');
  }
  const int largest = std::max({mesh.getEncodedSize(), state.getEncodedSize(), feedback.getEncodedSize()});
  return static_cast<std::size_t>(largest) + kSealOverhead;
}

// Why the relay ends a connection; each is counted (RelayStats).
enum class Ending { gone, slow, malformed, refused_auth, handshake_timeout, evicted, over_limit };

struct Relay::Impl {
  int listen_fd = -1;
  int wake[2] = {-1, -1};  // a byte in wake[1] stops the thread
  std::thread thread;
  mutable std::mutex stats_mutex;
  RelayStats stats;
  Bytes handshake_key;
  std::vector<std::unique_ptr<Client>> clients;
  std::vector<std::uint8_t> chunk = std::vector<std::uint8_t>(std::size_t{256} << 10);  // recv's buffer

  template <class F>
  void count(F&& f) {
    std::lock_guard<std::mutex> lock(stats_mutex);
    f(stats);
  }

  // What the relay holds for its clients now: queued copies and unparsed input.
  std::size_t held() const {
    std::size_t n = 0;
    for (const auto& c : clients) n += c->queued + (c->in.size() - c->in_pos);
    return n;
  }
  void note_held() {
    const std::size_t now = held();
    count([&](RelayStats& s) {
      s.held_bytes = now;
      s.peak_held_bytes = std::max<std::uint64_t>(s.peak_held_bytes, now);
    });
  }

  void close_client(Client& c, Ending why, const std::string& detail = {}) {
    if (c.closed) return;
    if (why != Ending::gone)
      spdlog::warn("bus relay: closed the connection of {}: {}", c.peer, detail);
    count([&](RelayStats& s) {
      switch (why) {
        case Ending::gone: break;
        case Ending::slow: ++s.slow_clients; break;
        case Ending::malformed: ++s.malformed; break;
        case Ending::refused_auth: ++s.refused_auth; break;
        case Ending::handshake_timeout: ++s.handshake_timeouts; break;
        case Ending::evicted: ++s.evicted_pending; break;
        case Ending::over_limit: ++s.refused_clients; break;
      }
      --s.clients_connected;
      s.subscriptions -= c.subscriptions.size();
    });
    ::close(c.fd);
    c.closed = true;
    c.out.clear();
    c.queued = 0;
    c.in.clear();
    c.in.shrink_to_fit();
    c.in_pos = 0;
  }

  void flush(Client& c) {
    while (!c.closed && !c.out.empty()) {
      auto& [frame, sent] = c.out.front();
      const ssize_t n = ::send(c.fd, frame->data() + sent, frame->size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK) return;
        if (errno == EINTR) continue;
        return close_client(c, Ending::gone);  // the client went away
      }
      sent += static_cast<std::size_t>(n);
      c.queued -= static_cast<std::size_t>(n);
      if (sent == frame->size()) c.out.pop_front();
    }
  }

  void send_frame(Client& c, const Frame& frame) {
    c.out.emplace_back(frame, 0);
    c.queued += frame->size();
    note_held();
    flush(c);
  }

  // A client that cannot take a copy within the bounds is disconnected: buffering for it
  // without bound took the coordinator to gigabytes, and dropping copies for it while keeping
  // it connected left it a member that silently misses messages. Its process sees the bus end.
  void enqueue(Client& c, const Frame& frame, const RelayOptions& o) {
    if (c.queued > 0 && c.queued + frame->size() > o.max_queued_bytes)
      return close_client(c, Ending::slow,
                          fmt::format("it reads too slowly ({} bytes queued for it, at most {})", c.queued,
                                      o.max_queued_bytes));
    // Over the relay's whole bound: the clients furthest behind go first (this one too, if it is).
    while (held() + frame->size() > o.max_held_bytes) {
      Client* slowest = nullptr;
      for (auto& other : clients)
        if (!other->closed && other->queued > 0 && (!slowest || other->queued > slowest->queued))
          slowest = other.get();
      if (slowest == nullptr) break;  // what is held is frames being read, each within max_frame_bytes
      close_client(*slowest, Ending::slow,
                   fmt::format("the relay holds {} bytes, at most {}; this client was furthest behind", held(),
                               o.max_held_bytes));
      if (slowest == &c) return;
    }
    send_frame(c, frame);
    count([&](RelayStats& s) {
      ++s.forwarded;
      s.bytes_forwarded += frame->size();
    });
  }

  void forward(const std::string& channel, const Frame& frame, const RelayOptions& o) {
    count([](RelayStats& s) { ++s.published; });
    if (channel.compare(0, o.channel_prefix.size(), o.channel_prefix) != 0) {
      count([](RelayStats& s) { ++s.dropped_foreign; });
      return;
    }
    for (auto& c : clients) {
      if (c->closed || !c->authenticated) continue;
      for (const auto& p : c->subscriptions)
        if (p.matches(channel)) {
          enqueue(*c, frame, o);
          break;  // one copy per client, however many of its subscriptions match
        }
    }
  }

  static Frame publish_frame(const std::string& channel, const Bytes& data) {
    std::vector<std::uint8_t> f;
    put_be32(f, kTcpqPublish);
    put_be32(f, static_cast<std::uint32_t>(channel.size()));
    f.insert(f.end(), channel.begin(), channel.end());
    put_be32(f, static_cast<std::uint32_t>(data.size()));
    f.insert(f.end(), data.begin(), data.end());
    return std::make_shared<const std::vector<std::uint8_t>>(std::move(f));
  }

  // A frame of a client in its handshake: the subscription to the handshake channel (answered
  // by the challenge) and the answer to it, nothing else. False: the client is closed.
  bool handshake(Client& c, std::uint32_t type, const std::string& channel, const std::uint8_t* data, std::size_t len,
                 const RelayOptions& o) {
    if (channel != kRelayAuthChannel) {
      close_client(c, Ending::refused_auth,
                   fmt::format("it {} \"{}\" before proving it holds the run's secret (LCM's own tools cannot: "
                               "docs/hosts.md)",
                               type == kTcpqPublish ? "published on" : "asked for", channel));
      return false;
    }
    if (type == kTcpqUnsubscribe) return true;
    if (type == kTcpqSubscribe) {
      if (!c.nonce.empty()) {
        close_client(c, Ending::refused_auth, "it asked for a second challenge");
        return false;
      }
      c.nonce = random_bytes(kNonceBytes);
      Bytes challenge(1 + c.nonce.size());
      challenge[0] = kAuthChallenge;
      std::copy(c.nonce.begin(), c.nonce.end(), challenge.begin() + 1);
      send_frame(c, publish_frame(kRelayAuthChannel, challenge));
      return !c.closed;
    }
    const auto client_nonce = c.nonce.empty() ? std::nullopt : check_handshake_answer(handshake_key, c.nonce, data, len);
    if (!client_nonce) {
      close_client(c, Ending::refused_auth, "its handshake answer does not verify with the run's secret");
      return false;
    }
    int authenticated = 0;
    for (const auto& other : clients) authenticated += !other->closed && other->authenticated;
    if (authenticated >= o.max_clients) {
      close_client(c, Ending::over_limit, fmt::format("the relay serves at most {} clients", o.max_clients));
      return false;
    }
    c.authenticated = true;
    count([](RelayStats& s) { ++s.authenticated; });
    send_frame(c, publish_frame(kRelayAuthChannel, handshake_proof(handshake_key, c.nonce, *client_nonce)));
    return !c.closed;
  }

  // Parses every complete frame in the client's buffer. False: the client was closed.
  bool parse(Client& c, const RelayOptions& o) {
    auto malformed = [&](const std::string& why) {
      close_client(c, Ending::malformed, why);
      return false;
    };
    for (;;) {
      const std::uint8_t* p = c.in.data() + c.in_pos;
      const std::size_t avail = c.in.size() - c.in_pos;
      if (!c.greeted) {
        if (avail < 8) return true;
        if (be32(p) != kTcpqMagicClient)
          return malformed(fmt::format("not an LCM tcpq client (first word {:#010x})", be32(p)));
        c.greeted = true;
        c.in_pos += 8;
        continue;
      }
      if (avail < 8) return true;
      const std::uint32_t type = be32(p), len = be32(p + 4);
      if (type != kTcpqPublish && type != kTcpqSubscribe && type != kTcpqUnsubscribe)
        return malformed(fmt::format("unknown message type {}", type));
      if (len > kMaxChannel) return malformed(fmt::format("a channel of {} bytes (at most {})", len, kMaxChannel));
      if (type != kTcpqPublish) {
        if (avail < 8 + std::size_t{len}) return true;
        const std::string pattern(reinterpret_cast<const char*>(p + 8), len);
        c.in_pos += 8 + std::size_t{len};
        if (!c.authenticated) {
          if (!handshake(c, type, pattern, nullptr, 0, o)) return false;
        } else if (type == kTcpqSubscribe) {
          ChannelPattern sub(pattern);
          if (!sub.valid() || c.subscriptions.size() >= kMaxSubscriptions) {
            spdlog::warn("bus relay: refused the subscription \"{}\" of {} ({})", pattern, c.peer,
                         sub.valid() ? "too many subscriptions" : "only names, '.', '.*' and '\\' escapes are served");
            count([](RelayStats& s) { ++s.refused_patterns; });
          } else {
            c.subscriptions.push_back(std::move(sub));
            count([](RelayStats& s) { ++s.subscriptions; });
          }
        } else {
          for (auto it = c.subscriptions.begin(); it != c.subscriptions.end(); ++it)
            if (it->text() == pattern) {
              c.subscriptions.erase(it);
              count([](RelayStats& s) { --s.subscriptions; });
              break;
            }
        }
        continue;
      }
      const std::size_t head = 8 + std::size_t{len} + 4;
      if (avail < head) return true;
      const std::uint32_t data_len = be32(p + 8 + len);
      const std::size_t cap = c.authenticated ? o.max_frame_bytes : kMaxHandshakeInput;
      if (data_len > cap) {
        if (!c.authenticated) {
          close_client(c, Ending::refused_auth,
                       fmt::format("it sent a message of {} bytes before proving it holds the run's secret", data_len));
          return false;
        }
        return malformed(fmt::format("a message of {} bytes (at most {}, twice the run's largest)", data_len, cap));
      }
      const std::size_t total = head + data_len;
      // The rest of a large message is read as it comes: nothing is reserved on the strength of
      // a length word alone, which a client may never follow with the bytes.
      if (avail < total) return true;
      const std::string channel(reinterpret_cast<const char*>(p + 8), len);
      if (!c.authenticated) {
        c.in_pos += total;
        if (!handshake(c, type, channel, p + head, data_len, o)) return false;
        continue;
      }
      // The frame a subscriber gets is byte for byte the one published.
      auto frame = std::make_shared<const std::vector<std::uint8_t>>(p, p + total);
      c.in_pos += total;
      forward(channel, frame, o);
      if (c.closed) return false;  // over the bounds itself while forwarding
    }
  }

  void read_from(Client& c, const RelayOptions& o) {
    std::size_t got = 0;
    while (!c.closed && got < kReadBurst) {
      const ssize_t n = ::recv(c.fd, chunk.data(), chunk.size(), MSG_DONTWAIT);
      if (n == 0) return close_client(c, Ending::gone);  // the client ended its connection
      if (n < 0) {
        if (errno == EINTR) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK) return close_client(c, Ending::gone);
        break;
      }
      got += static_cast<std::size_t>(n);
      c.in.insert(c.in.end(), chunk.begin(), chunk.begin() + n);
      note_held();
      if (!parse(c, o)) return;
      if (c.in_pos == c.in.size()) {
        c.in.clear();
        c.in_pos = 0;
        if (c.in.capacity() > (std::size_t{1} << 20)) c.in.shrink_to_fit();  // a large message is through
      } else if (c.in_pos > (std::size_t{1} << 20) && c.in_pos * 2 > c.in.size()) {
        c.in.erase(c.in.begin(), c.in.begin() + static_cast<std::ptrdiff_t>(c.in_pos));
        c.in_pos = 0;
      }
      if (!c.authenticated && c.in.size() - c.in_pos > kMaxHandshakeInput)
        return close_client(c, Ending::refused_auth, "it sent more than a handshake before proving it holds the secret");
    }
  }

  void accept_clients(const RelayOptions& o) {
    for (;;) {
      sockaddr_in peer{};
      socklen_t peer_len = sizeof peer;
      const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&peer), &peer_len, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) return;  // EAGAIN: no more; anything else: try again on the next wake-up
      // Connections in their handshake are few and brief; the oldest makes room for this one, so
      // that strangers holding connections open cannot keep a node or the monitor out.
      std::vector<Client*> pending;
      for (auto& c : clients)
        if (!c->closed && !c->authenticated) pending.push_back(c.get());
      if (static_cast<int>(pending.size()) >= o.max_pending)
        close_client(*pending.front(), Ending::evicted, "a newer connection needed its place in the handshake");
      // LCM's client writes a message as five small sends: without this on both ends, Nagle's
      // algorithm holds the later ones for the peer's delayed acknowledgement.
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      auto c = std::make_unique<Client>();
      c->fd = fd;
      c->since = SteadyClock::now();
      char ip[INET_ADDRSTRLEN] = "?";
      ::inet_ntop(AF_INET, &peer.sin_addr, ip, sizeof ip);
      c->peer = fmt::format("{}:{}", ip, ntohs(peer.sin_port));
      count([](RelayStats& s) {
        ++s.clients_accepted;
        ++s.clients_connected;
      });
      std::vector<std::uint8_t> hello;
      put_be32(hello, kTcpqMagicServer);
      put_be32(hello, kTcpqVersion);
      send_frame(*c, std::make_shared<const std::vector<std::uint8_t>>(std::move(hello)));
      clients.push_back(std::move(c));
    }
  }

  // Ends the handshakes that took too long; the milliseconds until the next one would.
  int expire_handshakes(const RelayOptions& o) {
    const auto now = SteadyClock::now();
    const auto limit = std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(o.handshake_timeout_s));
    int wait_ms = -1;
    for (auto& c : clients) {
      if (c->closed || c->authenticated) continue;
      if (now - c->since >= limit) {
        close_client(*c, Ending::handshake_timeout,
                     fmt::format("no handshake within {:g} s (a process without the run's secret?)", o.handshake_timeout_s));
        continue;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(c->since + limit - now).count() + 1;
      wait_ms = wait_ms < 0 ? static_cast<int>(left) : std::min(wait_ms, static_cast<int>(left));
    }
    return wait_ms;
  }
};

Relay::Relay(RelayOptions options) : options_(std::move(options)), impl_(std::make_unique<Impl>()) {
  if (options_.secret.empty()) throw std::runtime_error("bus relay: started without the run's secret");
  impl_->handshake_key = handshake_key(options_.secret);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<std::uint16_t>(options_.port));
  if (options_.port < 0 || options_.port > 65535 || ::inet_pton(AF_INET, options_.address.c_str(), &sa.sin_addr) != 1)
    throw std::runtime_error(fmt::format("bus relay: \"{}:{}\" is not an IPv4 address and port (LCM's tcpq needs one)",
                                         options_.address, options_.port));
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error("bus relay: cannot open a socket: " + errno_text());
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0 || ::listen(fd, 64) != 0) {
    const std::string why = errno_text();
    ::close(fd);
    throw std::runtime_error(
        fmt::format("bus relay: cannot listen on {}:{}: {}", options_.address, options_.port, why));
  }
  socklen_t len = sizeof sa;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&sa), &len);
  port_ = ntohs(sa.sin_port);
  impl_->listen_fd = fd;
  if (::pipe2(impl_->wake, O_CLOEXEC | O_NONBLOCK) != 0) {
    ::close(fd);
    throw std::runtime_error("bus relay: cannot make a pipe: " + errno_text());
  }
  impl_->thread = std::thread([this] { serve(); });
}

Relay::~Relay() {
  const char stop = 1;
  [[maybe_unused]] const auto n = ::write(impl_->wake[1], &stop, 1);
  if (impl_->thread.joinable()) impl_->thread.join();
  for (auto& c : impl_->clients) impl_->close_client(*c, Ending::gone);
  ::close(impl_->listen_fd);
  ::close(impl_->wake[0]);
  ::close(impl_->wake[1]);
}

std::string Relay::url() const { return fmt::format("tcpq://{}:{}", options_.address, port_); }

RelayStats Relay::stats() const {
  std::lock_guard<std::mutex> lock(impl_->stats_mutex);
  return impl_->stats;
}

void Relay::serve() {
  auto& im = *impl_;
  std::vector<pollfd> fds;
  for (;;) {
    fds.clear();
    fds.push_back({im.wake[0], POLLIN, 0});
    fds.push_back({im.listen_fd, POLLIN, 0});
    for (const auto& c : im.clients)
      fds.push_back({c->fd, static_cast<short>(POLLIN | (c->out.empty() ? 0 : POLLOUT)), 0});
    if (::poll(fds.data(), fds.size(), im.expire_handshakes(options_)) < 0) {
      if (errno == EINTR) continue;
      spdlog::error("bus relay: poll failed: {}", errno_text());
      return;
    }
    if (fds[0].revents != 0) return;
    // Clients accepted below are polled from the next round on; fds[i + 2] is clients[i].
    const std::size_t polled = fds.size() - 2;
    if (fds[1].revents & POLLIN) im.accept_clients(options_);
    for (std::size_t i = 0; i < polled; ++i) {
      Client& c = *im.clients[i];
      const short ev = fds[i + 2].revents;
      if (c.closed || ev == 0) continue;
      if (ev & (POLLIN | POLLHUP | POLLERR)) im.read_from(c, options_);
      if (!c.closed && (ev & POLLOUT)) im.flush(c);
    }
    im.note_held();
    im.clients.erase(std::remove_if(im.clients.begin(), im.clients.end(),
                                    [](const std::unique_ptr<Client>& c) { return c->closed; }),
                     im.clients.end());
  }
}

std::string local_address_toward(const std::vector<std::string>& hosts) {
  for (const auto& host : hosts) {
    addrinfo hints{};
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_DGRAM;
    addrinfo* found = nullptr;
    if (::getaddrinfo(host.c_str(), "9", &hints, &found) != 0 || found == nullptr)
      throw std::runtime_error(
          fmt::format("bus relay: cannot resolve host {} to an IPv4 address to choose the relay's address (give "
                      "hosts.relay_address)",
                      host));
    std::string local;
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    // A UDP "connection" sends nothing: it only asks the routing table for the source address.
    if (fd >= 0 && ::connect(fd, found->ai_addr, found->ai_addrlen) == 0) {
      sockaddr_in sa{};
      socklen_t len = sizeof sa;
      char ip[INET_ADDRSTRLEN] = "";
      if (::getsockname(fd, reinterpret_cast<sockaddr*>(&sa), &len) == 0 &&
          ::inet_ntop(AF_INET, &sa.sin_addr, ip, sizeof ip) != nullptr)
        local = ip;
    }
    if (fd >= 0) ::close(fd);
    ::freeaddrinfo(found);
    if (!local.empty() && local.rfind("127.", 0) != 0) return local;
  }
  return "127.0.0.1";
}

}  // namespace hemo
