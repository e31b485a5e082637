// hemocosim monitor: a live view of a run's coupling traffic, as a table, JSON lines or a page
// with time plots (issue #23). What it shows is computed in monitor_stats.h.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <deque>
#include <hemo/heartbeat_t.hpp>
#include <hemo/hello_t.hpp>
#include <hemo/step_done_t.hpp>
#include <hemo/step_order_t.hpp>
#include <map>
#include <mutex>
#include <thread>

#include "commands.h"
#include "monitor_page.h"
#include "monitor_stats.h"
#include "page_server.h"
#include "partition_exchange.h"
#include "run_directory.h"
#include "scene.h"

namespace hemo {

namespace {
volatile std::sig_atomic_t stop_monitor = 0;

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
double unix_now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

ProcessCounts counts_of(const heartbeat_t& hb) {
  return {hb.accepted,          hb.rejected_short,  hb.rejected_foreign,    hb.rejected_auth,
          hb.rejected_prestart, hb.rejected_replay, hb.rejected_undecodable};
}

ProcessCounts counts_of(const BusCounters& k) {
  return {static_cast<std::int64_t>(k.accepted),          static_cast<std::int64_t>(k.rejected_short),
          static_cast<std::int64_t>(k.rejected_foreign),  static_cast<std::int64_t>(k.rejected_auth),
          static_cast<std::int64_t>(k.rejected_prestart), static_cast<std::int64_t>(k.rejected_replay),
          static_cast<std::int64_t>(k.rejected_corrupt)};
}

// The rows the page has not fetched yet are kept here, serialised once; the oldest go when
// there are too many (hours of one-second rows), and the page learns so from "first".
class RowLog {
 public:
  void add(std::string row) {
    std::lock_guard<std::mutex> lock(mutex_);
    rows_.push_back(std::move(row));
    if (rows_.size() > kMaxRows) rows_.pop_front(), ++first_;
  }
  // {"first": index of the oldest kept row, "next": index after the newest, "rows": [since...]}
  std::string since(std::size_t since) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::size_t next = first_ + rows_.size();
    std::string out = fmt::format("{{\"first\":{},\"next\":{},\"rows\":[", first_, next);
    for (std::size_t i = std::max(since, first_); i < next; ++i) {
      if (i > std::max(since, first_)) out += ',';
      out += rows_[i - first_];
    }
    return out + "]}";
  }

 private:
  static constexpr std::size_t kMaxRows = 20000;
  mutable std::mutex mutex_;
  std::deque<std::string> rows_;
  std::size_t first_ = 0;
};

// The page and its data (page_server.h: bounded connections, Host checked); read-only, and
// bound to loopback unless told.
std::unique_ptr<PageServer> serve_page(const RowLog& log, const std::string& bind, int port) {
  return std::make_unique<PageServer>(bind, port, [&log](const PageRequest& req) {
    if (req.path == "/") return PageResponse{200, "text/html; charset=utf-8", monitor_page_html()};
    if (req.path != "/rows") return PageResponse{404, "text/plain; charset=utf-8", "not found\n"};
    std::size_t since = 0;
    if (const auto it = req.query.find("since"); it != req.query.end()) {
      try {
        since = std::stoul(it->second);
      } catch (const std::exception&) {
        return PageResponse{400, "text/plain; charset=utf-8", "since: not a row number\n"};
      }
    }
    return PageResponse{200, "application/json", log.since(since), /*no_store=*/true};
  });
}

long scene_steps(const std::string& scene_copy) {
  try {
    return load_scene(scene_copy).time.coupling_steps;
  } catch (const std::exception&) {
    return 0;  // the monitor still shows everything else; the ETA needs --steps then
  }
}
// The scene's imposed wall shear stress for the momentum balance; a scene it cannot read leaves
// the realised stress alone on show.
void balance_reference(MonitorStats& stats, const std::string& scene_copy) {
  try {
    stats.balance_reference(load_scene(scene_copy));
  } catch (const std::exception&) {
  }
}
}  // namespace

