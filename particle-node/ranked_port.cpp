// SPDX-License-Identifier: GPL-3.0-or-later
#include "ranked_port.h"

#include "agree.h"

#include <liveness.h>
#include <partition_exchange.h>
#include <traffic.h>

#include <fmt/format.h>

#include <chrono>
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

RankedPort::RankedPort(MPI_Comm comm, const RunContext& ctx,
                       const std::function<std::unique_ptr<ParticlePort>()>& make_port)
    : comm_(comm), step_(ctx.resume_step) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &ranks_);
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
  if (rank_ > 0) {
    try {
      reporter_ = std::make_unique<RankReporter>(ctx, "particles", rank_);
    } catch (const std::exception& e) {
      error = fmt::format("rank {} could not join the bus: {}", rank_, e.what());
    }
  }
  error = agree_on_error(error, comm_);
  if (!error.empty()) throw std::runtime_error(error);
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
  int fluid_ranks = 1;
  if (rank_ == 0) {
    try {
      mesh = port_->initialize();
      fluid_ranks = port_->peer_ranks();
      fluid_lag_ = port_->fluid_lag();
    } catch (const std::exception& e) {
      control = kError;
      error = e.what();
    }
  }
  broadcast_control(control, error);
  if (control == kError) throw std::runtime_error(rank_ == 0 ? error : "rank 0: " + error);
  broadcast(mesh, comm_, rank_);
  int shared[2] = {fluid_ranks, fluid_lag_};
  MPI_Bcast(shared, 2, MPI_INT, 0, comm_);
  fluid_lag_ = shared[1];
  partitioned_ = hemo::partitioned(shared[0], ranks_);
  fluid_ranks_ = shared[0];
  return mesh;
}

ParticleDecomposition RankedPort::every_box(const Box& box, double margin) const {
  const double mine[6] = {box.lo.x(), box.lo.y(), box.lo.z(), box.hi.x(), box.hi.y(), box.hi.z()};
  std::vector<double> all(6 * static_cast<std::size_t>(ranks_));
  MPI_Allgather(mine, 6, MPI_DOUBLE, all.data(), 6, MPI_DOUBLE, comm_);
  ParticleDecomposition particles;
  particles.margin = margin;
  for (int r = 0; r < ranks_; ++r) {
    const double* b = all.data() + 6 * r;
    particles.boxes.push_back({Vec3(b[0], b[1], b[2]), Vec3(b[3], b[4], b[5])});
  }
  return particles;
}

OverlapMap RankedPort::start_exchange(const mesh_t& mesh, const Box& box, double margin, const RunContext& ctx,
                                      bool boxes_move) {
  // Every rank's box, on every rank (each computes the map itself).
  const ParticleDecomposition particles = every_box(box, margin);
  fluid_decomposition_t owners;
  int control = kContinue;
  std::string error;
  if (rank_ == 0) {
    try {
      particle_domain_t domain = domain_message(mesh.mesh_hash, particles);
      port_->bus().publish(channel::domain, domain, 0, /*keep=*/true);
      owners = port_->wait_for_kept(channel::partition, "the fluid's decomposition").as<fluid_decomposition_t>();
    } catch (const std::exception& e) {
      control = kError;
      error = e.what();
    }
  }
  broadcast_control(control, error);
  if (control == kError) throw ExchangeError(error);
  broadcast(owners, comm_, rank_);
  OverlapMap map;
  try {
    CellPoints points = cell_points_of(mesh);
    FluidDecomposition fluid = fluid_decomposition_of(owners, mesh);
    map = overlap_map(points, fluid, particles, period_of(mesh));
    if (boxes_move) {
      cell_points_ = std::move(points);
      fluid_ = std::move(fluid);
      period_ = period_of(mesh);
      mesh_hash_ = mesh.mesh_hash;
    }
    receiver_ = std::make_unique<ParticleRankReceiver>(ctx, rank_, ranks_, fluid_ranks_, map.from[rank_],
                                                       mesh.mesh_hash, mesh.n_cells,
                                                       kCoordinatorPatience * ctx.timeout_s);
    publisher_ = std::make_unique<ParticleRankPublisher>(ctx, rank_, ranks_, fluid_ranks_, map.from[rank_]);
  } catch (const std::exception& e) {
    error = e.what();
  }
  error = agree_on_error(error, comm_);
  if (!error.empty()) throw ExchangeError(error);
  return map;
}

