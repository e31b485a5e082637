// SPDX-License-Identifier: GPL-3.0-or-later
#include "ranked_port.h"

#include <traffic.h>

#include <fmt/format.h>

#include <cstdint>
#include <stdexcept>
#include <vector>

namespace hemo::particles {

namespace {

// An LCM message from rank 0 to every rank (encoded on rank 0, decoded elsewhere).
template <class Msg>
void broadcast(Msg& msg, MPI_Comm comm, int rank) {
  long long size = rank == 0 ? msg.getEncodedSize() : 0;
  MPI_Bcast(&size, 1, MPI_LONG_LONG, 0, comm);
  std::vector<char> buf(static_cast<std::size_t>(size));
  if (rank == 0 && msg.encode(buf.data(), 0, static_cast<int>(size)) < 0)
    throw std::runtime_error("cannot encode a message for the other ranks");
  MPI_Bcast(buf.data(), static_cast<int>(size), MPI_CHAR, 0, comm);
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  RankTraffic::broadcast(sizeof size + static_cast<std::uint64_t>(size), rank == 0, ranks);
  if (rank != 0 && msg.decode(buf.data(), 0, static_cast<int>(size)) < 0)
    throw std::runtime_error("cannot decode a message from rank 0");
}

}  // namespace

RankedPort::RankedPort(MPI_Comm comm, const std::function<std::unique_ptr<ParticlePort>()>& make_port) : comm_(comm) {
  MPI_Comm_rank(comm_, &rank_);
  // Rank 0 may fail to join the bus: the others must hear of it rather than wait forever.
  int control = kContinue;
  std::string error;
  if (rank_ == 0) {
    try {
      port_ = make_port();
    } catch (const std::exception& e) {
      control = kError;
      error = e.what();
    }
  }
  broadcast_control(control, error);
  if (control == kError) {
    if (rank_ == 0) throw std::runtime_error(error);
    throw std::runtime_error("rank 0 could not join the bus: " + error);
  }
}

void RankedPort::broadcast_control(int& control, std::string& error) {
  MPI_Bcast(&control, 1, MPI_INT, 0, comm_);
  if (control != kError) return;
  int len = static_cast<int>(error.size());
  MPI_Bcast(&len, 1, MPI_INT, 0, comm_);
  error.resize(static_cast<std::size_t>(len));
  MPI_Bcast(error.data(), len, MPI_CHAR, 0, comm_);
}

mesh_t RankedPort::initialize() {
  mesh_t mesh;
  int control = kContinue;
  std::string error;
  if (rank_ == 0) {
    try {
      mesh = port_->initialize();
    } catch (const std::exception& e) {
      control = kError;
      error = e.what();
    }
  }
  broadcast_control(control, error);
  if (control == kError) throw std::runtime_error(rank_ == 0 ? error : "rank 0: " + error);
  broadcast(mesh, comm_, rank_);
  return mesh;
}

Diagnostics RankedPort::with_rank_traffic(const Diagnostics& diag) {
  const TrafficBytes mine = RankTraffic::take();
  const std::uint64_t own[2] = {mine.sent, mine.received};
  int ranks = 1;
  MPI_Comm_size(comm_, &ranks);
  std::vector<std::uint64_t> all(2 * static_cast<std::size_t>(ranks));
  MPI_Gather(own, 2, MPI_UINT64_T, all.data(), 2, MPI_UINT64_T, 0, comm_);
  Diagnostics out = diag;
  if (rank_ != 0 || diag.empty()) return out;  // a report without diagnostics stays without
  for (int r = 0; r < ranks; ++r) {
    out.emplace_back(fmt::format("rank{}_sent_B", r), static_cast<double>(all[2 * r]));
    out.emplace_back(fmt::format("rank{}_received_B", r), static_cast<double>(all[2 * r + 1]));
  }
  return out;
}

std::optional<ParticleStep> RankedPort::advance(particle_feedback_t& feedback, const Diagnostics& diag) {
  std::optional<ParticleStep> step;
  int control = kContinue;
  std::string error;
  // Every rank's bytes since its last report (this gather itself not counted: it is the measuring).
  const Diagnostics reported = with_rank_traffic(diag);
  if (rank_ == 0) {
    try {
      step = port_->advance(feedback, reported);
      control = step ? kContinue : kStop;
    } catch (const std::exception& e) {
      control = kError;
      error = e.what();
    }
  }
  broadcast_control(control, error);
  if (control == kError) throw std::runtime_error(rank_ == 0 ? error : "rank 0: " + error);
  if (control == kStop) return std::nullopt;
  if (rank_ != 0) step.emplace();
  broadcast(step->order, comm_, rank_);
  broadcast(step->fluid, comm_, rank_);
  step_ = step->order.envelope.step;
  return step;
}

void RankedPort::finalize() {
  if (port_) port_->finalize();
}

void RankedPort::fail(const std::string& error) {
  if (port_) port_->fail(error);
}

}  // namespace hemo::particles
