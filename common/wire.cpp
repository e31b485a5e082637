// SPDX-License-Identifier: GPL-3.0-or-later
#include "wire.h"

#include "bus_crypto.h"

#include <fmt/format.h>
#include <lcm/lcm-cpp.hpp>
#include <spdlog/spdlog.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace hemo {

bool is_tcpq(const std::string& url) { return url.rfind("tcpq://", 0) == 0; }
bool is_inproc(const std::string& url) { return url.rfind("inproc://", 0) == 0; }

namespace {

std::int64_t wall_clock_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// ---- LCM ----

// LCM's UDP multicast drops large (fragmented) messages when the kernel's receive buffer is
// small; deploy/install-deps.sh raises it where it may. Say so once when it could not.
void warn_if_small_receive_buffer(const std::string& url) {
  if (url.rfind("udpm", 0) != 0) return;
  static bool warned = false;
  std::ifstream in("/proc/sys/net/core/rmem_max");
  long bytes = 0;
  if (!(in >> bytes) || bytes >= (2L << 20) || warned) return;
  warned = true;
  spdlog::warn(
      "net.core.rmem_max is {} bytes; LCM over UDP may drop large messages (they are asked for again, "
      "at a cost in time). Raise it: sysctl -w net.core.rmem_max=8388608 net.core.rmem_default=8388608",
      bytes);
}

// LCM's tcpq client connects with a blocking connect() as the instance is made: where a firewall
// drops the packets that is minutes of silence, and where the relay is not listening LCM goes on
// without a connection (every wait then times out). A connection tried first, with a bound,
// turns both into one line. Returns the URL.
const std::string& reachable(const std::string& url) {
  if (!is_tcpq(url)) return url;
  const std::string where = url.substr(7);
  const auto colon = where.rfind(':');
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  const std::string host = where.substr(0, colon);
  const int port = colon == std::string::npos ? 7700 : std::atoi(where.c_str() + colon + 1);
  // LCM 1.3 takes only a numeric address here: a host name would silently mean 0.0.0.0.
  if (::inet_pton(AF_INET, host.c_str(), &sa.sin_addr) != 1 || port <= 0 || port > 65535)
    throw std::runtime_error(fmt::format("bus URL {}: LCM's tcpq needs an IPv4 address and a port", url));
  sa.sin_port = htons(static_cast<std::uint16_t>(port));
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  int err = fd < 0 ? errno : 0;
  if (fd >= 0 && ::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
    err = errno;
    if (err == EINPROGRESS) {
      pollfd p{fd, POLLOUT, 0};
      const int n = ::poll(&p, 1, 10000);
      socklen_t len = sizeof err;
      if (n == 1)
        ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
      else
        err = ETIMEDOUT;
    }
  }
  if (fd >= 0) ::close(fd);
  if (err != 0)
    throw std::runtime_error(fmt::format(
        "cannot reach the bus relay at {}: {} (the coordinator runs it while the run goes; from this host, a "
        "firewall or hosts.relay_address may be in the way: docs/hosts.md)",
        where, std::strerror(err)));
  return url;
}

}  // namespace

