// What the bus needs of a transport: raw datagrams published on a channel, those of the channels
// it listens to handed over as they arrive. Two kinds, chosen by the URL:
//   udpm://… tcpq://…   LCM (UDP multicast; TCP through the coordinator's relay): runs;
//   inproc://NAME       an in-process hub: every wire of one NAME in the process hears every
//                       other and itself, as multicast loops back, with no socket and no loss —
//                       the coupling runtime's unit tests (fake nodes as threads of the test).
// Everything above it (envelope, HMAC, replay checks, decoding: bus.h) is the same for both.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace lcm {
class LCM;
}

namespace hemo {

// At most this many received datagrams wait per channel; more are dropped at receipt (the Bus
// constructor, bus.cpp, says why it is this large).
inline constexpr int kSubscriptionQueue = 10000;

class Wire {
 public:
  // data, length, channel, receive time (µs since the epoch). Must not throw.
  using Handler = std::function<void(const std::uint8_t*, std::size_t, const std::string&, std::int64_t)>;

  // Opens the transport of `url`; throws std::runtime_error with one line saying why it cannot.
  // Over TCP the relay lets only holders of the run's secret in (bus_crypto.h, the handshake):
  // `secret` is required there, unused otherwise.
  static std::unique_ptr<Wire> open(const std::string& url, const std::vector<std::uint8_t>& secret = {});
  virtual ~Wire() = default;

  virtual void publish(const std::string& channel, const std::uint8_t* data, std::size_t len) = 0;
  virtual void subscribe(const std::string& channel, Handler handler) = 0;
  // Hands over at most one waiting datagram, waiting up to timeout_ms for one: > 0 one handled,
  // 0 none within the time, < 0 the transport failed (errno says why; EINTR: a signal).
  virtual int handle(int timeout_ms) = 0;
};

bool is_tcpq(const std::string& url);
// The relay's handshake on an LCM tcpq client just connected to `url`, before it subscribes to
// anything: proves that it holds `secret` and checks that the relay does. Throws one line when
// the relay refuses, does not answer, or does not hold the secret.
void authenticate_to_relay(lcm::LCM& lcm, const std::vector<std::uint8_t>& secret, const std::string& url);
bool is_inproc(const std::string& url);

}  // namespace hemo
