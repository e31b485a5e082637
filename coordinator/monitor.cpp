// hemocosim monitor: a live view of a run's coupling traffic.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "commands.h"
#include "run_directory.h"

#include <hemo/heartbeat_t.hpp>
#include <hemo/step_done_t.hpp>

#include <fmt/format.h>

#include <chrono>
#include <csignal>
#include <map>
#include <unistd.h>

namespace hemo {

namespace {
volatile std::sig_atomic_t stop_monitor = 0;

struct ChannelStats {
  std::uint64_t count = 0, bytes = 0;
  std::uint64_t window_count = 0, window_bytes = 0;
  std::int64_t last_step = -1;
  std::string last_sender;
};

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

int monitor_command(const MonitorOptions& opt) {
  auto [dir, ctx] = RunDirectory::open(opt.run_dir);
  Bus bus(ctx, "monitor");
  std::signal(SIGINT, [](int) { stop_monitor = 1; });
  const bool clear = !opt.plain && isatty(STDOUT_FILENO);

  std::map<std::string, ChannelStats> channels;
  std::map<std::string, double> last_seen;  // sender -> time
  std::map<std::string, std::string> last_error;
  std::map<std::string, heartbeat_t> last_heartbeat;  // sender -> its latest, with its bus counters
  std::int64_t step = -1;
  const double start = now();
  double window_start = start;

  while (!stop_monitor && (opt.duration_s <= 0 || now() - start < opt.duration_s)) {
    bus.poll(0.05, [&](const Received& msg) {
      auto& c = channels[msg.kind];
      ++c.count, ++c.window_count;
      c.bytes += msg.bytes.size(), c.window_bytes += msg.bytes.size();
      c.last_step = msg.envelope.step;
      c.last_sender = msg.envelope.sender;
      last_seen[msg.envelope.sender] = now();
      if (msg.kind == channel::heartbeat) last_heartbeat[msg.envelope.sender] = msg.as<heartbeat_t>();
      if (msg.kind == channel::step_done) {
        step = std::max<std::int64_t>(step, msg.envelope.step);
        auto done = msg.as<step_done_t>();
        if (!done.ok) last_error[done.node] = done.error;
      }
    });
    const double t = now();
    if (t - window_start < opt.interval_s) continue;
    const double span = t - window_start;
    std::string out = clear ? "\033[H\033[2J" : "";
    out += fmt::format("run {}  bus {}  step {}  (monitoring {:.0f} s)\n", ctx.run_id, ctx.lcm_url, step, t - start);
    out += fmt::format("{:<20} {:>10} {:>10} {:>12} {:>10}  {}\n", "channel", "msgs", "msgs/s", "bytes/msg", "last step",
                       "sender");
    for (auto& [name, c] : channels) {
      out += fmt::format("{:<20} {:>10} {:>10.1f} {:>12.0f} {:>10}  {}\n", name, c.count, c.window_count / span,
                         c.count ? double(c.bytes) / c.count : 0.0, c.last_step, c.last_sender);
      c.window_count = c.window_bytes = 0;
    }
    out += "nodes:";
    for (const auto& [sender, seen] : last_seen)
      out += fmt::format("  {} {}", sender, t - seen < 2.0 ? "alive" : fmt::format("silent {:.0f} s", t - seen));
    // What each process dropped (from its heartbeat), and the monitor itself: only accepted
    // messages are in the table above (replays and recordings from before it started are not).
    out += fmt::format("\n{:<20} {:>10} {:>8} {:>8} {:>8} {:>9} {:>8} {:>11}\n", "dropped by", "accepted", "short",
                       "foreign", "bad tag", "pre-start", "replay", "undecodable");
    for (const auto& [sender, hb] : last_heartbeat)
      out += fmt::format("{:<20} {:>10} {:>8} {:>8} {:>8} {:>9} {:>8} {:>11}\n", sender, hb.accepted, hb.rejected_short,
                         hb.rejected_foreign, hb.rejected_auth, hb.rejected_prestart, hb.rejected_replay,
                         hb.rejected_undecodable);
    const auto k = bus.counters();
    out += fmt::format("{:<20} {:>10} {:>8} {:>8} {:>8} {:>9} {:>8} {:>11}\n", "(this monitor)", k.accepted,
                       k.rejected_short, k.rejected_foreign, k.rejected_auth, k.rejected_prestart, k.rejected_replay,
                       k.rejected_corrupt);
    out += fmt::format("resend requests seen {}\n", channels.count(channel::resend) ? channels[channel::resend].count : 0);
    for (const auto& [node, err] : last_error) out += fmt::format("{} reported: {}\n", node, err);
    fmt::print("{}", out);
    std::fflush(stdout);
    window_start = t;
  }
  return 0;
}

}  // namespace hemo
