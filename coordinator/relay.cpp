// SPDX-License-Identifier: GPL-3.0-or-later
#include "relay.h"

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
  std::vector<std::uint8_t> in;  // received, not yet parsed from in_pos on
  std::size_t in_pos = 0;
  bool greeted = false;  // the client's magic word and version have arrived
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
      "{} clients ({} now), {} messages in, {} copies out ({:.1f} MB); dropped: other channels {}, slow clients {}; "
      "malformed clients {}, refused subscriptions {}, refused clients {}",
      clients_accepted, clients_connected, published, forwarded, bytes_forwarded / 1e6, dropped_foreign, dropped_slow,
      malformed, refused_patterns, refused_clients);
}

struct Relay::Impl {
  int listen_fd = -1;
  int wake[2] = {-1, -1};  // a byte in wake[1] stops the thread
  std::thread thread;
  mutable std::mutex stats_mutex;
  RelayStats stats;
  std::vector<std::unique_ptr<Client>> clients;
  std::vector<std::uint8_t> chunk = std::vector<std::uint8_t>(std::size_t{256} << 10);  // recv's buffer

  template <class F>
  void count(F&& f) {
    std::lock_guard<std::mutex> lock(stats_mutex);
    f(stats);
  }

  void close_client(Client& c, const std::string& malformed_reason = {}) {
    if (c.closed) return;
    if (!malformed_reason.empty()) {
      spdlog::warn("bus relay: closed the connection of {}: {}", c.peer, malformed_reason);
      count([](RelayStats& s) { ++s.malformed; });
    }
    ::close(c.fd);
    c.closed = true;
    c.out.clear();
    c.queued = 0;
    count([&](RelayStats& s) {
      --s.clients_connected;
      s.subscriptions -= c.subscriptions.size();
    });
  }

  void flush(Client& c) {
    while (!c.closed && !c.out.empty()) {
      auto& [frame, sent] = c.out.front();
      const ssize_t n = ::send(c.fd, frame->data() + sent, frame->size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK) return;
        if (errno == EINTR) continue;
        return close_client(c);  // the client went away
      }
      sent += static_cast<std::size_t>(n);
      c.queued -= static_cast<std::size_t>(n);
      if (sent == frame->size()) c.out.pop_front();
    }
  }

  void enqueue(Client& c, const Frame& frame, std::size_t max_queued) {
    if (c.queued > 0 && c.queued + frame->size() > max_queued) {
      count([](RelayStats& s) { ++s.dropped_slow; });
      return;
    }
    c.out.emplace_back(frame, 0);
    c.queued += frame->size();
    count([&](RelayStats& s) {
      ++s.forwarded;
      s.bytes_forwarded += frame->size();
    });
    flush(c);
  }

  void forward(const std::string& channel, const Frame& frame, const RelayOptions& o) {
    count([](RelayStats& s) { ++s.published; });
    if (channel.compare(0, o.channel_prefix.size(), o.channel_prefix) != 0) {
      count([](RelayStats& s) { ++s.dropped_foreign; });
      return;
    }
    for (auto& c : clients) {
      if (c->closed) continue;
      for (const auto& p : c->subscriptions)
        if (p.matches(channel)) {
          enqueue(*c, frame, o.max_queued_bytes);
          break;  // one copy per client, however many of its subscriptions match
        }
    }
  }

  // Parses every complete frame in the client's buffer. False: malformed, `why` says how.
  bool parse(Client& c, const RelayOptions& o, std::string& why) {
    for (;;) {
      const std::uint8_t* p = c.in.data() + c.in_pos;
      const std::size_t avail = c.in.size() - c.in_pos;
      if (!c.greeted) {
        if (avail < 8) return true;
        if (be32(p) != kTcpqMagicClient) {
          why = fmt::format("not an LCM tcpq client (first word {:#010x})", be32(p));
          return false;
        }
        c.greeted = true;
        c.in_pos += 8;
        continue;
      }
      if (avail < 8) return true;
      const std::uint32_t type = be32(p), len = be32(p + 4);
      if (type != kTcpqPublish && type != kTcpqSubscribe && type != kTcpqUnsubscribe) {
        why = fmt::format("unknown message type {}", type);
        return false;
      }
      if (len > kMaxChannel) {
        why = fmt::format("a channel of {} bytes (at most {})", len, kMaxChannel);
        return false;
      }
      if (type != kTcpqPublish) {
        if (avail < 8 + std::size_t{len}) return true;
        const std::string pattern(reinterpret_cast<const char*>(p + 8), len);
        c.in_pos += 8 + std::size_t{len};
        if (type == kTcpqSubscribe) {
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
      if (data_len > o.max_frame_bytes) {
        why = fmt::format("a message of {} bytes (at most {})", data_len, o.max_frame_bytes);
        return false;
      }
      const std::size_t total = head + data_len;
      if (avail < total) {
        c.in.reserve(c.in_pos + total);  // read the rest of a large message without regrowing
        return true;
      }
      // The frame a subscriber gets is byte for byte the one published.
      auto frame = std::make_shared<const std::vector<std::uint8_t>>(p, p + total);
      const std::string channel(reinterpret_cast<const char*>(p + 8), len);
      c.in_pos += total;
      forward(channel, frame, o);
    }
  }

  void read_from(Client& c, const RelayOptions& o) {
    std::size_t got = 0;
    while (!c.closed && got < kReadBurst) {
      const ssize_t n = ::recv(c.fd, chunk.data(), chunk.size(), MSG_DONTWAIT);
      if (n == 0) return close_client(c);  // the client ended its connection
      if (n < 0) {
        if (errno == EINTR) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK) return close_client(c);
        break;
      }
      got += static_cast<std::size_t>(n);
      c.in.insert(c.in.end(), chunk.begin(), chunk.begin() + n);
      std::string why;
      if (!parse(c, o, why)) return close_client(c, why);
      if (c.in_pos == c.in.size()) {
        c.in.clear();
        c.in_pos = 0;
      } else if (c.in_pos > (std::size_t{1} << 20) && c.in_pos * 2 > c.in.size()) {
        c.in.erase(c.in.begin(), c.in.begin() + static_cast<std::ptrdiff_t>(c.in_pos));
        c.in_pos = 0;
      }
    }
  }

  void accept_clients(const RelayOptions& o) {
    for (;;) {
      sockaddr_in peer{};
      socklen_t peer_len = sizeof peer;
      const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&peer), &peer_len, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) return;  // EAGAIN: no more; anything else: try again on the next wake-up
      if (static_cast<int>(clients.size()) >= o.max_clients) {
        ::close(fd);
        count([](RelayStats& s) { ++s.refused_clients; });
        continue;
      }
      // LCM's client writes a message as five small sends: without this on both ends, Nagle's
      // algorithm holds the later ones for the peer's delayed acknowledgement.
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      auto c = std::make_unique<Client>();
      c->fd = fd;
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
      c->queued = hello.size();
      c->out.emplace_back(std::make_shared<const std::vector<std::uint8_t>>(std::move(hello)), 0);
      flush(*c);
      clients.push_back(std::move(c));
    }
  }
};

Relay::Relay(RelayOptions options) : options_(std::move(options)), impl_(std::make_unique<Impl>()) {
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
  for (auto& c : impl_->clients) impl_->close_client(*c);
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
    if (::poll(fds.data(), fds.size(), -1) < 0) {
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