int monitor_command(const MonitorOptions& opt) {
  // stdout is the view (with --json, a script's input); the bus's warnings and its closing
  // count of drops go to stderr.
  spdlog::set_default_logger(spdlog::stderr_color_mt("monitor"));
  RunContext ctx;
  long total = opt.total_steps;
  std::string scene_copy;
  if (!opt.run_dir.empty()) {
    auto [dir, c] = RunDirectory::open(opt.run_dir);
    ctx = c;
    scene_copy = dir.scene_copy();
    if (total <= 0) total = scene_steps(scene_copy);
  } else if (opt.url.empty() || opt.run_id.empty() || opt.secret_file.empty()) {
    throw std::runtime_error("monitor needs a run directory, or --url, --run-id and --secret-file");
  }
  if (!opt.url.empty()) ctx.lcm_url = opt.url;
  if (!opt.run_id.empty()) ctx.run_id = opt.run_id;
  if (!opt.secret_file.empty()) {
    ctx.secret_file = opt.secret_file;
    ctx.load_secret();
  }

  Bus bus(ctx, "monitor");
  std::signal(SIGINT, [](int) { stop_monitor = 1; });
  std::signal(SIGTERM, [](int) { stop_monitor = 1; });
  const bool clear = !opt.plain && !opt.json && isatty(STDOUT_FILENO);

  RowLog rows;
  std::unique_ptr<PageServer> page;
  if (opt.http_port >= 0) {
    page = serve_page(rows, opt.bind, opt.http_port);
    // On stderr: stdout may be JSON lines for a script.
    fmt::print(stderr, "monitor: live page at http://{}:{}/\n", opt.bind, page->port());
    std::fflush(stderr);
  }

  MonitorStats stats(ctx.run_id, total);
  if (!scene_copy.empty()) balance_reference(stats, scene_copy);
  const double start = now();
  double window_start = start;
  stats.close_interval(start, unix_now());  // the first interval starts now, not at the first message

  // The reports of a node's ranks >= 1, on channels of their own: listened to once its hello
  // says how many it has. Channel -> node and rank.
  std::map<std::string, std::pair<std::string, int>> rank_reports;
  // Each node's ranks from its hello; with both known and either above one, the pairs' channels
  // of the partitioned exchange are listened to as well (their latency and bytes).
  std::map<std::string, int> ranks_of;
  bool pairs_heard = false;
  // A monitor started after the nodes' hellos asks for them again (each node keeps its own).
  double hellos_asked = -1;
  while (!stop_monitor && (opt.duration_s <= 0 || now() - start < opt.duration_s)) {
    if (ranks_of.size() < 2 && now() - hellos_asked > 2.0) {
      bus.request_resend(channel::hello, 0);
      hellos_asked = now();
    }
    bus.poll(0.05, [&](const Received& msg) {
      const double t = now();
      stats.message(msg.kind, msg.envelope.sender, msg.envelope.step, msg.bytes.size(), msg.envelope.sent_unix_ns,
                    msg.received_unix_us, t);
      if (msg.kind == channel::heartbeat) {
        const auto hb = msg.as<heartbeat_t>();
        stats.heartbeat(msg.envelope.sender, hb.uptime_s, counts_of(hb));
      } else if (msg.kind == channel::step) {
        stats.step_order(msg.envelope.step, msg.as<step_order_t>().time_s);
      } else if (msg.kind == channel::step_done) {
        const auto d = msg.as<step_done_t>();
        if (d.node == msg.envelope.sender)  // a node reports for itself only
          stats.step_done(d.node, msg.envelope.step, d.ok, d.error, d.compute_s, d.wait_s, d.names, d.values);
      } else if (msg.kind == channel::hello) {
        const auto h = msg.as<hello_t>();
        if (h.role == msg.envelope.sender && (h.role == "fluid" || h.role == "particles")) {
          for (int r = 1; r < h.ranks; ++r) {
            const std::string kind = channel::of_node_rank(channel::step_done, h.role, r);
            rank_reports[kind] = {h.role, r};
            bus.listen(kind);
          }
          ranks_of[h.role] = h.ranks;
          if (!pairs_heard && ranks_of.count("fluid") && ranks_of.count("particles") &&
              partitioned(ranks_of["fluid"], ranks_of["particles"])) {
            pairs_heard = true;
            const int nf = ranks_of["fluid"], np = ranks_of["particles"];
            for (int f = 0; f < nf; ++f)
              for (int p = 0; p < np; ++p)
                for (const char* kind : {channel::fluid_state, channel::particle_feedback})
                  bus.listen(channel::of_pair(kind, f, nf, p, np));
          }
        }
      } else if (const auto rank = rank_reports.find(msg.kind); rank != rank_reports.end()) {
        const auto d = msg.as<step_done_t>();
        if (d.ok && d.node == rank->second.first)
          stats.rank_done(d.node, rank->second.second, msg.envelope.step, d.compute_s, d.wait_s, d.names, d.values);
      }
    });
    const double t = now();
    if (t - window_start < opt.interval_s) continue;
    window_start = t;
    stats.own_counts(counts_of(bus.counters()));
    const auto row = stats.close_interval(t, unix_now());
    // Node error lines and sender names are bytes from the bus: never let one stop the monitor.
    const auto line = row.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    if (page) rows.add(line);
    if (opt.json)
      fmt::print("{}\n", line);
    else
      fmt::print("{}{}", clear ? "\033[H\033[2J" : "", format_monitor_table(row, ctx.lcm_url));
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace hemo