void authenticate_to_relay(lcm::LCM& lcm, const std::vector<std::uint8_t>& secret, const std::string& url) {
  const std::string where = url.substr(url.find("://") + 3);
  if (secret.empty()) throw std::runtime_error("the bus relay at " + where + " lets in only holders of the run's secret");
  std::vector<std::vector<std::uint8_t>> said;  // what the relay published on the handshake channel
  lcm::Subscription* sub = lcm.subscribeFunction(
      kRelayAuthChannel,
      +[](const lcm::ReceiveBuffer* rbuf, const std::string&, std::vector<std::vector<std::uint8_t>>* out) {
        const auto* d = static_cast<const std::uint8_t*>(rbuf->data);
        out->emplace_back(d, d + rbuf->data_size);
      },
      &said);
  // The relay answers at once; the bound is for a relay that is not ours, or a stalled network.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  auto next = [&](std::uint8_t kind, const char* what) {
    while (said.empty()) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
      const int n = left > 0 ? lcm.handleTimeout(static_cast<int>(left)) : 0;
      if (n < 0)
        throw std::runtime_error(fmt::format(
            "the bus relay at {} closed the connection in the handshake (it refuses a process without the run's "
            "secret: RUN_DIR/secret)",
            where));
      if (n == 0 && left <= 0)
        throw std::runtime_error(fmt::format("the bus relay at {} sent no {} within 10 s", where, what));
    }
    auto m = std::move(said.front());
    said.erase(said.begin());
    if (m.empty() || m[0] != kind)
      throw std::runtime_error(fmt::format("the bus relay at {} sent something else than its {}", where, what));
    return m;
  };
  const auto challenge = next(kAuthChallenge, "challenge");
  if (challenge.size() != 1 + kNonceBytes)
    throw std::runtime_error(fmt::format("the bus relay at {} sent a malformed challenge", where));
  const Bytes relay_nonce(challenge.begin() + 1, challenge.end());
  const Bytes key = handshake_key(secret);
  const Bytes client_nonce = random_bytes(kNonceBytes);
  const Bytes answer = handshake_answer(key, relay_nonce, client_nonce);
  if (lcm.publish(kRelayAuthChannel, answer.data(), static_cast<unsigned>(answer.size())) != 0)
    throw std::runtime_error(fmt::format("lost the connection to the bus relay at {} in its handshake", where));
  const auto proof = next(kAuthAccepted, "acceptance");
  const Bytes expected = handshake_proof(key, relay_nonce, client_nonce);
  if (proof.size() != expected.size() || !same_digest(proof.data() + 1, expected.data() + 1))
    throw std::runtime_error(fmt::format(
        "the bus relay at {} does not hold this run's secret: it is not this run's relay", where));
  lcm.unsubscribe(sub);
}

