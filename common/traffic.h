// The bytes one process (one MPI rank of a node, or the coordinator) moves for the coupling, the
// measure of issue #36 and docs/scale-out.md: what it publishes and receives on the bus (bus.cpp
// counts every datagram), its heartbeats, and the payload of its node's MPI collectives that
// carry the exchange (counted where they are called: the fluid's gather and scatter, the particle
// ranks' broadcast of the state and all-reduces of the deposition and the crossing records).
//
// The bus's bytes are exact: the datagrams' lengths as handed to and from LCM (LCM's own fragment
// headers, UDP and IP not included). A collective's are its payload as if it were sent directly
// between the root and each other rank: a broadcast or scatter of n bytes is n received by each
// other rank and n (P - 1) sent by the root; a gather, each rank's own part sent and the others'
// received by the root; an all-reduce of n, n sent and n received by every rank. That is what
// the wire carries on 2 ranks; on more, MPI's and OpenFOAM's trees and rings move the same data
// along other routes (a ring all-reduce up to 2 n each way).
//
// Two parts of those are counted again on their own:
// - what a loss costs, `resent` of the sent bytes and `received_again` of the received: the resend
//   requests a bus published or heard, the messages it published again on request, and the
//   copies of a message it had already been handed (bus.cpp). Sent less resent is what the rank
//   must send a step; how often it sends more depends on loss and on a busy machine's timing.
// - `halo`, the payload a particle rank exchanged with the ranks sharing its cells (CellHaloSum:
//   the solid volume once a step, the co-relaxed plasma's sums every DEM step), sent and received
//   alike; it is in sent and received too.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <atomic>
#include <cstdint>

namespace hemo {

struct TrafficBytes {
  std::uint64_t sent = 0;
  std::uint64_t received = 0;
  std::uint64_t resent = 0;          // of sent: resend requests and messages published again
  std::uint64_t received_again = 0;  // of received: resend requests heard and copies already had
  std::uint64_t halo = 0;            // of sent, and as much of received: the cell halo's sums
};

// Process-wide; the heartbeat thread adds to it too.
class RankTraffic {
 public:
  static void sent(std::uint64_t bytes) { counters().sent.fetch_add(bytes, std::memory_order_relaxed); }
  static void received(std::uint64_t bytes) { counters().received.fetch_add(bytes, std::memory_order_relaxed); }
  // Bytes already counted by sent() or received() that loss or lateness made it move.
  static void resent(std::uint64_t bytes) { counters().resent.fetch_add(bytes, std::memory_order_relaxed); }
  static void received_again(std::uint64_t bytes) {
    counters().received_again.fetch_add(bytes, std::memory_order_relaxed);
  }
  // An exchange of `bytes` each way with the ranks sharing this rank's cells.
  static void halo(std::uint64_t bytes) {
    sent(bytes);
    received(bytes);
    counters().halo.fetch_add(bytes, std::memory_order_relaxed);
  }
  // A collective's payload on this rank by the rule above (`ranks` the communicator's size).
  static void broadcast(std::uint64_t bytes, bool root, int ranks) {
    if (ranks < 2) return;
    if (root)
      sent(bytes * static_cast<std::uint64_t>(ranks - 1));
    else
      received(bytes);
  }
  static void all_reduce(std::uint64_t bytes, int ranks) {
    if (ranks < 2) return;
    sent(bytes);
    received(bytes);
  }
  // What was counted since the last take (the first: since the process started).
  static TrafficBytes take() {
    return {counters().sent.exchange(0, std::memory_order_relaxed),
            counters().received.exchange(0, std::memory_order_relaxed),
            counters().resent.exchange(0, std::memory_order_relaxed),
            counters().received_again.exchange(0, std::memory_order_relaxed),
            counters().halo.exchange(0, std::memory_order_relaxed)};
  }

 private:
  struct Counters {
    std::atomic<std::uint64_t> sent{0}, received{0}, resent{0}, received_again{0}, halo{0};
  };
  static Counters& counters() {
    static Counters c;
    return c;
  }
};

}  // namespace hemo
