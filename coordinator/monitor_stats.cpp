// SPDX-License-Identifier: GPL-3.0-or-later
#include "monitor_stats.h"

#include "momentum_balance.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace hemo {

using nlohmann::json;

namespace {
// Silent this long and a process is shown as such: heartbeats come twice a second.
constexpr double kAliveWithin_s = 2.0;

// "FLUID_STATE" of "FLUID_STATE.1.0", a pair's channel in the partitioned exchange (bus.h,
// channel::of_pair): its latency is its direction's, as the whole-mesh message's is.
std::string kind_of(const std::string& channel) { return channel.substr(0, channel.find('.')); }

// The kinds a publisher keeps and publishes again on request: seen twice, a message was resent.
bool resendable(const std::string& kind) {
  return kind == "STEP" || kind == "FLUID_STATE" || kind == "PARTICLE_FEEDBACK" || kind == "STEP_DONE" ||
         kind == "MESH";
}

json or_null(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

json counts_json(const ProcessCounts& c) {
  return {{"accepted", c.accepted},
          {"rejected",
           {{"short", c.rejected_short},
            {"foreign", c.rejected_foreign},
            {"auth", c.rejected_auth},
            {"prestart", c.rejected_prestart},
            {"replay", c.rejected_replay},
            {"undecodable", c.rejected_undecodable}}},
          {"rejected_total", c.rejected_short + c.rejected_foreign + c.rejected_auth + c.rejected_prestart +
                                 c.rejected_replay + c.rejected_undecodable}};
}
}  // namespace

const std::vector<Direction>& latency_directions() {
  static const std::vector<Direction> d = {{"FLUID_STATE", "fluid -> particles"},
                                           {"PARTICLE_FEEDBACK", "particles -> fluid"},
                                           {"STEP", "coordinator -> nodes"},
                                           {"STEP_DONE", "nodes -> coordinator"}};
  return d;
}

MonitorStats::MonitorStats(std::string run_id, long total_steps, double rate_window_s)
    : run_id_(std::move(run_id)), total_steps_(total_steps), rate_window_s_(rate_window_s) {}

void MonitorStats::message(const std::string& kind, const std::string& sender, std::int64_t step, std::size_t bytes,
                           std::int64_t sent_unix_ns, std::int64_t received_unix_us, double now_s) {
  if (started_s_ < 0) started_s_ = window_start_s_ = now_s;
  auto& c = channels_[kind];
  ++c.msgs, ++c.window_msgs;
  c.bytes += bytes, c.window_bytes += bytes;
  c.last_step = step;
  c.last_sender = sender;
  auto& p = processes_[sender];
  p.last_heard_s = now_s;
  if (kind == "RESEND") ++resend_requests_, ++window_resend_requests_;
  if (resendable(kind_of(kind)) && !seen_.insert({kind, sender, step}).second) ++repeats_;
  if (sent_unix_ns > 0 && received_unix_us > 0) {
    auto& l = latency_[kind_of(kind)];
    // In integers first: as doubles, nanoseconds since 1970 keep only about 256 ns.
    const double ms = double(received_unix_us * 1000 - sent_unix_ns) * 1e-6;
    l.max_ms = l.n ? std::max(l.max_ms, ms) : ms;
    ++l.n;
    l.sum_ms += ms;
    l.last_ms = ms;
  }
}

void MonitorStats::step_order(std::int64_t step, double time_s) {
  if (step >= ordered_step_) {
    ordered_step_ = step;
    time_s_ = time_s;
  }
}

void MonitorStats::step_done(const std::string& node, std::int64_t step, bool ok, const std::string& error,
                             double compute_s, double wait_s, const std::vector<std::string>& names,
                             const std::vector<double>& values) {
  auto& n = nodes_[node];
  if (!ok) {
    n.ok = false;
    n.error = error;
    return;
  }
  if (step <= n.step) return;  // a resend, or a report from before a restart
  n.step = step;
  n.window_compute += compute_s;
  n.window_wait += wait_s;
  ++n.window_reports;
  n.last_compute = compute_s;
  n.last_wait = wait_s;
  n.diagnostics.clear();
  for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) n.diagnostics.emplace_back(names[i], values[i]);
  if (node != "fluid") return;
  const auto tau = std::find(names.begin(), names.end(), "wall_shear_stress_Pa");
  const std::size_t at = static_cast<std::size_t>(tau - names.begin());
  if (tau != names.end() && at < values.size() && std::isfinite(values[at])) {
    wall_shear_.window_sum += values[at];
    ++wall_shear_.window_samples;
    wall_shear_.last_Pa = values[at];
  }
}

