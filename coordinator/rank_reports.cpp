// SPDX-License-Identifier: GPL-3.0-or-later
#include "rank_reports.h"

#include <algorithm>

namespace hemo {

RankReports::RankReports(int ranks, double now_s) { set_ranks(ranks, now_s); }

void RankReports::set_ranks(int ranks, double now_s) {
  Rank starting;
  starting.last_heard = now_s;
  ranks_.resize(static_cast<std::size_t>(std::max(ranks, 1)), starting);
}

void RankReports::heard(int rank, double now_s) {
  if (rank < 0 || rank >= this->ranks()) return;
  auto& r = ranks_[static_cast<std::size_t>(rank)];
  r.last_heard = std::max(r.last_heard, now_s);
  r.heard = true;
}

bool RankReports::reported(int rank, long step, double now_s) {
  if (rank < 0 || rank >= this->ranks()) return false;
  heard(rank, now_s);
  auto& r = ranks_[static_cast<std::size_t>(rank)];
  if (step <= r.step) return false;
  r.step = step;
  return true;
}

long RankReports::done_step() const {
  long done = ranks_.front().step;
  for (const auto& r : ranks_) done = std::min(done, r.step);
  return done;
}

std::vector<int> RankReports::missing(long step) const {
  std::vector<int> out;
  for (int r = 0; r < ranks(); ++r)
    if (ranks_[static_cast<std::size_t>(r)].step < step) out.push_back(r);
  return out;
}

std::optional<RankReports::Silence> RankReports::silent(double now_s, double timeout_s, double startup_s) const {
  for (int r = 1; r < ranks(); ++r) {
    const auto& rank = ranks_[static_cast<std::size_t>(r)];
    const double allowance = rank.heard ? timeout_s : std::max(timeout_s, startup_s);
    if (now_s - rank.last_heard > allowance) return Silence{r, rank.heard, now_s - rank.last_heard};
  }
  return std::nullopt;
}

void RankReports::forgive(double away_s, double now_s) {
  for (auto& r : ranks_) r.last_heard = std::min(now_s, r.last_heard + away_s);
}

std::string rank_list_words(const std::vector<int>& ranks, int of) {
  std::string list;
  for (const int r : ranks) list += (list.empty() ? "" : ", ") + std::to_string(r);
  return (ranks.size() == 1 ? "rank " : "ranks ") + list + " of " + std::to_string(of);
}

}  // namespace hemo
