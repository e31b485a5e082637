// hemocosim run: launch both nodes and drive the lockstep to the end.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "analyze.h"
#include "checkpoint.h"
#include "commands.h"
#include "feeder_develop.h"
#include "hosts.h"
#include "placement.h"
#include "relay.h"
#include "run_driver.h"
#include "run_files.h"
#include "scene.h"
#include "xdmf.h"

#include <fmt/format.h>

#include <arpa/inet.h>
#include <unistd.h>
#include <cmath>
#include <csignal>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <stdexcept>
#include <tuple>

namespace hemo {

namespace {
volatile std::sig_atomic_t interrupted = 0;
// The first SIGINT / SIGTERM stops the run after its step, with a checkpoint; a second one stops
// it at once (the nodes get SIGTERM as the coordinator ends, node_process.cpp).
void on_signal(int sig) {
  if (interrupted) {
    static const char msg[] = "hemocosim: error: interrupted twice: stopped at once, without a checkpoint\n";
    [[maybe_unused]] const auto n = ::write(STDERR_FILENO, msg, sizeof msg - 1);
    ::_exit(128 + sig);
  }
  interrupted = 1;
}

std::string default_run_dir(const Scene& scene) {
  char stamp[32];
  const std::time_t t = std::time(nullptr);
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&t));
  return fmt::format("runs/{}-{}", scene.run.name, stamp);
}

// The TCP transport's relay (docs/hosts.md), listening where the nodes' hosts reach this one; it
// forwards the run's channels only.
std::unique_ptr<Relay> start_relay(const Scene& scene, const RunContext& ctx) {
  RelayOptions opt;
  opt.address = scene.hosts.relay_address;
  if (opt.address == "auto") {
    std::vector<std::string> hosts;
    for (const auto* list : {&scene.hosts.fluid, &scene.hosts.particles})
      for (const auto& h : parse_host_list(*list)) hosts.push_back(h.host);
    opt.address = local_address_toward(hosts);
  }
  opt.port = scene.hosts.relay_port;
  opt.channel_prefix = ctx.run_id + "/";
  opt.secret = ctx.secret;
  opt.sized_for(largest_bus_message(scene));
  return std::make_unique<Relay>(opt);
}

// The closing summary's line on the momentum balance (docs/model.md §5), printed only when the
// settled flow's wall shear stress misses the imposed one; a metrics.csv it cannot read is said
// in one line and does not fail the run.
void report_momentum_balance(const std::string& run_dir, const Scene& scene) {
  try {
    const std::string line = analysis::closing_balance_line(run_dir, scene);
    if (!line.empty()) fmt::print(stderr, "hemocosim: {}\n", line);
  } catch (const std::exception& e) {
    fmt::print(stderr, "hemocosim: momentum balance not judged: {}\n", e.what());
  }
}

// Drives the run, then makes what the nodes wrote openable in ParaView, also after a failure.
int drive_and_finish(const Scene& scene_as_given, RunDirectory& dir, const RunContext& given_ctx, const Span span) {
  const Scene scene = placed_in_allocation(scene_as_given);
  HostLauncher launcher(scene.hosts, dir.path);
  launcher.check_hosts();
  // The relay lives as long as the run, across node restarts; destroyed last, it ends the bus
  // only once the nodes are stopped.
  RunContext ctx = given_ctx;
  std::unique_ptr<Relay> relay;
  if (scene.hosts.tcp()) {
    relay = start_relay(scene, ctx);
    ctx.lcm_url = relay->url();
    dir.record_bus_url(ctx.lcm_url);  // for the monitor, `hemocosim restart` and the nodes of a resume
    fmt::print(stderr, "hemocosim: bus over TCP: relay at {}:{}\n", relay->address(), relay->port());
  }
  struct RelayReport {
    const std::unique_ptr<Relay>& relay;
    ~RelayReport() {
      if (!relay) return;
      const auto s = relay->stats();
      if (s.turned_away() + s.refused_patterns + s.dropped_foreign > 0)
        fmt::print(stderr, "hemocosim: bus relay: {}\n", s.str());
    }
  } relay_report{relay};
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  Reached reached;
  try {
    reached = drive(scene, dir, ctx, span, launcher, [] { return interrupted != 0; });
  } catch (const std::exception& e) {
    // The nodes are stopped by now.
    try {
      write_paraview_sidecars(dir.path);
    } catch (const std::exception&) {
    }
    // A node's failed write says "error in IOstream" (OpenFOAM) or "cannot flush" (HDF5): the
    // cause, named here, is the disk.
    const std::string what = e.what();
    const bool full = dir.out_of_space() && what.find("no space left on device") == std::string::npos;
    throw std::runtime_error((full ? fmt::format("no space left on device for {}: ", dir.path) : "") + what +
                             resume_hint(dir));
  }
  const int snapshots = write_paraview_sidecars(dir.path);
  fmt::print(stderr, "hemocosim: {} particle snapshots; open {}/particles.xmf and fluid/fluid.foam in ParaView\n",
             snapshots, dir.path);
  report_momentum_balance(dir.path, scene);
  if (!reached.end) {
    if (interrupted)
      throw std::runtime_error(fmt::format("interrupted after step {}", reached.step) + resume_hint(dir));
    fmt::print(stderr, "hemocosim: stopped as asked{}\n", resume_hint(dir));
  }
  return 0;
}