void MonitorStats::rank_done(const std::string& node, int rank, std::int64_t step, double compute_s, double wait_s,
                             const std::vector<std::string>& names, const std::vector<double>& values) {
  auto& [last, shown] = nodes_[node].ranks[rank];
  if (step <= last && !shown.empty()) return;  // a resend, or a report from before a restart
  last = step;
  shown = {{fmt::format("rank{}_compute_s", rank), compute_s}, {fmt::format("rank{}_wait_s", rank), wait_s}};
  for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) shown.emplace_back(names[i], values[i]);
}

void MonitorStats::balance_reference(const Scene& scene) {
  wall_shear_.imposed_Pa = imposed_wall_shear_stress(scene);
  wall_shear_.viscosity_Pa_s = scene.plasma.viscosity;
  wall_shear_.mesh_ratio = mesh_balance_ratio(scene);
}

void MonitorStats::heartbeat(const std::string& sender, double uptime_s, const ProcessCounts& counts) {
  auto& p = processes_[sender];
  p.uptime_s = uptime_s;
  p.counts = counts;
}

std::int64_t MonitorStats::completed_step() const {
  // A coupling step is done when both nodes have reported it; the coordinator orders the next then.
  const auto f = nodes_.find("fluid"), p = nodes_.find("particles");
  if (f == nodes_.end() || p == nodes_.end()) return -1;
  return std::min(f->second.step, p->second.step);
}

RateEta rate_and_eta(const std::deque<std::pair<double, std::int64_t>>& history, double window_s, long total) {
  RateEta r;
  if (history.size() < 2) return r;
  const auto& newest = history.back();
  // The oldest sample within the window, but never the newest itself.
  std::size_t from = history.size() - 2;
  while (from > 0 && newest.first - history[from - 1].first <= window_s) --from;
  const auto& oldest = history[from];
  const double span = newest.first - oldest.first;
  if (span <= 0 || oldest.second < 0) return r;
  r.steps_per_s = double(newest.second - oldest.second) / span;
  if (total > 0) {
    const double left = double(std::max<std::int64_t>(0, total - newest.second));
    if (left == 0)
      r.eta_s = 0.0;
    else if (*r.steps_per_s > 0)
      r.eta_s = left / *r.steps_per_s;
  }
  return r;
}

