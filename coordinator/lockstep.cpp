// SPDX-License-Identifier: GPL-3.0-or-later
#include "lockstep.h"

#include "checkpoint.h"
#include "hosts.h"
#include "liveness.h"
#include "node_port.h"
#include "rank_exchange.h"
#include "rank_report.h"
#include "stability_guard.h"
#include "traffic.h"

#include <hemo/heartbeat_t.hpp>
#include <hemo/hello_t.hpp>
#include <hemo/step_done_t.hpp>
#include <hemo/step_order_t.hpp>

#include <fmt/format.h>

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <limits>
#include <sstream>

namespace hemo {

namespace {
double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

std::string self_dir() { return std::filesystem::read_symlink("/proc/self/exe").parent_path().string(); }

std::string who(const std::string& process) {
  return process == "coordinator" ? "the coordinator" : "the " + process + " node";
}

std::vector<std::string> split(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}
}  // namespace

Lockstep::Lockstep(const Scene& scene, RunDirectory dir, const RunContext& ctx, NodeLauncher& launcher, long first_step)
    : scene_(scene), dir_(std::move(dir)), ctx_(ctx), launcher_(launcher), first_step_(first_step) {
  bus_ = std::make_unique<Bus>(ctx_, "coordinator", channel::heard_by_coordinator());
  heartbeat_ = std::make_unique<Heartbeat>(
      ctx_, "coordinator", 0.5, [bus = bus_.get()] { return bus->counters(); }, HeardReport{true, ""});
  // Reports of nodes from before (a restart) would pass the bus check for the new ones.
  std::error_code ec;
  std::filesystem::remove_all(std::filesystem::path(heard_report_file(ctx_, "coordinator")).parent_path(), ec);
  write_coordinator_process(dir_.path);  // the nodes on this host watch it while it is silent
  // A resumed run keeps the steps before it.
  metrics_ = AppendFile(dir_.metrics_file(), first_step == 0, "step,time_s,node,name,value\n");
  launch("fluid", scene.run.fluid_command, "hemocosim-fluid", scene.run.fluid_ranks, first_step);
  launch("particles", scene.run.particle_command, "hemocosim-particles", scene.run.particle_ranks, first_step);
}

Lockstep::~Lockstep() {
  bus_->log_counters();  // what the coordinator received and dropped, by cause
  try {
    write_metrics();
  } catch (const std::exception& e) {  // a full disk: the run stops for it already
    fmt::print(stderr, "hemocosim: {}\n", e.what());
  }
  for (auto& [name, node] : nodes_)
    if (node.process) node.process->terminate();
}

void Lockstep::launch(const std::string& node, const std::string& command, const char* default_program, int ranks,
                      long first_step) {
  auto argv = split(command);
  if (argv.empty()) argv.push_back(self_dir() + "/" + default_program);
  for (const auto& a :
       {std::string("--scene"), dir_.scene_copy(), std::string("--run-dir"), dir_.path, std::string("--run-id"),
        ctx_.run_id, std::string("--lcm-url"), ctx_.lcm_url, std::string("--secret-file"), ctx_.secret_file,
        std::string("--timeout"), fmt::format("{}", scene_.run.node_timeout), std::string("--drop-every"),
        fmt::format("{}", ctx_.drop_every), std::string("--ranks"), fmt::format("{}", ranks)})
    argv.push_back(a);
  const std::string& hosts = node == "fluid" ? scene_.hosts.fluid : scene_.hosts.particles;
  if (!hosts.empty()) {
    argv.push_back("--mpi-hosts");
    argv.push_back(host_list_text(parse_host_list(hosts)));
  }
  if (scene_.hosts.launcher == Launcher::slurm) {
    argv.push_back("--mpi-starter");
    argv.push_back("srun");
  }
  if (ctx_.encrypt) argv.push_back("--encrypt-bus");
  if (first_step > 0) {
    argv.push_back("--resume-step");
    argv.push_back(fmt::format("{}", first_step));
  }
  auto& state = nodes_[node];
  state.process = launcher_.launch(node, argv, dir_.log(node));
  std::ofstream(dir_.path + "/" + node + ".pid") << state.process->pid() << "\n";
  state.last_heard = now();
  state.heard = false;
  state.reports = RankReports(ranks, now());
  listen_to_ranks(node);
}

void Lockstep::listen_to_ranks(const std::string& node) {
  for (int r = 1; r < nodes_.at(node).reports.ranks(); ++r) {
    rank_senders_[rank_sender(node, r)] = {node, r};
    bus_->listen(channel::of_node_rank(channel::step_done, node, r));
    bus_->listen(channel::of_node_rank(channel::heartbeat, node, r));
  }
}

void Lockstep::order(long step, double time_s, double dt_s, bool write_output, bool write_checkpoint) {
  step_order_t o;
  o.time_s = time_s;
  o.dt_s = dt_s;
  o.write_output = write_output;
  o.write_checkpoint = write_checkpoint;
  o.stop = false;
  step_time_s_ = time_s;
  ordered_at_ = now();
  bus_->publish(channel::step, o, step, /*keep=*/true);
  bus_->forget_before(step - 1);
  write_metrics();  // now that the nodes are busy
}

double Lockstep::diagnostic(const std::string& node, const std::string& name) const {
  const auto& last = nodes_.at(node).last;
  const auto it = last.find(name);
  return it != last.end() ? it->second : std::numeric_limits<double>::quiet_NaN();
}

void Lockstep::write_metrics() {
  std::string rows;
  for (const auto& r : unwritten_)
    rows += fmt::format("{},{:.9g},{},{},{:.17g}\n", r.step, r.time_s, r.source, r.name, r.value);
  unwritten_.clear();
  metrics_.append(rows);
}

void Lockstep::record(const Received& msg) {
  const auto done = msg.as<step_done_t>();
  auto it = nodes_.find(done.node);
  if (it == nodes_.end() || done.node != msg.envelope.sender) return;
  auto& node = it->second;
  if (!done.ok) {
    // A node that gave up on this coordinator's silence is healthy: restart it (liveness.h).
    const auto& names = done.names;
    if (std::find(names.begin(), names.end(), kCoordinatorSilentDiagnostic) != names.end())
      throw NodeLost(
          fmt::format("{} node gave up waiting for the coordinator at step {}{}: {}", done.node, msg.envelope.step,
                      paused_s_ > 0 ? ", because the coordinator was " + pause_words(paused_s_) : "", done.error));
    throw std::runtime_error(fmt::format("{} node failed at step {}: {}", done.node, msg.envelope.step, done.error));
  }
  if (!node.reports.reported(0, msg.envelope.step, now())) return;  // a repeat
  node.compute = done.compute_s;
  node.wait = done.wait_s;
  node.last.clear();
  for (std::size_t i = 0; i < done.names.size() && i < done.values.size(); ++i)
    node.last[done.names[i]] = done.values[i];
  const long k = msg.envelope.step;
  // A resumed run's start-up report is of the checkpoint's step, whose metrics the run kept.
  if (k == first_step_ && k > 0) return;
  if (k > first_step_) {  // step 0 is the nodes' set-up, not a step
    node.totals["compute_s"] += done.compute_s;
    node.totals["wait_s"] += done.wait_s;
    for (std::size_t i = 0; i < done.names.size(); ++i) {
      const std::string& name = done.names[i];
      if (name.rfind("phase_", 0) == 0) node.totals[name] += done.values[i];
      if (name.size() > 2 && name.compare(name.size() - 2, 2, "_B") == 0) node.bytes[name] += done.values[i];
    }
  }
  for (std::size_t i = 0; i < done.names.size(); ++i)
    if (done.names[i] == kCheckpointDiagnostic && done.values[i] == double(k)) node.checkpoint_step = k;
  auto row = [&](const std::string& name, double value) {
    unwritten_.push_back({k, step_time_s_, done.node, name, value});
  };
  row("compute_s", done.compute_s);
  row("wait_s", done.wait_s);
  for (std::size_t i = 0; i < done.names.size(); ++i) row(done.names[i], done.values[i]);
  // Raised by await() once the bus has returned: never thrown through the bus's handlers.
  if (unstable_.empty()) unstable_ = unstable_step(done.node, k, done.names, done.values, scene_.run);
}

void Lockstep::record_rank(const Received& msg, const std::string& name, int rank) {
  const auto done = msg.as<step_done_t>();
  if (done.node != name || msg.envelope.sender != rank_sender(name, rank)) return;
  if (!done.ok)
    throw std::runtime_error(
        fmt::format("{} node's rank {} failed at step {}: {}", name, rank, msg.envelope.step, done.error));
  auto& node = nodes_.at(name);
  if (!node.reports.reported(rank, msg.envelope.step, now())) return;  // a repeat
  const long k = msg.envelope.step;
  if (k == first_step_ && k > 0) return;  // a resumed run's start-up: the run kept its metrics
  const std::string compute = fmt::format("rank{}_compute_s", rank), wait = fmt::format("rank{}_wait_s", rank);
  if (k > first_step_) {
    node.totals[compute] += done.compute_s;
    node.totals[wait] += done.wait_s;
    for (std::size_t i = 0; i < done.names.size() && i < done.values.size(); ++i) {
      const std::string& n = done.names[i];
      if (n.size() > 2 && n.compare(n.size() - 2, 2, "_B") == 0) node.bytes[n] += done.values[i];
    }
  }
  unwritten_.push_back({k, step_time_s_, name, compute, done.compute_s});
  unwritten_.push_back({k, step_time_s_, name, wait, done.wait_s});
  for (std::size_t i = 0; i < done.names.size() && i < done.values.size(); ++i)
    unwritten_.push_back({k, step_time_s_, name, done.names[i], done.values[i]});
}

long Lockstep::common_checkpoint() const {
  long common = -1;
  bool first = true;
  for (const auto& [name, node] : nodes_) {
    common = first ? node.checkpoint_step : std::min(common, node.checkpoint_step);
    first = false;
  }
  return common;
}

void Lockstep::check_health(long step) {
  for (auto& [name, node] : nodes_) {
    if (!node.process->running()) {
      // A node that failed a step says why before it exits; that report, not the exit, is the
      // error (and no reason to restart it: it would fail again).
      bus_->poll(0.2, [&](const Received& msg) {
        if (msg.kind == channel::step_done) record(msg);
      });
      const auto last = node.process->last_log_line();
      throw NodeLost(fmt::format("{} node {} at step {}{}{} (log: {})", name, node.process->how_it_ended(), step,
                                 last.empty() ? "" : ": ", last, node.process->log_path()));
    }
    // Until its first heartbeat a node is starting up (MPI launch, engine set-up, a loaded or
    // remote host): it has the start-up allowance, not the heartbeat timeout.
    const double allowance =
        node.heard ? scene_.run.node_timeout : std::max(scene_.run.node_timeout, scene_.run.startup_timeout);
    if (now() - node.last_heard > allowance)
      throw NodeLost(fmt::format("{} node {} at step {}: no heartbeat for {:.0f} s{} (log: {})", name,
                                 node.heard ? "stopped answering" : "did not start", step, allowance,
                                 why_silent(name, node), node.process->log_path()));
    // Its other ranks beat on their own: one of them stopped (killed, frozen, its host gone)
    // while rank 0 still beats.
    if (const auto rank = node.reports.silent(now(), scene_.run.node_timeout, scene_.run.startup_timeout))
      throw NodeLost(fmt::format("{} node's rank {} of {} {} at step {}: no heartbeat for {:.0f} s (log: {})", name,
                                 rank->rank, node.reports.ranks(),
                                 rank->started ? "stopped answering" : "did not start", step,
                                 rank->started ? scene_.run.node_timeout
                                               : std::max(scene_.run.node_timeout, scene_.run.startup_timeout),
                                 node.process->log_path()));
  }
}

// What the coordinator can tell about a node it does not hear: its process stopped (on this
// host), or its messages refused for its clock.
std::string Lockstep::why_silent(const std::string& name, NodeState& node) const {
  if (const auto lag = bus_->prestart_lag_s(name))
    return fmt::format(
        "; its messages are refused as sent before the coordinator started: its clock is {:.1f} s behind this "
        "host's (clock skew: the hosts' clocks must agree within {:g} s; NTP?)",
        *lag, 1e-6 * static_cast<double>(kClockSkewAllowanceUs));
  if (node.process->running() && process_state(node.process->pid()) == ProcessState::stopped)
    return "; its process is stopped (SIGSTOP or a suspended shell?)";
  return "";
}

// A pause of the coordinator (SIGSTOP, a suspended host) is not the nodes' silence: the time it
// was away is taken off every node's silence and the step's time, and said once.
void Lockstep::forgive_own_pause(long step, double* step_started) {
  const double away = pauses_.turn();
  if (away <= 0) return;
  for (auto& [name, node] : nodes_) {
    node.last_heard = std::min(now(), node.last_heard + away);
    node.reports.forgive(away, now());
  }
  if (step_started) *step_started += away;
  paused_s_ = away;
  if (away > std::min(5.0, scene_.run.node_timeout / 2))
    fmt::print(stderr, "hemocosim: the coordinator was {} at step {}; going on\n", pause_words(away), step);
}

void Lockstep::check_bus() {
  if (bus_checked_ || now() - bus_checked_at_ < 0.25) return;
  bus_checked_at_ = now();
  char own_host[256] = "?";
  ::gethostname(own_host, sizeof own_host - 1);
  std::map<std::string, HeardReportLine> report;
  report["coordinator"] = {own_host, heartbeat_->heard()};
  for (const auto& [name, node] : nodes_) {
    const auto line = read_heard_report(heard_report_file(ctx_, name));
    // A node that reports nothing (another program swapped in, or one still starting: the
    // start-up allowance covers that) is not judged.
    if (!line) return;
    report[name] = *line;
    reported_at_.emplace(name, now());
  }
  std::vector<std::string> unheard;
  for (const auto& [listener, r] : report)
    for (const auto& [speaker, other] : report)
      if (speaker != listener && !r.heard.count(speaker))
        unheard.push_back(
            fmt::format("{} (on {}) does not hear {} (on {})", who(listener), r.host, who(speaker), other.host));
  if (unheard.empty()) {
    bus_checked_ = true;
    return;
  }
  double last_report = 0;
  for (const auto& [name, at] : reported_at_) last_report = std::max(last_report, at);
  if (now() - last_report < scene_.run.bus_check_s) return;
  std::string also;
  for (std::size_t i = 1; i < unheard.size(); ++i) also += (i == 1 ? "; also " : ", ") + unheard[i];
  const bool tcp = ctx_.lcm_url.rfind("tcpq://", 0) == 0;
  throw std::runtime_error(fmt::format(
      "bus check: {} within {:g} s on {}{}; {}", unheard.front(), scene_.run.bus_check_s, ctx_.lcm_url, also,
      tcp ? "the relay forwards to every process connected to it: one that is not heard lost its connection or "
            "does not publish (its log; docs/hosts.md)"
          : "likely multicast is not routed between the hosts (a route for 224.0.0.0/4 on the interface that "
            "joins them, run.bus_ttl), a firewall drops UDP to that group and port, or a receive buffer is too "
            "small; where multicast cannot pass, use the TCP transport (--transport tcp; docs/hosts.md)"));
}

void Lockstep::hear(double wait_s) {
  bus_->poll(wait_s, [&](const Received& msg) {
    auto it = nodes_.find(msg.envelope.sender);
    if (it != nodes_.end()) {
      it->second.last_heard = now();
      it->second.heard = true;
      // Its hello says on how many ranks it runs: every one of them reports each step.
      if (msg.kind == channel::hello) {
        const auto hello = msg.as<hello_t>();
        if (hello.role == it->first && hello.ranks >= 1) {
          it->second.said_hello = true;
          it->second.reports.set_ranks(hello.ranks, now());
          listen_to_ranks(it->first);
        }
      }
      if (msg.kind == channel::step_done) record(msg);
      return;
    }
    const auto rank = rank_senders_.find(msg.envelope.sender);
    if (rank == rank_senders_.end()) return;
    const auto& [node, r] = rank->second;
    auto& state = nodes_.at(node);
    state.reports.heard(r, now());
    if (msg.kind == channel::of_node_rank(channel::step_done, node, r)) record_rank(msg, node, r);
  });
}

void Lockstep::settle_bus_check() {
  bus_checked_at_ = 0;  // look now
  check_bus();
  // A node that reports writes its first report before it says hello, so one without a report
  // now never will (it is not judged, and not waited for); once every node reported, check_bus
  // decides (or throws) within run.bus_check_s.
  while (!bus_checked_ && reported_at_.size() == nodes_.size()) {
    hear(0.05);
    forgive_own_pause(first_step_, nullptr);
    check_bus();
    check_health(first_step_);
  }
}

void Lockstep::await(long step, double timeout_s) {
  double start = now();
  double last_asked = start;
  auto all_done = [&] {
    for (auto& [name, node] : nodes_)
      if (node.reports.done_step() < step) return false;
    return true;
  };
  while (!all_done()) {
    hear(0.05);
    forgive_own_pause(step, &start);
    if (!unstable_.empty()) throw UnstableRun(unstable_);
    check_bus();
    check_health(step);
    if (now() - last_asked > ctx_.retry_s) {
      // A report may have been dropped: ask again, each rank on its own channel.
      bus_->request_resend(channel::step_done, step);
      for (auto& [name, node] : nodes_)
        for (const int r : node.reports.missing(step)) {
          if (r == 0) continue;
          bus_->request_resend(channel::of_node_rank(channel::step_done, name, r), step);
          // Until its hello is heard the rank count is the launch's: the hello may say fewer.
          if (!node.said_hello) bus_->request_resend(channel::hello, 0);
        }
      last_asked = now();
    }
    // The coordinator's own bytes, one window a step like the nodes' (the start-up's dropped).
    if (all_done() && step == first_step_) RankTraffic::take();
    if (all_done() && step > first_step_) {
      for (const auto& [what, bytes] : rank_bytes(0, RankTraffic::take())) {
        own_bytes_[what] += bytes;
        unwritten_.push_back({step, step_time_s_, "coordinator", what, bytes});
      }
      // Serial: the nodes compute one after the other; parallel: at once. What the step took
      // beyond that is the coupling: messages, waking up, the coordinator's bookkeeping.
      const double wall = now() - ordered_at_;
      double computing = 0;
      for (const auto& [name, node] : nodes_)
        computing = scene_.coupling_scheme == CouplingScheme::parallel ? std::max(computing, node.compute) : computing + node.compute;
      stepping_wall_s_ += wall;
      overhead_s_ += wall - computing;
      unwritten_.push_back({step, step_time_s_, "lockstep", "step_wall_s", wall});
      unwritten_.push_back({step, step_time_s_, "lockstep", "coupling_overhead_s", wall - computing});
    }
    if (now() - start > timeout_s) {
      for (auto& [name, node] : nodes_) {
        const auto missing = node.reports.missing(step);
        if (!missing.empty())
          throw std::runtime_error(fmt::format(
              "{} node did not finish step {} within {:.0f} s{} (log: {})", name, step, timeout_s,
              node.reports.ranks() > 1 ? ": " + rank_list_words(missing, node.reports.ranks()) + " did not report it"
                                       : "",
              node.process->log_path()));
      }
    }
  }
}

void Lockstep::stop(long step) {
  write_metrics();
  step_order_t o;
  o.time_s = step_time_s_;
  o.dt_s = 0;
  o.write_output = false;
  o.write_checkpoint = false;
  o.stop = true;
  bus_->publish(channel::step, o, step, /*keep=*/true);
  // Nodes that missed the order ask for it again; keep answering while they finish.
  double deadline = now() + scene_.run.node_timeout;
  for (;;) {
    forgive_own_pause(step, &deadline);
    bool all_exited = true;
    for (auto& [name, node] : nodes_) all_exited &= !node.process->running();
    if (all_exited) break;
    if (now() > deadline) throw std::runtime_error("nodes did not exit after the stop order");
    bus_->poll(0.05, [](const Received&) {});
  }
  for (auto& [name, node] : nodes_) {
    if (node.process->how_it_ended() != "exited with status 0")
      throw std::runtime_error(fmt::format("{} node {} while finishing (log: {})", name, node.process->how_it_ended(),
                                           node.process->log_path()));
  }
}

}  // namespace hemo

