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

std::vector<std::string> channels_of(const std::vector<std::pair<int, std::string>>& sources) {
  std::vector<std::string> out;
  for (const auto& s : sources) out.push_back(s.second);
  return out;
}

}  // namespace

std::string rank_sender(const std::string& role, int rank) { return role + "." + std::to_string(rank); }

FluidRankPublisher::FluidRankPublisher(const RunContext& ctx, int rank, int ranks, int particle_ranks,
                                       const std::map<int, std::vector<int>>& readers,
                                       const std::vector<int>& global_of_local)
    : rank_(rank), bus_(ctx, rank_sender("fluid", rank), {channel::resend}) {
  std::map<int, int> local_of_global;
  for (std::size_t i = 0; i < global_of_local.size(); ++i) local_of_global[global_of_local[i]] = static_cast<int>(i);
  for (const auto& [p, cells] : readers) {
    Reader r{channel::of_pair(channel::fluid_state, rank, ranks, p, particle_ranks), cells, {}};
    for (int c : cells) {
      const auto it = local_of_global.find(c);
      if (it == local_of_global.end())
        throw std::runtime_error(
            fmt::format("the overlap map gives particle rank {} cell {} of fluid rank {}, which does not own it", p, c,
                        rank));
      r.local_index.push_back(it->second);
    }
    readers_.emplace(p, std::move(r));
  }
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

FluidRankPublisher::~FluidRankPublisher() {
  stop_.store(true);
  if (answering_.joinable()) answering_.join();
}

void FluidRankPublisher::publish(const fluid_state_t& local, std::int64_t step) {
  {
    std::lock_guard<std::mutex> lock(error_mutex_);
    if (!error_.empty()) throw std::runtime_error(fmt::format("fluid rank {}: {}", rank_, error_));
  }
  for (const auto& [p, r] : readers_) {
    fluid_partition_t msg = slice_partition(local, r.cells, r.local_index, rank_, p);
    bus_.publish(r.channel, msg, step, /*keep=*/true);
  }
  bus_.forget_before(step - 1);
}

std::size_t FluidRankPublisher::cells_published() const {
  std::size_t n = 0;
  for (const auto& [p, r] : readers_) n += r.cells.size();
  return n;
}

std::uint64_t FluidRankPublisher::take_sent_bytes() {
  std::uint64_t total = 0;
  for (const auto& [kind, bytes] : bus_.traffic().sent)
    if (channel::base_kind(kind) == channel::fluid_state) total += bytes;
  return total - std::exchange(sent_taken_, total);
}

std::uint64_t ParticleRankReceiver::take_received_bytes() {
  std::uint64_t total = 0;
  for (const auto& [kind, bytes] : bus_.traffic().received) total += bytes;
  return total - std::exchange(received_taken_, total);
}

ParticleRankReceiver::ParticleRankReceiver(const RunContext& ctx, int rank, int ranks, int fluid_ranks,
                                           const std::map<int, std::vector<int>>& from, std::string mesh_hash,
                                           int n_cells, double patience_s)
    : rank_(rank),
      mesh_hash_(std::move(mesh_hash)),
      n_cells_(n_cells),
      patience_s_(patience_s),
      bus_(ctx, rank_sender("particles", rank), [&] {
        std::vector<std::pair<int, std::string>> channels;
        for (const auto& [f, cells] : from)
          channels.emplace_back(f, channel::of_pair(channel::fluid_state, f, fluid_ranks, rank, ranks));
        return channels_of(channels);
      }()) {
  for (const auto& [f, cells] : from)
    sources_.push_back({f, channel::of_pair(channel::fluid_state, f, fluid_ranks, rank, ranks), cells});
}

fluid_state_t ParticleRankReceiver::receive(std::int64_t step, const std::function<void()>& serve) {
  for (;;)
    if (auto whole = receive_within(step, 0.05, serve)) return std::move(*whole);
}

std::optional<fluid_state_t> ParticleRankReceiver::receive_within(std::int64_t step, double seconds,
                                                                  const std::function<void()>& serve) {
  const auto& ctx = bus_.context();
  const double until = seconds_now() + seconds;
  if (waiting_for_ != step) {
    waiting_for_ = step;
    waiting_since_ = last_asked_ = seconds_now();
  }
  for (;;) {
    std::size_t arrived = 0;
    for (const Source& s : sources_) arrived += pending_.count({s.channel, step});
    if (arrived == sources_.size()) break;
    bus_.poll(std::max(0.0, std::min(0.05, until - seconds_now())),
              [&](const Received& msg) { pending_[{msg.kind, msg.envelope.step}] = msg; });
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
          throw std::runtime_error(fmt::format("particle rank {}: no fluid state of step {} from fluid rank {} within {:.0f} s",
                                               rank_, step, s.fluid_rank, patience_s_));
    }
    if (now >= until) return std::nullopt;
  }
  fluid_state_t whole;
  whole.mesh_hash = mesh_hash_;
  resize_cells(whole, n_cells_);
  for (const Source& s : sources_) {
    const std::string why = take_partition(pending_.at({s.channel, step}).as<fluid_partition_t>(), s.cells,
                                           s.fluid_rank, rank_, whole);
    if (!why.empty()) throw std::runtime_error(fmt::format("step {}: {}", step, why));
  }
  // What is older than this step is no longer wanted (a resend answered twice, an early step's).
  for (auto it = pending_.begin(); it != pending_.end();) it = it->first.second <= step ? pending_.erase(it) : std::next(it);
  waiting_for_ = -1;
  return whole;
}

std::unique_ptr<FluidRankPublisher> open_one_rank_fluid_end(FluidPort& port, const mesh_t& mesh,
                                                            const RunContext& ctx) {
  const int particle_ranks = port.peer_ranks();
  if (!partitioned(1, particle_ranks)) return nullptr;
  const FluidDecomposition fluid{1, std::vector<int>(static_cast<std::size_t>(mesh.n_cells), 0)};
  fluid_decomposition_t partition = decomposition_message(mesh.mesh_hash, fluid);
  port.bus().publish(channel::partition, partition, 0, /*keep=*/true);
  const ParticleDecomposition particles = particle_decomposition_of(
      port.wait_for_kept(channel::domain, "the particle ranks' boxes").as<particle_domain_t>(), mesh);
  const OverlapMap map = overlap_map(cell_points_of(mesh), fluid, particles, period_of(mesh));
  std::map<int, std::vector<int>> readers;
  for (std::size_t p = 0; p < map.from.size(); ++p)
    if (const auto it = map.from[p].find(0); it != map.from[p].end()) readers[static_cast<int>(p)] = it->second;
  std::vector<int> identity(static_cast<std::size_t>(mesh.n_cells));
  for (int c = 0; c < mesh.n_cells; ++c) identity[static_cast<std::size_t>(c)] = c;
  return std::make_unique<FluidRankPublisher>(ctx, 0, 1, particle_ranks, readers, identity);
}

std::unique_ptr<ParticleRankReceiver> open_one_rank_particle_end(ParticlePort& port, const mesh_t& mesh,
                                                                 const RunContext& ctx) {
  const int fluid_ranks = port.peer_ranks();
  if (!partitioned(fluid_ranks, 1)) return nullptr;
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
  return std::make_unique<ParticleRankReceiver>(ctx, 0, 1, fluid_ranks, map.from[0], mesh.mesh_hash, mesh.n_cells,
                                                kCoordinatorPatience * ctx.timeout_s);
}

}  // namespace hemo