json MonitorStats::close_interval(double now_s, double unix_s) {
  if (started_s_ < 0) started_s_ = window_start_s_ = now_s;
  const double span = now_s - window_start_s_;
  const std::int64_t completed = completed_step();

  json row;
  row["schema"] = kMonitorSchema;
  row["run_id"] = run_id_;
  row["unix_time_s"] = unix_s;
  row["elapsed_s"] = now_s - started_s_;
  row["interval_s"] = span;
  row["ordered_step"] = ordered_step_;
  row["completed_step"] = completed;
  row["total_steps"] = total_steps_ > 0 ? json(total_steps_) : json(nullptr);
  row["time_s"] = time_s_;

  // The interval's own rate, and the smoothed one the ETA uses; only once a completed step has
  // been seen at both ends (a monitor that joins mid-run knows nothing of the steps before).
  std::optional<double> interval_rate;
  if (completed >= 0 && interval_start_completed_ >= 0 && span > 0)
    interval_rate = double(completed - interval_start_completed_) / span;
  if (completed >= 0) history_.emplace_back(now_s, completed);
  while (history_.size() > 2 && now_s - history_[1].first > rate_window_s_) history_.pop_front();
  const auto rate = rate_and_eta(history_, rate_window_s_, total_steps_);
  row["steps_per_s"] = or_null(interval_rate);
  row["steps_per_s_smoothed"] = or_null(rate.steps_per_s);
  row["eta_s"] = or_null(rate.eta_s);
  interval_start_completed_ = completed;

  json latency = json::object();
  for (const auto& d : latency_directions()) {
    const auto it = latency_.find(d.channel);
    json l = {{"from_to", d.from_to}, {"n", 0}, {"mean", nullptr}, {"max", nullptr}, {"last", nullptr}};
    if (it != latency_.end() && it->second.n > 0) {
      l["n"] = it->second.n;
      l["mean"] = it->second.sum_ms / double(it->second.n);
      l["max"] = it->second.max_ms;
      l["last"] = it->second.last_ms;
    }
    latency[d.channel] = l;
  }
  row["latency_ms"] = latency;
  latency_.clear();

  json channels = json::object();
  for (auto& [kind, c] : channels_) {
    channels[kind] = {{"msgs", c.msgs},
                      {"msgs_per_s", span > 0 ? double(c.window_msgs) / span : 0.0},
                      {"bytes_per_s", span > 0 ? double(c.window_bytes) / span : 0.0},
                      {"bytes_per_msg", c.msgs ? double(c.bytes) / double(c.msgs) : 0.0},
                      {"last_step", c.last_step},
                      {"last_sender", c.last_sender}};
    c.window_msgs = c.window_bytes = 0;
  }
  row["channels"] = channels;

  json nodes = json::object(), diagnostics = json::object();
  for (auto& [name, n] : nodes_) {
    json j = {{"step", n.step}, {"reports", n.window_reports}, {"ok", n.ok}};
    j["compute_s"] = n.window_reports ? json(n.window_compute / n.window_reports) : json(nullptr);
    j["wait_s"] = n.window_reports ? json(n.window_wait / n.window_reports) : json(nullptr);
    j["last_compute_s"] = n.last_compute;
    j["last_wait_s"] = n.last_wait;
    if (!n.ok) j["error"] = n.error;
    nodes[name] = j;
    json d = json::object();
    for (const auto& [k, v] : n.diagnostics) d[k] = std::isfinite(v) ? json(v) : json(nullptr);
    for (const auto& [r, rank] : n.ranks)
      for (const auto& [k, v] : rank.second) d[k] = std::isfinite(v) ? json(v) : json(nullptr);
    if (n.step >= 0) diagnostics[name] = {{"step", n.step}, {"values", d}};
    n.window_compute = n.window_wait = 0;
    n.window_reports = 0;
  }
  row["nodes"] = nodes;
  row["diagnostics"] = diagnostics;

  // The momentum balance: the interval's mean of the fluid's reports (the latest when none came in it).
  auto& w = wall_shear_;
  const std::optional<double> tau =
      w.window_samples > 0 ? std::optional<double>(w.window_sum / w.window_samples) : w.last_Pa;
  auto over = [](const std::optional<double>& a, const std::optional<double>& b) -> std::optional<double> {
    if (a && b && *b > 0) return *a / *b;
    return std::nullopt;
  };
  row["balance"] = {{"wall_shear_stress_Pa", or_null(tau)},
                    {"samples", w.window_samples},
                    {"imposed_wall_shear_stress_Pa", or_null(w.imposed_Pa)},
                    {"ratio", or_null(over(tau, w.imposed_Pa))},
                    {"mesh_ratio", or_null(w.mesh_ratio)},
                    {"wall_shear_rate_per_s", or_null(over(tau, w.viscosity_Pa_s))},
                    {"imposed_wall_shear_rate_per_s", or_null(over(w.imposed_Pa, w.viscosity_Pa_s))}};
  w.window_sum = 0;
  w.window_samples = 0;

  row["resends"] = {{"requests", resend_requests_},
                    {"requests_in_interval", window_resend_requests_},
                    {"repeated_messages", repeats_}};
  window_resend_requests_ = 0;

  json processes = json::object();
  for (const auto& [sender, p] : processes_) {
    json j = p.counts ? counts_json(*p.counts) : json::object();
    const double silent = now_s - p.last_heard_s;
    j["alive"] = silent < kAliveWithin_s;
    j["silent_s"] = silent;
    j["uptime_s"] = p.uptime_s;
    j["counts_known"] = p.counts.has_value();
    processes[sender] = j;
  }
  row["processes"] = processes;
  if (own_) row["monitor"] = counts_json(*own_);

  window_start_s_ = now_s;
  return row;
}

namespace {
std::string num(const json& v, const char* format, const char* none = "-") {
  if (!v.is_number()) return none;
  return fmt::format(fmt::runtime(format), v.get<double>());
}

std::string duration(double s) {
  if (s < 60) return fmt::format("{:.0f} s", s);
  if (s < 3600) return fmt::format("{:.0f} min {:02.0f} s", std::floor(s / 60), std::fmod(s, 60));
  return fmt::format("{:.0f} h {:02.0f} min", std::floor(s / 3600), std::floor(std::fmod(s, 3600) / 60));
}

std::string counts_row(const std::string& who, const json& c) {
  const auto& r = c["rejected"];
  return fmt::format("{:<20} {:>10} {:>8} {:>8} {:>8} {:>9} {:>8} {:>11}\n", who, c["accepted"].get<long>(),
                     r["short"].get<long>(), r["foreign"].get<long>(), r["auth"].get<long>(), r["prestart"].get<long>(),
                     r["replay"].get<long>(), r["undecodable"].get<long>());
}
}  // namespace