// The commands a resumed run executes, said; one this run's coordinator did not record and sign
// (an edited scene.toml or run.toml) only with --allow-commands.
void refuse_unsigned_commands(const RunDirectory& dir, const RunContext& ctx, const Scene& scene, bool allowed) {
  for (const auto& [node, command] :
       {std::pair{"fluid", scene.run.fluid_command}, std::pair{"particles", scene.run.particle_command}})
    if (!command.empty()) fmt::print(stderr, "hemocosim: the {} node runs `{}`\n", node, command);
  if (dir.commands_signed(ctx, scene)) return;
  if (!allowed)
    throw std::runtime_error(fmt::format(
        "{}: the commands above were not recorded by this run's coordinator (scene.toml or run.toml changed since); "
        "resume with --allow-commands to run them anyway",
        dir.path));
  fmt::print(stderr, "hemocosim: warning: running commands this run did not record (--allow-commands)\n");
}

// A resumed run writes at least a checkpoint like the one it starts from; refused before anything
// is changed when the disk cannot take it (a resume on a full disk would cut what is there).
void need_free_space(const RunDirectory& dir, long from) {
  constexpr std::uintmax_t kMargin = 16u << 20;  // logs, metrics, run.toml, a snapshot of a small run
  const std::uintmax_t need = dir.checkpoint_bytes(from) + kMargin, free = free_bytes(dir.path);
  if (free < need)
    throw std::runtime_error(fmt::format(
        "no space left on device: {:.1f} MB free for {}, a resume needs at least {:.1f} MB (its checkpoint's size "
        "and 16 MB); nothing was changed",
        static_cast<double>(free) / 1e6, dir.path, static_cast<double>(need) / 1e6));
}

// The step after which to stop at the latest: --stop-after-step, else the last (with adaptive
// intervals not known in advance: no bound, the clock ends the run).
long last_step(const Scene& scene, long stop_after_step) {
  const long end = scene.time.adaptive_interval() ? std::numeric_limits<long>::max() : scene.time.coupling_steps;
  return stop_after_step > 0 ? std::min(stop_after_step, end) : end;
}

// The command line's placement over the scene's: hosts given there replace the scene's (and the
// ranks they imply); --np-* must agree with the hosts a node ends up with.
void place_nodes(Scene& scene, RunOptions opt) {
  if (!opt.fluid_hostfile.empty()) opt.fluid_hosts = read_host_file(opt.fluid_hostfile);
  if (!opt.particle_hostfile.empty()) opt.particle_hosts = read_host_file(opt.particle_hostfile);
  auto& h = scene.hosts;
  if (!opt.launcher.empty()) choice_named(opt.launcher, h.launcher);  // main.cpp checked the name
  if (!opt.launch_command.empty()) {
    check_launch_command(opt.launch_command);
    h.launch_command = opt.launch_command;
  }
  for (auto [given, list, np, ranks, option] :
       {std::tuple{&opt.fluid_hosts, &h.fluid, opt.fluid_ranks, &scene.run.fluid_ranks, "--np-fluid"},
        std::tuple{&opt.particle_hosts, &h.particles, opt.particle_ranks, &scene.run.particle_ranks,
                   "--np-particles"}}) {
    if (!given->empty()) {
      parse_host_list(*given);  // refused here, with the option's name, rather than mid-run
      *list = *given;
      *ranks = ranks_for_hosts(parse_host_list(*list), np > 0 ? np : 1, option);
    } else if (np > 0) {
      *ranks = ranks_for_hosts(parse_host_list(*list), np, option);
    }
  }
  if (opt.bus_ttl >= 0) scene.run.bus_ttl = opt.bus_ttl;
  if (!opt.transport.empty()) choice_named(opt.transport, h.transport);
  if (!opt.relay_address.empty()) {
    in_addr ip{};
    if (opt.relay_address != "auto" && ::inet_pton(AF_INET, opt.relay_address.c_str(), &ip) != 1)
      throw std::invalid_argument(
          fmt::format("--relay-address {}: must be auto or an IPv4 address of this host (LCM's tcpq takes no names)",
                      opt.relay_address));
    h.relay_address = opt.relay_address;
  }
  if (opt.relay_port >= 0) h.relay_port = opt.relay_port;
}

