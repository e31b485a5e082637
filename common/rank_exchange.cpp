// SPDX-License-Identifier: GPL-3.0-or-later
#include "rank_exchange.h"

#include "cell_fields.h"
#include "liveness.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <utility>

namespace hemo {

namespace {

double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::vector<std::string> channels_of(const std::vector<PairInbox::Source>& sources) {
  std::vector<std::string> out;
  for (const auto& s : sources) out.push_back(s.channel);
  return out;
}

std::map<std::string, int> ranks_of(const std::vector<PairInbox::Source>& sources) {
  std::map<std::string, int> out;
  for (const auto& s : sources) out[s.channel] = s.rank;
  return out;
}

}  // namespace

std::string rank_sender(const std::string& role, int rank) { return role + "." + std::to_string(rank); }

AnsweringBus::AnsweringBus(const RunContext& ctx, const std::string& sender) : bus_(ctx, sender, {channel::resend}) {
  answering_ = std::thread([this] {
    while (!stop_.load()) {
      try {
        bus_.poll(0.1, [](const Received&) {});  // the bus answers what it kept; nothing else is wanted
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(error_mutex_);
        error_ = e.what();
        return;
      }
    }
  });
}

AnsweringBus::~AnsweringBus() {
  stop_.store(true);
  if (answering_.joinable()) answering_.join();
}

void AnsweringBus::check(const std::string& who) const {
  std::lock_guard<std::mutex> lock(error_mutex_);
  if (!error_.empty()) throw std::runtime_error(fmt::format("{}: {}", who, error_));
}

std::uint64_t AnsweringBus::take_sent_bytes(const std::string& kind) {
  std::uint64_t total = 0;
  for (const auto& [k, bytes] : bus_.traffic().sent)
    if (channel::base_kind(k) == kind) total += bytes;
  return total - std::exchange(sent_taken_, total);
}

PairInbox::PairInbox(const RunContext& ctx, const std::string& sender, std::vector<Source> sources,
                     const std::vector<Source>& heard, double patience_s, std::string self, std::string what,
                     std::string peer)
    : sources_(std::move(sources)),
      heard_(ranks_of(heard)),
      patience_s_(patience_s),
      self_(std::move(self)),
      what_(std::move(what)),
      peer_(std::move(peer)),
      bus_(ctx, sender, channels_of(heard)) {}

bool PairInbox::wait_within(std::int64_t step, double seconds, const std::function<void()>& serve) {
  const auto& ctx = bus_.context();
  const double until = seconds_now() + seconds;
  if (waiting_for_ != step) {
    waiting_for_ = step;
    waiting_since_ = last_asked_ = seconds_now();
  }
  for (;;) {
    std::size_t arrived = 0;
    for (const Source& s : sources_) arrived += pending_.count({s.channel, step});
    if (arrived == sources_.size()) {
      waiting_for_ = -1;
      return true;
    }
    bus_.poll(std::max(0.0, std::min(0.05, until - seconds_now())),
              [&](const Received& msg) { pending_[{msg.kind, msg.envelope.step}] = msg; });
    // A peer that sends this step's cells on a pair the map of the step does not have works
    // from another map (the boxes moved on one node only).
    for (const auto& [key, msg] : pending_) {
      if (key.second != step) continue;
      const bool source = std::any_of(sources_.begin(), sources_.end(),
                                      [&](const Source& s) { return s.channel == key.first; });
      if (!source)
        throw std::runtime_error(fmt::format("{}: a {} of step {} from {} {}, which the overlap map of the step does "
                                             "not pair it with",
                                             self_, what_, step, peer_, heard_.count(key.first) ? heard_.at(key.first) : -1));
    }
    if (serve) serve();
    const double now = seconds_now();
    if (now - last_asked_ > ctx.retry_s) {
      for (const Source& s : sources_)
        if (!pending_.count({s.channel, step})) bus_.request_resend(s.channel, step);
      last_asked_ = now;
    }
    if (now - waiting_since_ > patience_s_) {
      for (const Source& s : sources_)
        if (!pending_.count({s.channel, step}))
          throw std::runtime_error(fmt::format("{}: no {} of step {} from {} {} within {:.0f} s", self_, what_, step,
                                               peer_, s.rank, patience_s_));
    }
    if (now >= until) return false;
  }
}

void PairInbox::forget_through(std::int64_t step) {
  for (auto it = pending_.begin(); it != pending_.end();) it = it->first.second <= step ? pending_.erase(it) : std::next(it);
}

std::uint64_t PairInbox::take_received_bytes() {
  std::uint64_t total = 0;
  for (const auto& [kind, bytes] : bus_.traffic().received) total += bytes;
  return total - std::exchange(received_taken_, total);
}

FluidRankPublisher::FluidRankPublisher(const RunContext& ctx, int rank, int ranks, int particle_ranks,
                                       const std::map<int, std::vector<int>>& readers,
                                       const std::vector<int>& global_of_local)
    : rank_(rank), ranks_(ranks), particle_ranks_(particle_ranks), out_(ctx, rank_sender("fluid", rank)) {
  for (std::size_t i = 0; i < global_of_local.size(); ++i) local_of_global_[global_of_local[i]] = static_cast<int>(i);
  replan(readers);
}

void FluidRankPublisher::replan(const std::map<int, std::vector<int>>& readers) {
  std::map<int, Reader> planned;
  for (const auto& [p, cells] : readers) {
    Reader r{channel::of_pair(channel::fluid_state, rank_, ranks_, p, particle_ranks_), cells, {}};
    for (int c : cells) {
      const auto it = local_of_global_.find(c);
      if (it == local_of_global_.end())
        throw std::runtime_error(
            fmt::format("the overlap map gives particle rank {} cell {} of fluid rank {}, which does not own it", p, c,
                        rank_));
      r.local_index.push_back(it->second);
    }
    planned.emplace(p, std::move(r));
  }
  readers_ = std::move(planned);
}

void FluidRankPublisher::publish(const fluid_state_t& local, std::int64_t step) {
  out_.check(fmt::format("fluid rank {}", rank_));
  for (const auto& [p, r] : readers_) {
    fluid_partition_t msg = slice_partition(local, r.cells, r.local_index, rank_, p);
    out_.bus().publish(r.channel, msg, step, /*keep=*/true);
  }
  out_.bus().forget_before(step - 1);
}

std::size_t FluidRankPublisher::cells_published() const {
  std::size_t n = 0;
  for (const auto& [p, r] : readers_) n += r.cells.size();
  return n;
}

namespace {

// The pair channel of this rank with the other node's rank `peer`.
std::string pair_channel(const std::string& kind, int rank, int ranks, int peer, int peer_ranks, bool fluid_side) {
  return fluid_side ? channel::of_pair(kind, rank, ranks, peer, peer_ranks)
                    : channel::of_pair(kind, peer, peer_ranks, rank, ranks);
}

// One source per rank of the other node this rank exchanges with, ascending.
std::vector<PairInbox::Source> pair_sources(const std::string& kind, const std::map<int, std::vector<int>>& peers,
                                            int rank, int ranks, int peer_ranks, bool fluid_side,
                                            std::vector<std::vector<int>>& cells) {
  std::vector<PairInbox::Source> sources;
  cells.clear();
  for (const auto& [peer, peer_cells] : peers) {
    sources.push_back({peer, pair_channel(kind, rank, ranks, peer, peer_ranks, fluid_side)});
    cells.push_back(peer_cells);
  }
  return sources;
}

// Every pair channel of this rank: what it hears, whichever of them the map of a step uses.
std::vector<PairInbox::Source> every_pair(const std::string& kind, int rank, int ranks, int peer_ranks,
                                          bool fluid_side) {
  std::vector<PairInbox::Source> all;
  for (int peer = 0; peer < peer_ranks; ++peer)
    all.push_back({peer, pair_channel(kind, rank, ranks, peer, peer_ranks, fluid_side)});
  return all;
}

}  // namespace

ParticleRankReceiver::ParticleRankReceiver(const RunContext& ctx, int rank, int ranks, int fluid_ranks,
                                           const std::map<int, std::vector<int>>& from, std::string mesh_hash,
                                           int n_cells, double patience_s)
    : rank_(rank),
      ranks_(ranks),
      fluid_ranks_(fluid_ranks),
      mesh_hash_(std::move(mesh_hash)),
      n_cells_(n_cells),
      in_(ctx, rank_sender("particles", rank),
          pair_sources(channel::fluid_state, from, rank, ranks, fluid_ranks, /*fluid_side=*/false, cells_),
          every_pair(channel::fluid_state, rank, ranks, fluid_ranks, /*fluid_side=*/false), patience_s,
          fmt::format("particle rank {}", rank), "fluid state", "fluid rank") {}

void ParticleRankReceiver::replan(const std::map<int, std::vector<int>>& from) {
  in_.set_sources(pair_sources(channel::fluid_state, from, rank_, ranks_, fluid_ranks_, /*fluid_side=*/false, cells_));
}

fluid_state_t ParticleRankReceiver::receive(std::int64_t step, const std::function<void()>& serve) {
  for (;;)
    if (auto whole = receive_within(step, 0.05, serve)) return std::move(*whole);
}

std::optional<fluid_state_t> ParticleRankReceiver::receive_within(std::int64_t step, double seconds,
                                                                  const std::function<void()>& serve) {
  if (!in_.wait_within(step, seconds, serve)) return std::nullopt;
  fluid_state_t whole;
  whole.mesh_hash = mesh_hash_;
  resize_cells(whole, n_cells_);
  for (std::size_t i = 0; i < cells_.size(); ++i) {
    const std::string why = take_partition(in_.message(i, step).as<fluid_partition_t>(), cells_[i],
                                           in_.sources()[i].rank, rank_, whole);
    if (!why.empty()) throw std::runtime_error(fmt::format("step {}: {}", step, why));
  }
  in_.forget_through(step);
  return whole;
}

ParticleRankPublisher::ParticleRankPublisher(const RunContext& ctx, int rank, int ranks, int fluid_ranks,
                                             const std::map<int, std::vector<int>>& from)
    : rank_(rank), ranks_(ranks), fluid_ranks_(fluid_ranks), out_(ctx, rank_sender("particles", rank)) {
  replan(from);
}

void ParticleRankPublisher::replan(const std::map<int, std::vector<int>>& from) {
  fluids_.clear();
  for (const auto& [f, cells] : from)
    fluids_.emplace(f, Fluid{channel::of_pair(channel::particle_feedback, f, fluid_ranks_, rank_, ranks_), cells});
}

void ParticleRankPublisher::publish(const particle_feedback_t& partial, std::int64_t step) {
  out_.check(fmt::format("particle rank {}", rank_));
  for (const auto& [f, fluid] : fluids_) {
    feedback_partition_t msg = slice_feedback(partial, fluid.cells, f, rank_);
    out_.bus().publish(fluid.channel, msg, step, /*keep=*/true);
  }
  out_.bus().forget_before(step - 1);
}

FluidRankReceiver::FluidRankReceiver(const RunContext& ctx, int rank, int ranks, int particle_ranks,
                                     const std::map<int, std::vector<int>>& readers, std::string mesh_hash,
                                     int n_cells, double patience_s)
    : rank_(rank),
      ranks_(ranks),
      particle_ranks_(particle_ranks),
      mesh_hash_(std::move(mesh_hash)),
      n_cells_(n_cells),
      in_(ctx, rank_sender("fluid", rank),
          pair_sources(channel::particle_feedback, readers, rank, ranks, particle_ranks, /*fluid_side=*/true, cells_),
          every_pair(channel::particle_feedback, rank, ranks, particle_ranks, /*fluid_side=*/true), patience_s,
          fmt::format("fluid rank {}", rank), "feedback", "particle rank") {}

void FluidRankReceiver::replan(const std::map<int, std::vector<int>>& readers) {
  in_.set_sources(
      pair_sources(channel::particle_feedback, readers, rank_, ranks_, particle_ranks_, /*fluid_side=*/true, cells_));
}

particle_feedback_t FluidRankReceiver::receive(std::int64_t step, const std::function<void()>& serve) {
  for (;;)
    if (auto sum = receive_within(step, 0.05, serve)) return std::move(*sum);
}

std::optional<particle_feedback_t> FluidRankReceiver::receive_within(std::int64_t step, double seconds,
                                                                     const std::function<void()>& serve) {
  if (!in_.wait_within(step, seconds, serve)) return std::nullopt;
  particle_feedback_t sum;
  sum.mesh_hash = mesh_hash_;
  resize_cells(sum, n_cells_);
  for (std::size_t i = 0; i < cells_.size(); ++i) {  // ascending particle rank: the same sums every run
    const std::string why = add_feedback_partition(in_.message(i, step).as<feedback_partition_t>(), cells_[i], rank_,
                                                   in_.sources()[i].rank, sum);
    if (!why.empty()) throw std::runtime_error(fmt::format("step {}: {}", step, why));
  }
  in_.forget_through(step);
  return sum;
}

std::map<int, std::vector<int>> readers_of(const OverlapMap& map, int fluid_rank) {
  std::map<int, std::vector<int>> readers;
  for (std::size_t p = 0; p < map.from.size(); ++p)
    if (const auto it = map.from[p].find(fluid_rank); it != map.from[p].end()) readers[static_cast<int>(p)] = it->second;
  return readers;
}

std::optional<FluidRankEnd> open_one_rank_fluid_end(FluidPort& port, const mesh_t& mesh, const RunContext& ctx) {
  const int particle_ranks = port.peer_ranks();
  if (!partitioned(1, particle_ranks)) return std::nullopt;
  const FluidDecomposition fluid{1, std::vector<int>(static_cast<std::size_t>(mesh.n_cells), 0)};
  fluid_decomposition_t partition = decomposition_message(mesh.mesh_hash, fluid);
  port.bus().publish(channel::partition, partition, 0, /*keep=*/true);
  const ParticleDecomposition particles = particle_decomposition_of(
      port.wait_for_kept(channel::domain, "the particle ranks' boxes").as<particle_domain_t>(), mesh);
  const OverlapMap map = overlap_map(cell_points_of(mesh), fluid, particles, period_of(mesh));
  const auto readers = readers_of(map, 0);
  std::vector<int> identity(static_cast<std::size_t>(mesh.n_cells));
  for (int c = 0; c < mesh.n_cells; ++c) identity[static_cast<std::size_t>(c)] = c;
  FluidRankEnd end;
  end.state = std::make_unique<FluidRankPublisher>(ctx, 0, 1, particle_ranks, readers, identity);
  end.feedback = std::make_unique<FluidRankReceiver>(ctx, 0, 1, particle_ranks, readers, mesh.mesh_hash, mesh.n_cells,
                                                     kCoordinatorPatience * ctx.timeout_s);
  return end;
}

std::optional<ParticleRankEnd> open_one_rank_particle_end(ParticlePort& port, const mesh_t& mesh,
                                                          const RunContext& ctx) {
  const int fluid_ranks = port.peer_ranks();
  if (!partitioned(fluid_ranks, 1)) return std::nullopt;
  Box box;
  if (!mesh.points.empty()) box = {particles::Vec3(mesh.points[0][0], mesh.points[0][1], mesh.points[0][2]), {}};
  box.hi = box.lo;
  for (const auto& p : mesh.points) {
    const particles::Vec3 x(p[0], p[1], p[2]);
    box.lo = box.lo.cwiseMin(x);
    box.hi = box.hi.cwiseMax(x);
  }
  const ParticleDecomposition particles{{box}, 0.0};
  particle_domain_t domain = domain_message(mesh.mesh_hash, particles);
  port.bus().publish(channel::domain, domain, 0, /*keep=*/true);
  const FluidDecomposition fluid = fluid_decomposition_of(
      port.wait_for_kept(channel::partition, "the fluid's decomposition").as<fluid_decomposition_t>(), mesh);
  const OverlapMap map = overlap_map(cell_points_of(mesh), fluid, particles, period_of(mesh));
  ParticleRankEnd end;
  end.state = std::make_unique<ParticleRankReceiver>(ctx, 0, 1, fluid_ranks, map.from[0], mesh.mesh_hash, mesh.n_cells,
                                                     kCoordinatorPatience * ctx.timeout_s);
  end.feedback = std::make_unique<ParticleRankPublisher>(ctx, 0, 1, fluid_ranks, map.from[0]);
  return end;
}

}  // namespace hemo