std::string format_monitor_table(const json& row, const std::string& lcm_url) {
  std::string out;
  const auto total = row["total_steps"];
  out += fmt::format("run {}  bus {}  step {}{}  t = {:.6g} s  (monitoring {:.0f} s)\n",
                     row["run_id"].get<std::string>(), lcm_url, row["completed_step"].get<long>(),
                     total.is_number() ? fmt::format(" of {}", total.get<long>()) : std::string(),
                     row["time_s"].get<double>(), row["elapsed_s"].get<double>());
  const auto& eta = row["eta_s"];
  out += fmt::format("rate {} steps/s (this interval {})  ETA {}\n", num(row["steps_per_s_smoothed"], "{:.3g}"),
                     num(row["steps_per_s"], "{:.3g}"), eta.is_number() ? duration(eta.get<double>()) : "-");
  out += fmt::format("{:<20} {:>10} {:>10} {:>12} {:>12} {:>10}  {}\n", "channel", "msgs", "msgs/s", "bytes/s",
                     "bytes/msg", "last step", "sender");
  for (const auto& [name, c] : row["channels"].items())
    out += fmt::format("{:<20} {:>10} {:>10.1f} {:>12.0f} {:>12.0f} {:>10}  {}\n", name, c["msgs"].get<long>(),
                       c["msgs_per_s"].get<double>(), c["bytes_per_s"].get<double>(), c["bytes_per_msg"].get<double>(),
                       c["last_step"].get<long>(), c["last_sender"].get<std::string>());
  out += "latency, publish to receipt here (ms; across hosts as good as the clocks' agreement)\n";
  out += fmt::format("{:<20} {:<22} {:>6} {:>9} {:>9}\n", "channel", "direction", "msgs", "mean", "max");
  for (const auto& [name, l] : row["latency_ms"].items())
    out += fmt::format("{:<20} {:<22} {:>6} {:>9} {:>9}\n", name, l["from_to"].get<std::string>(), l["n"].get<long>(),
                       num(l["mean"], "{:.3f}"), num(l["max"], "{:.3f}"));
  const auto& b = row["balance"];
  if (b["wall_shear_stress_Pa"].is_number())
    out += fmt::format(
        "momentum balance: wall shear stress {} Pa = {} of the imposed {} Pa ({} on this mesh); "
        "wall shear rate {} of {} 1/s; {} step{} in this interval\n",
        num(b["wall_shear_stress_Pa"], "{:.4f}"), num(b["ratio"], "{:.3f}"),
        num(b["imposed_wall_shear_stress_Pa"], "{:.4f}"), num(b["mesh_ratio"], "{:.3f}"),
        num(b["wall_shear_rate_per_s"], "{:.1f}"), num(b["imposed_wall_shear_rate_per_s"], "{:.1f}"),
        b["samples"].get<int>(), b["samples"].get<int>() == 1 ? "" : "s");
  out += fmt::format("{:<20} {:>10} {:>12} {:>12}\n", "node", "step", "compute s", "wait s");
  for (const auto& [name, n] : row["nodes"].items())
    out += fmt::format("{:<20} {:>10} {:>12} {:>12}{}\n", name, n["step"].get<long>(), num(n["compute_s"], "{:.4g}"),
                       num(n["wait_s"], "{:.4g}"), n.contains("error") ? "  failed" : "");
  out += "nodes:";
  for (const auto& [sender, p] : row["processes"].items())
    out += fmt::format(
        "  {} {}", sender,
        p["alive"].get<bool>() ? std::string("alive") : fmt::format("silent {:.0f} s", p["silent_s"].get<double>()));
  // What each process dropped (from its heartbeat), and the monitor itself: only accepted
  // messages are in the tables above (replays and recordings from before it started are not).
  out += fmt::format("\n{:<20} {:>10} {:>8} {:>8} {:>8} {:>9} {:>8} {:>11}\n", "dropped by", "accepted", "short",
                     "foreign", "bad tag", "pre-start", "replay", "undecodable");
  for (const auto& [sender, p] : row["processes"].items())
    if (p["counts_known"].get<bool>()) out += counts_row(sender, p);
  if (row.contains("monitor")) out += counts_row("(this monitor)", row["monitor"]);
  const auto& r = row["resends"];
  out +=
      fmt::format("resend requests seen {} ({} in this interval); messages seen again {}\n", r["requests"].get<long>(),
                  r["requests_in_interval"].get<long>(), r["repeated_messages"].get<long>());
  for (const auto& [name, n] : row["nodes"].items())
    if (n.contains("error")) out += fmt::format("{} reported: {}\n", name, n["error"].get<std::string>());
  return out;
}

}  // namespace hemo