namespace hemo {

std::string Lockstep::profile_report(double wall_s, long steps) const {
  std::string csv = "node,phase,total_s,per_step_ms\n";
  std::string text =
      fmt::format("profile of {} coupled steps ({:.2f} s wall, {:.2f} s stepping):\n", steps, wall_s, stepping_wall_s_);
  for (const auto& [name, node] : nodes_) {
    for (const auto& [phase, total] : node.totals) {
      csv += fmt::format("{},{},{:.6g},{:.6g}\n", name, phase, total, 1e3 * total / std::max(steps, 1L));
      text += fmt::format("  {:<10} {:<30} {:10.3f} s {:10.3f} ms/step\n", name, phase, total,
                          1e3 * total / std::max(steps, 1L));
    }
  }
  for (const auto& [name, node] : nodes_) {
    const double mib = node.process->peak_memory_mib();
    csv += fmt::format("{},peak_memory_MiB,{:.1f},\n", name, mib);
    if (mib > 0)  // 0: not known here (a node on another host, or a Slurm job step)
      text += fmt::format("  {:<10} {:<30} {:10.1f} MiB\n", name, "peak memory", mib);
    else
      text += fmt::format("  {:<10} {:<30} {:>10}\n", name, "peak memory", "not known here");
  }
  // Bytes: a mean per step, in the total's column (units in the name, as peak memory's).
  const double per_step = 1.0 / std::max(steps, 1L);
  auto bytes_rows = [&](const std::string& name, const std::map<std::string, double>& bytes) {
    for (const auto& [what, total] : bytes)
      csv += fmt::format("{},{}_per_step,{:.10g},\n", name, what, total * per_step);
    auto of_rank = [&](int r, const char* what) {
      const auto it = bytes.find(fmt::format("rank{}_{}_B", r, what));
      return it == bytes.end() ? 0.0 : it->second * per_step;
    };
    for (int r = 0; bytes.count(fmt::format("rank{}_sent_B", r)); ++r)
      text += fmt::format("  {:<10} {:<30} {:10.0f} B/step sent ({:.0f} resent), {:.0f} B/step received ({:.0f} again)\n",
                          name, fmt::format("rank {} bytes", r), of_rank(r, "sent"), of_rank(r, "resent"),
                          of_rank(r, "received"), of_rank(r, "received_again"));
  };
  for (const auto& [name, node] : nodes_) bytes_rows(name, node.bytes);
  bytes_rows("coordinator", own_bytes_);
  const double overhead = overhead_s_;
  csv += fmt::format("lockstep,coupling_overhead_s,{:.6g},{:.6g}\n", overhead, 1e3 * overhead / std::max(steps, 1L));
  text += fmt::format("  {:<10} {:<30} {:10.3f} s {:10.3f} ms/step ({:.1f} % of stepping)\n", "lockstep",
                      "coupling overhead", overhead, 1e3 * overhead / std::max(steps, 1L),
                      100 * overhead / std::max(stepping_wall_s_, 1e-12));
  std::ofstream(dir_.path + "/profile.csv") << csv;
  return text;
}

}  // namespace hemo