std::optional<OverlapMap> RankedPort::publish_boxes(const Box& box, double margin, std::int64_t step, bool moved) {
  const ParticleDecomposition particles = every_box(box, margin);
  std::string error;
  if (rank_ == 0) {
    try {
      particle_domain_t domain = domain_message(mesh_hash_, particles);
      port_->bus().publish(channel::domain, domain, step, /*keep=*/true);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  std::optional<OverlapMap> map;
  if (moved && error.empty()) {
    try {
      map = overlap_map(cell_points_, fluid_, particles, period_);
      receiver_->replan(map->from[static_cast<std::size_t>(rank_)]);
      publisher_->replan(map->from[static_cast<std::size_t>(rank_)]);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  error = agree_on_error(error, comm_);
  if (!error.empty()) throw ExchangeError(error);
  return map;
}

Diagnostics RankedPort::with_rank_traffic(const Diagnostics& diag) {
  const TrafficBytes mine = RankTraffic::take();
  const std::uint64_t state = receiver_ ? receiver_->take_received_bytes() : 0;
  const std::uint64_t feedback = publisher_ ? publisher_->take_sent_bytes() : 0;
  const std::uint64_t reports = reporter_ ? reporter_->take_sent_bytes() : 0;
  Diagnostics out = rank_ == 0 ? diag : Diagnostics();
  if (diag.empty()) return out;  // a report without diagnostics stays without
  for (const auto& bytes : rank_bytes(rank_, mine)) out.push_back(bytes);
  // The partitioned exchange's own measures: the fluid state that reached this rank, the
  // feedback it sent.
  if (partitioned_) {
    out.emplace_back(fmt::format("rank{}_received_fluid_state_B", rank_), static_cast<double>(state));
    out.emplace_back(fmt::format("rank{}_sent_feedback_B", rank_), static_cast<double>(feedback));
    // What it summed with the ranks sharing its cells (sent, and as much received).
    out.emplace_back(fmt::format("rank{}_halo_B", rank_), static_cast<double>(mine.halo));
  }
  // Its own reports and heartbeats (rank 0's are its port's).
  if (reporter_) out.emplace_back(fmt::format("rank{}_sent_report_B", rank_), static_cast<double>(reports));
  return out;
}

std::optional<ParticleStep> RankedPort::advance(particle_feedback_t& feedback, const Diagnostics& diag,
                                                const std::function<void(std::int64_t)>& before_state) {
  std::optional<ParticleStep> step;
  int control = kContinue;
  std::string error;
  if (partitioned_) {
    // Every rank its own partial sums to the fluid ranks whose cells they reach, before it
    // reports the step: what the next order makes the fluid wait for is then published.
    // Publishing counts as coupling, not computing, as the fluid's does (fluidLink.H).
    if (port_) port_->end_computing();
    if (reporter_) reporter_->end_computing();
    try {
      publisher_->publish(feedback, step_);
    } catch (const std::exception& e) {
      error = e.what();
    }
    error = agree_on_error(error, comm_);
    if (!error.empty()) throw ExchangeError(error);
  }
  const Diagnostics reported = with_rank_traffic(diag);
  if (reporter_) reporter_->report(step_, reported);
  if (rank_ == 0) {
    try {
      step = partitioned_ ? port_->advance_partitioned(reported) : port_->advance(feedback, reported);
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
  // Whatever comes next, the rank's wait is over once the step's order and inputs are here.
  struct WaitEnds {
    RankReporter* reporter;
    ~WaitEnds() {
      if (reporter) reporter->begin_step();
    }
  } wait_ends{reporter_.get()};
  broadcast(step->order, comm_, rank_);
  step_ = step->order.envelope.step;
  if (!partitioned_) {
    broadcast(step->fluid, comm_, rank_);
    return step;
  }
  if (before_state) before_state(step_);
  // Every rank its own cells of the state the step runs in; a partition that does not fit, or
  // does not come, stops every rank with the lowest one's line.
  const auto waiting = std::chrono::steady_clock::now();
  try {
    // Rank 0 keeps serving its port meanwhile: the fluid may be asking again for the feedback
    // it needs before it can publish this state.
    step->fluid = receiver_->receive(step_ - fluid_lag_, [this] {
      if (port_) port_->serve();
    });
  } catch (const std::exception& e) {
    error = e.what();
  }
  error = agree_on_error(error, comm_);
  if (!error.empty()) throw ExchangeError(error);
  // The agreement is where a rank that has its part waits for the others' (the other ranks'
  // wait ends here too, at WaitEnds): waiting, not computing.
  if (port_) port_->count_as_waiting(std::chrono::duration<double>(std::chrono::steady_clock::now() - waiting).count());
  return step;
}

// The ranks' own ends of the bus go too: the process may exit without unwinding, and a resend
// thread still signing at exit could crash it.
void RankedPort::finalize() {
  reporter_.reset();
  if (port_) port_->finalize();
}

void RankedPort::fail(const std::string& error) {
  reporter_.reset();
  if (port_) port_->fail(error);
}

}  // namespace hemo::particles
