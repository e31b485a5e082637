// The particle node's bus connection on one or more MPI ranks: rank 0 alone holds the
// ParticlePort (joins the bus, heartbeats, publishes); what it receives — the mesh once, then
// each step's order and fluid state — is broadcast (LCM-encoded) to the other ranks, so every
// rank runs the same steps. The feedback and diagnostics every rank computes are the same
// (per-cell arrays are summed over ranks first); only rank 0's are published, with every rank's
// bytes of the step.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <mpi.h>
#include <node_port.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace hemo::particles {

class RankedPort {
 public:
  // `make_port` is called on rank 0 only.
  RankedPort(MPI_Comm comm, const std::function<std::unique_ptr<ParticlePort>()>& make_port);

  mesh_t initialize();
  // Collective. Rank 0 publishes `feedback` and `diag`; every rank gets the next step or
  // nothing (stop). When rank 0 fails to get a step (bus error, timeout) every rank throws.
  std::optional<ParticleStep> advance(particle_feedback_t& feedback, const Diagnostics& diag);
  void finalize();
  // Rank 0 tells the coordinator (other ranks: nothing).
  void fail(const std::string& error);
  // The step being worked on (rank 0: the port's, which starts at a resumed run's step).
  std::int64_t step() const { return port_ ? port_->step() : step_; }
  int rank() const { return rank_; }

 private:
  enum Control : int { kContinue = 0, kStop = 1, kError = 2 };
  void broadcast_control(int& control, std::string& error);
  // `diag` and, on rank 0, the bytes each rank moved for the coupling since its last report
  // (rank<r>_sent_B, rank<r>_received_B; common/traffic.h); collective.
  Diagnostics with_rank_traffic(const Diagnostics& diag);

  MPI_Comm comm_;
  int rank_ = 0;
  std::unique_ptr<ParticlePort> port_;
  std::int64_t step_ = 0;
};

}  // namespace hemo::particles
