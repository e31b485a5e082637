// SPDX-License-Identifier: GPL-3.0-or-later
#include "rank_exchange.h"

#include "cell_fields.h"

#include <fmt/format.h>

#include <chrono>
#include <stdexcept>

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

fluid_state_t ParticleRankReceiver::receive(std::int64_t step) {
  fluid_state_t whole;
  whole.mesh_hash = mesh_hash_;
  resize_cells(whole, n_cells_);
  std::vector<bool> taken(sources_.size(), false);
  std::size_t left = sources_.size();
  const auto& ctx = bus_.context();
  const double start = seconds_now();
  double last_asked = start;
  for (;;) {
    for (std::size_t i = 0; i < sources_.size(); ++i) {
      if (taken[i]) continue;
      const auto it = pending_.find({sources_[i].channel, step});
      if (it == pending_.end()) continue;
      const std::string why = take_partition(it->second.as<fluid_partition_t>(), sources_[i].cells,
                                             sources_[i].fluid_rank, rank_, whole);
      if (!why.empty()) throw std::runtime_error(fmt::format("step {}: {}", step, why));
      taken[i] = true;
      --left;
    }
    if (left == 0) break;
    bus_.poll(0.05, [&](const Received& msg) { pending_[{msg.kind, msg.envelope.step}] = msg; });
    const double now = seconds_now();
    if (now - last_asked > ctx.retry_s) {
      for (std::size_t i = 0; i < sources_.size(); ++i)
        if (!taken[i] && !pending_.count({sources_[i].channel, step}))
          bus_.request_resend(sources_[i].channel, step);
      last_asked = now;
    }
    if (now - start > patience_s_) {
      std::size_t i = 0;
      while (taken[i]) ++i;
      throw std::runtime_error(fmt::format("particle rank {}: no fluid state of step {} from fluid rank {} within {:.0f} s",
                                           rank_, step, sources_[i].fluid_rank, patience_s_));
    }
  }
  // What is older than this step is no longer wanted (a resend answered twice, an early step's).
  for (auto it = pending_.begin(); it != pending_.end();) it = it->first.second <= step ? pending_.erase(it) : std::next(it);
  return whole;
}

}  // namespace hemo