namespace {

class LcmWire final : public Wire {
 public:
  LcmWire(const std::string& url, const std::vector<std::uint8_t>& secret) : url_(url), lcm_(reachable(url)) {
    if (!lcm_.good() || (is_tcpq(url) && lcm_.getFileno() < 0))
      throw std::runtime_error("cannot open the LCM bus at " + url);
    // LCM's tcpq client writes a message as five small sends; Nagle's algorithm holds each later
    // one until the one before is acknowledged. (A reconnection LCM makes later gets a socket
    // without this: slower, not wrong.)
    if (is_tcpq(url) && lcm_.getFileno() >= 0) {
      const int one = 1;
      ::setsockopt(lcm_.getFileno(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      authenticate_to_relay(lcm_, secret, url);
    }
    warn_if_small_receive_buffer(url);
    // LCM's UDP provider joins the group at the first subscription and checks that a datagram
    // it sends comes back; when it does not (multicast dropped on this host too, by a
    // firewall), the subscription is null and LCM's C++ wrapper would hand it on (a crash in
    // setQueueCapacity). A probe first, so that this is one line instead.
    lcm_subscription_t* probe = lcm_subscribe(
        lcm_.getUnderlyingLCM(), "hemocosim/probe", +[](const lcm_recv_buf_t*, const char*, void*) {}, nullptr);
    if (probe == nullptr)
      throw std::runtime_error(fmt::format(
          "cannot listen on the LCM bus at {}: multicast sent from this host does not come back to it (LCM's self "
          "test: a firewall drops UDP to 224.0.0.0/4, or the route for it is wrong); where multicast cannot pass, "
          "use the TCP transport (--transport tcp; docs/hosts.md)",
          url));
    lcm_unsubscribe(lcm_.getUnderlyingLCM(), probe);
  }

  // Once the relay has ended the connection, LCM's client would connect again by itself, without
  // the handshake (so to no avail), and select() on a socket of -1 (an abort): the connection
  // stays lost, as the relay meant, and handle() says so.
  bool lost() const { return is_tcpq(url_) && lcm_.getFileno() < 0; }

  void publish(const std::string& channel, const std::uint8_t* data, std::size_t len) override {
    if (!lost()) lcm_.publish(channel, data, static_cast<unsigned>(len));
  }

  void subscribe(const std::string& channel, Handler handler) override {
    handlers_.push_back(std::make_unique<Handler>(std::move(handler)));
    lcm::Subscription* s = lcm_.subscribeFunction(
        channel,
        +[](const lcm::ReceiveBuffer* rbuf, const std::string& chan, Handler* h) {
          (*h)(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size, chan, rbuf->recv_utime);
        },
        handlers_.back().get());
    if (s == nullptr) throw std::runtime_error("cannot subscribe to " + channel + " on the LCM bus at " + url_);
    s->setQueueCapacity(kSubscriptionQueue);
  }

  int handle(int timeout_ms) override {
    if (lost()) {
      errno = ECONNRESET;
      return -1;
    }
    return lcm_.handleTimeout(timeout_ms);
  }

 private:
  std::string url_;
  mutable lcm::LCM lcm_;
  std::vector<std::unique_ptr<Handler>> handlers_;  // stable addresses: LCM keeps them
};

// ---- in process ----

class InProcessWire;

// The wires of one name. A publish copies the datagram to every wire listening to its channel,
// the publisher's own included (as multicast loops back).
struct Hub {
  std::mutex mutex;
  std::vector<InProcessWire*> wires;
};

std::shared_ptr<Hub> hub_named(const std::string& name) {
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<Hub>> hubs;
  std::lock_guard<std::mutex> lock(mutex);
  auto hub = hubs[name].lock();
  if (!hub) hubs[name] = hub = std::make_shared<Hub>();
  return hub;
}

class InProcessWire final : public Wire {
 public:
  explicit InProcessWire(const std::string& url) : hub_(hub_named(url.substr(9))) {
    std::lock_guard<std::mutex> lock(hub_->mutex);
    hub_->wires.push_back(this);
  }
  ~InProcessWire() override {
    std::lock_guard<std::mutex> lock(hub_->mutex);
    hub_->wires.erase(std::find(hub_->wires.begin(), hub_->wires.end(), this));
  }

  void publish(const std::string& channel, const std::uint8_t* data, std::size_t len) override {
    const std::int64_t now = wall_clock_us();
    std::lock_guard<std::mutex> lock(hub_->mutex);
    for (InProcessWire* w : hub_->wires) w->deliver(channel, data, len, now);
  }

  void subscribe(const std::string& channel, Handler handler) override {
    std::lock_guard<std::mutex> lock(mutex_);
    handlers_[channel] = std::move(handler);
  }

  int handle(int timeout_ms) override {
    Datagram d;
    Handler* handler = nullptr;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (!arrived_.wait_for(lock, std::chrono::milliseconds(std::max(0, timeout_ms)), [&] { return !queue_.empty(); }))
        return 0;
      d = std::move(queue_.front());
      queue_.pop_front();
      --waiting_[d.channel];
      handler = &handlers_.at(d.channel);  // handlers are only added, never removed
    }
    (*handler)(d.bytes.data(), d.bytes.size(), d.channel, d.received_us);
    return 1;
  }

 private:
  struct Datagram {
    std::string channel;
    std::vector<std::uint8_t> bytes;
    std::int64_t received_us = 0;
  };

  void deliver(const std::string& channel, const std::uint8_t* data, std::size_t len, std::int64_t now) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!handlers_.count(channel) || waiting_[channel] >= kSubscriptionQueue) return;
      queue_.push_back({channel, std::vector<std::uint8_t>(data, data + len), now});
      ++waiting_[channel];
    }
    arrived_.notify_one();
  }

  std::shared_ptr<Hub> hub_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::map<std::string, Handler> handlers_;
  std::deque<Datagram> queue_;
  std::map<std::string, int> waiting_;
};

}  // namespace

std::unique_ptr<Wire> Wire::open(const std::string& url, const std::vector<std::uint8_t>& secret) {
  if (is_inproc(url)) {
    if (url.size() <= 9) throw std::runtime_error("bus URL " + url + ": inproc:// needs a name");
    return std::make_unique<InProcessWire>(url);
  }
  return std::make_unique<LcmWire>(url, secret);
}

}  // namespace hemo