// The fluid node's own program cannot split the mesh into more pieces than it has layers: said
// here, before anything is written or started (a resume would otherwise restart it in vain).
void refuse_fluid_ranks(const Scene& scene, const std::string& what) {
  if (!scene.run.fluid_command.empty()) return;  // another program decides for itself
  if (const auto problem = fluid_ranks_problem(scene.mesh, scene.run.fluid_ranks))
    throw std::runtime_error(fmt::format("{}: {}", what, *problem));
}

// An open vessel's feeder developed on its own first (vessel.feeder_develop_s,
// model/feeder_develop.h): the derived periodic scene, written beside the run
// (RUN_DIR/feeder-develop.toml), run as any scene is into RUN_DIR/feeder-develop, or with
// --feeder-cache into the cache's folder named by that scene's SHA-256 and linked there. A develop
// run found at its last step is used as it is (a study's next run with the same feeder, a resume);
// one stopped before is resumed; the particle node reads its last checkpoint. `placement`: the
// open run's command line (its ranks and hosts); the develop run is the coordinator's own.
void develop_feeder(const Scene& scene, const RunDirectory& dir, const RunOptions& placement) {
  namespace fs = std::filesystem;
  const std::string scene_file = dir.path + "/" + kFeederDevelopFolder + ".toml";
  {
    std::ifstream in(dir.scene_copy());
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(scene_file) << feeder_develop_scene_text(scene, text);
  }
  const long steps = feeder_develop_steps(scene);
  const fs::path link = fs::path(dir.path) / kFeederDevelopFolder;
  fs::path develop = link;
  if (fs::is_symlink(link))
    develop = fs::read_symlink(link);
  else if (!fs::exists(link) && !placement.feeder_cache.empty())
    develop = fs::absolute(fs::path(placement.feeder_cache) / sha256_file(scene_file));
  fmt::print(stderr, "hemocosim: the feeder develops on its own for {:g} s ({} steps) in {}\n",
             scene.vessel.feeder_develop, steps, develop.string());
  try {
    if (last_complete_checkpoint(develop.string()) == steps) {
      fmt::print(stderr, "hemocosim: developed earlier: its checkpoint of step {} is there\n", steps);
    } else if (last_complete_checkpoint(develop.string())) {
      resume_command(ResumeOptions{develop.string()});
    } else {
      if (fs::exists(develop / "scene.toml")) fs::remove_all(develop);  // a start that never reached a checkpoint
      RunOptions opt = placement;
      opt.scene = scene_file;
      opt.out = develop.string();
      opt.stop_after_step = 0;
      opt.feeder_cache.clear();
      fs::create_directories(develop.parent_path());
      run_command(opt);
    }
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("the feeder's develop run {} did not finish: {}", develop.string(), e.what()));
  }
  if (develop != link && !fs::exists(link)) fs::create_directory_symlink(develop, link);
}

}  // namespace

