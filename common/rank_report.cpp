// SPDX-License-Identifier: GPL-3.0-or-later
#include "rank_report.h"

#include "rank_exchange.h"

#include <hemo/heartbeat_t.hpp>
#include <hemo/step_done_t.hpp>

#include <fmt/format.h>

#include <chrono>
#include <stdexcept>
#include <utility>

namespace hemo {

Diagnostics rank_bytes(int rank, const TrafficBytes& bytes) {
  return {{fmt::format("rank{}_sent_B", rank), static_cast<double>(bytes.sent)},
          {fmt::format("rank{}_resent_B", rank), static_cast<double>(bytes.resent)},
          {fmt::format("rank{}_received_B", rank), static_cast<double>(bytes.received)},
          {fmt::format("rank{}_received_again_B", rank), static_cast<double>(bytes.received_again)}};
}

double RankReporter::now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

namespace {
constexpr double kHeartbeatPeriodS = 0.5;  // as every process's (NodePort's Heartbeat)
}  // namespace

RankReporter::RankReporter(const RunContext& ctx, const std::string& role, int rank)
    : role_(role),
      rank_(rank),
      channel_(channel::of_node_rank(channel::step_done, role, rank)),
      bus_(ctx, rank_sender(role, rank), {channel::resend}),
      step_started_(now()) {
  answering_ = std::thread([this, started = step_started_, beat = channel::of_node_rank(channel::heartbeat, role, rank)] {
    double beaten = 0;
    while (!stop_.load()) {
      try {
        if (now() - beaten >= kHeartbeatPeriodS) {
          heartbeat_t hb{};
          hb.uptime_s = now() - started;
          put_counters(bus_.counters(), hb);
          bus_.publish(beat, hb, -1);  // a heartbeat is of no step
          beaten = now();
        }
        bus_.poll(0.1, [](const Received&) {});  // the bus answers what it kept; nothing else is wanted
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(error_mutex_);
        error_ = e.what();
        return;
      }
    }
  });
}

RankReporter::~RankReporter() {
  stop_.store(true);
  if (answering_.joinable()) answering_.join();
}

void RankReporter::report(std::int64_t step, const Diagnostics& diag) {
  {
    std::lock_guard<std::mutex> lock(error_mutex_);
    if (!error_.empty()) throw std::runtime_error(fmt::format("{} rank {}: {}", role_, rank_, error_));
  }
  step_done_t done;
  done.node = role_;
  done.ok = true;
  done.compute_s = (computing_ended_at_ >= 0 ? computing_ended_at_ : now()) - step_started_;
  computing_ended_at_ = -1;
  done.wait_s = wait_s_;
  done.n_diagnostics = static_cast<int32_t>(diag.size());
  for (const auto& [name, value] : diag) {
    done.names.push_back(name);
    done.values.push_back(value);
  }
  bus_.publish(channel_, done, step, /*keep=*/true);
  bus_.forget_before(step - 1);
  waiting_since_ = now();
}

std::uint64_t RankReporter::take_sent_bytes() {
  std::uint64_t total = 0;
  for (const auto& [kind, bytes] : bus_.traffic().sent) total += bytes;
  return total - std::exchange(sent_taken_, total);
}

void RankReporter::begin_step() {
  step_started_ = now();
  wait_s_ = step_started_ - waiting_since_;
}

}  // namespace hemo