int run_command(const RunOptions& opt) {
  // Refused here, before the run directory and the nodes, what the particle node would refuse at
  // step 0: particles that cannot be placed (the same placement, SceneCheck::placement).
  Scene scene = load_scene(opt.scene, SceneCheck::placement);
  // The particle node couples particles and nothing else: it would refuse a scene without any at
  // its start, after the run directory and the fluid node. A plasma-only run brings a stand-in.
  if (particles::rbc_count(scene) + particles::platelet_count(scene) == 0 && scene.run.particle_command.empty())
    throw std::runtime_error(opt.scene +
                             ": the scene has no particles (rbc.hematocrit and platelet.number_density_per_ul "
                             "give none): the particle node has nothing to couple; a plasma-only run needs a "
                             "stand-in particle node in run.particle_command");
  try {
    place_nodes(scene, opt);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  refuse_fluid_ranks(scene, opt.scene);
  auto [dir, ctx] = RunDirectory::create(opt.out.empty() ? default_run_dir(scene) : opt.out, opt.scene,
                                         bus_ttl(scene.run.bus_ttl, scene.hosts.across_hosts()));
  const RunLock lock(dir.path);  // for the run's life: a resume of it meanwhile is refused
  dir.keep_surface(scene);
  dir.sign_commands(ctx, scene);
  dir.record_ranks(scene.run.fluid_ranks, scene.run.particle_ranks);
  dir.record_placement(scene.hosts);
  dir.record_transport(scene.hosts);
  ctx.drop_every = scene.run.drop_every;
  std::ofstream(dir.path + "/coordinator.pid") << getpid() << "\n";
  fmt::print(stderr, "hemocosim: run {} in {}\n", ctx.run_id, dir.path);
  if (develops_feeder(scene)) develop_feeder(scene, dir, opt);
  return drive_and_finish(scene, dir, ctx, {0, last_step(scene, opt.stop_after_step)});
}

int resume_command(const ResumeOptions& opt) {
  auto [dir, ctx] = RunDirectory::open(opt.run_dir);
  const RunLock lock(dir.path);  // before anything is changed: a coordinator still running it keeps it
  Scene scene = load_scene(dir.scene_copy());
  if (dir.fluid_ranks > 0) scene.run.fluid_ranks = dir.fluid_ranks;
  if (dir.particle_ranks > 0) scene.run.particle_ranks = dir.particle_ranks;
  use_swapped_programs(dir, scene);
  if (dir.placement.across_hosts()) scene.hosts = dir.placement;  // the ranks (run.toml) came from these hosts
  // A node's ranks on other hosts were placed at the run's start (host:ranks): a new count
  // would need a new placement.
  for (const auto& [asked, ranks, what] : {std::tuple{opt.particle_ranks, &scene.run.particle_ranks, "particle"},
                                           std::tuple{opt.fluid_ranks, &scene.run.fluid_ranks, "fluid"}}) {
    if (asked <= 0 || asked == *ranks) continue;
    if (dir.placement.across_hosts())
      throw std::runtime_error(fmt::format(
          "{} runs across hosts, whose ranks were placed at its start: resume it on its {} {} ranks", dir.path,
          *ranks, what));
    *ranks = asked;
  }
  if (dir.transport_recorded) {
    scene.hosts.transport = dir.placement.transport;
    scene.hosts.relay_address = dir.placement.relay_address;
    scene.hosts.relay_port = dir.placement.relay_port;
  }
  refuse_unsigned_commands(dir, ctx, scene, opt.allow_commands);
  refuse_fluid_ranks(scene, dir.path);
  const auto from = dir.last_checkpoint();
  // Stopped while its feeder developed, before the nodes of the run itself started: that is
  // finished, then the run starts.
  if (!from && develops_feeder(scene) && !std::filesystem::exists(dir.metrics_file())) {
    RunOptions placement;
    placement.fluid_ranks = scene.run.fluid_ranks;
    placement.particle_ranks = scene.run.particle_ranks;
    dir.record_ranks(scene.run.fluid_ranks, scene.run.particle_ranks);
    std::ofstream(dir.path + "/coordinator.pid") << getpid() << "\n";
    fmt::print(stderr, "hemocosim: run {} in {} starts after its feeder's develop run\n", ctx.run_id, dir.path);
    develop_feeder(scene, dir, placement);
    return drive_and_finish(scene, dir, ctx, {0, last_step(scene, opt.stop_after_step)});
  }
  if (!from) throw std::runtime_error(fmt::format("{} has no complete checkpoint to resume from", dir.path));
  dir.verify_checkpoint(*from);
  need_free_space(dir, *from);
  const long last = last_step(scene, opt.stop_after_step);
  if (*from >= last)
    throw std::runtime_error(
        fmt::format("{}: its checkpoint of step {} is already at the end (step {})", dir.path, *from, last));
  ctx.drop_every = scene.run.drop_every;
  dir.record_ranks(scene.run.fluid_ranks, scene.run.particle_ranks);  // a later resume goes on with these
  dir.drop_metrics_after(*from);
  std::ofstream(dir.path + "/coordinator.pid") << getpid() << "\n";
  fmt::print(stderr, "hemocosim: run {} in {} resumes from step {}\n", ctx.run_id, dir.path, *from);
  return drive_and_finish(scene, dir, ctx, {*from, last});
}

}  // namespace hemo
