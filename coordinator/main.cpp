// hemocosim: the coordinator of the blood co-simulation.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "analyze.h"
#include "bench.h"
#include "commands.h"
#include "plot.h"
#include "scene.h"
#include "study.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

int main(int argc, char** argv) {
  CLI::App app{"hemocosim: unresolved CFD-DEM of red blood cells and platelets, coupled over LCM"};
  app.require_subcommand(1);

  hemo::RunOptions run;
  auto* run_cmd = app.add_subcommand("run", "Run a scene: launch the fluid and particle nodes and couple them");
  run_cmd->add_option("scene", run.scene, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  run_cmd->add_option("--out", run.out, "Run directory to create (default runs/<name>-<time>)");
  run_cmd->add_option("--np-fluid", run.fluid_ranks, "MPI ranks of the fluid node (overrides run.fluid_ranks)")
      ->check(CLI::PositiveNumber);
  run_cmd
      ->add_option("--np-particles", run.particle_ranks,
                   "MPI ranks of the particle node (overrides run.particle_ranks)")
      ->check(CLI::PositiveNumber);
  run_cmd
      ->add_option("--stop-after-step", run.stop_after_step,
                   "Stop after this coupling step, writing a checkpoint there (go on with `hemocosim resume`)")
      ->check(CLI::PositiveNumber);
  auto* fluid_hosts = run_cmd->add_option(
      "--fluid-hosts", run.fluid_hosts,
      "Hosts of the fluid node's MPI job and ranks on each, e.g. a or a:2,b:2; its ranks are their sum "
      "(overrides hosts.fluid; docs/hosts.md)");
  auto* particle_hosts = run_cmd->add_option(
      "--particle-hosts", run.particle_hosts,
      "Hosts of the particle node's MPI job and ranks on each, e.g. b:2,c:2 (overrides hosts.particles)");
  run_cmd
      ->add_option("--fluid-hostfile", run.fluid_hostfile,
                   "The fluid node's hosts as an Open MPI host file (lines `host slots=N`) instead of --fluid-hosts")
      ->check(CLI::ExistingFile)
      ->excludes(fluid_hosts);
  run_cmd
      ->add_option("--particle-hostfile", run.particle_hostfile,
                   "The particle node's hosts as an Open MPI host file instead of --particle-hosts")
      ->check(CLI::ExistingFile)
      ->excludes(particle_hosts);
  run_cmd
      ->add_option("--launcher", run.launcher,
                   "How a node with hosts starts: ssh (on its first host, by the launch command), local (here; "
                   "Open MPI places its ranks) or slurm (a job step of the Slurm job this runs in, on its share of "
                   "the job's nodes; docs/slurm.md) (overrides hosts.launcher)")
      ->check(CLI::IsMember(hemo::choice_names<hemo::Launcher>()));
  run_cmd->add_option(
      "--launch-command", run.launch_command,
      "The command that starts a node on a host, with {host} {command} {node} {run_dir} (default \"ssh -o "
      "BatchMode=yes {host} {command}\"; overrides hosts.launch_command)");
  run_cmd
      ->add_option("--bus-ttl", run.bus_ttl,
                   "Multicast TTL of the run's bus (default 0 on one host, 1 with hosts; overrides run.bus_ttl)")
      ->check(CLI::Range(0, 255));
  run_cmd
      ->add_option("--transport", run.transport,
                   "The bus: multicast (LCM UDP multicast) or tcp (through a relay the coordinator runs, for "
                   "networks without multicast) (overrides hosts.transport; docs/hosts.md)")
      ->check(CLI::IsMember(hemo::choice_names<hemo::Transport>()));
  run_cmd->add_option("--relay-address", run.relay_address,
                      "IPv4 address of this host the TCP relay listens on, reachable from the nodes' hosts (default "
                      "auto; overrides hosts.relay_address)");
  run_cmd
      ->add_option("--relay-port", run.relay_port,
                   "Port of the TCP relay (0: any free one; overrides hosts.relay_port)")
      ->check(CLI::Range(0, 65535));

  run_cmd->add_option("--feeder-cache", run.feeder_cache,
                      "Folder of developed feeders (vessel.feeder_develop_s): a feeder developed there before for "
                      "the same scene is used again, a new one is kept there (default: in the run directory)");

  hemo::ResumeOptions resume;
  auto* resume_cmd = app.add_subcommand(
      "resume", "Go on with a stopped run (interrupted, failed, --stop-after-step) from its last checkpoint");
  resume_cmd->add_option("run_dir", resume.run_dir, "Run directory")->required()->check(CLI::ExistingDirectory);
  resume_cmd
      ->add_option("--stop-after-step", resume.stop_after_step,
                   "Stop again after this coupling step, writing a checkpoint there")
      ->check(CLI::PositiveNumber);
  resume_cmd
      ->add_option("--np-particles", resume.particle_ranks,
                   "MPI ranks of the particle node from now on (default: as before); the checkpoint's particles "
                   "are shared anew among them")
      ->check(CLI::PositiveNumber);
  resume_cmd
      ->add_option("--np-fluid", resume.fluid_ranks,
                   "MPI ranks of the fluid node from now on (default: as before); the checkpoint's fields are "
                   "redistributed onto them (reconstructPar, decomposePar)")
      ->check(CLI::PositiveNumber);
  resume_cmd->add_flag("--allow-commands", resume.allow_commands,
                       "Run the nodes' commands (run.fluid_command, run.particle_command, a swap's) even when this "
                       "run's coordinator did not record them: scene.toml or run.toml was changed since");

  // restart and swap: a request to the coordinator of a running run.
  auto add_node_request = [&app](const char* name, const char* what, hemo::ControlOptions& opt) {
    auto* cmd = app.add_subcommand(name, what);
    cmd->add_option("run_dir", opt.run_dir, "Run directory of a running run")
        ->required()
        ->check(CLI::ExistingDirectory);
    cmd->add_option("node", opt.node, "The node: fluid or particles")
        ->required()
        ->check(CLI::IsMember({"fluid", "particles"}));
    cmd->add_option("--timeout", opt.timeout_s, "Seconds to wait for the coordinator to carry it out")
        ->capture_default_str();
    return cmd;
  };
  hemo::ControlOptions restart, swap;
  auto* restart_cmd = add_node_request(
      "restart", "Restart a node of a running run: both nodes go on from a checkpoint of the current step", restart);
  auto* swap_cmd = add_node_request("swap",
                                    "Swap a node of a running run for another program that speaks the messages; it "
                                    "goes on from a checkpoint of the current step",
                                    swap);
  swap_cmd
      ->add_option("--with", swap.with,
                   "The program (and its arguments) that takes the node's place; it gets the node's usual options, "
                   "--resume-step among them")
      ->required();

  std::string check_scene;
  auto* check_cmd = app.add_subcommand("check", "Validate a scene and summarise what it will run");
  bool list_keys = false;
  check_cmd->add_option("scene", check_scene, "Scene file (TOML)")->check(CLI::ExistingFile);
  check_cmd->add_flag("--keys", list_keys, "List every scene key with its default and the values it allows instead");
  std::string check_out;
  check_cmd->add_option("--out", check_out,
                        "Where the run directory will be (its filesystem's free space is compared with the estimate; "
                        "default: the current directory)");

  hemo::MonitorOptions mon;
  auto* mon_cmd = app.add_subcommand(
      "monitor",
      "Live view of a run's coupling traffic: latency, compute and wait, rate and ETA, bytes/s, resends, "
      "rejections, the nodes' diagnostics; a table, JSON lines or a page with time plots");
  mon_cmd
      ->add_option("run_dir", mon.run_dir, "Run directory of a running run (or give --url, --run-id and --secret-file)")
      ->check(CLI::ExistingDirectory);
  mon_cmd->add_option("--url", mon.url, "LCM URL of the run's bus (default: RUN_DIR/run.toml's lcm_url)");
  mon_cmd->add_option("--run-id", mon.run_id, "The run's id (default: RUN_DIR/run.toml's run_id)");
  mon_cmd
      ->add_option(
          "--secret-file", mon.secret_file,
          "A copy of the run's secret file (default: RUN_DIR/secret); the secret itself never goes on a command line")
      ->check(CLI::ExistingFile);
  mon_cmd
      ->add_option("--steps", mon.total_steps, "The run's coupling steps, for the ETA (default: RUN_DIR/scene.toml's)")
      ->check(CLI::PositiveNumber);
  mon_cmd->add_option("--duration", mon.duration_s, "Stop after this many seconds (0: until Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  mon_cmd->add_option("--interval", mon.interval_s, "Seconds between refreshes")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 3600.0));
  mon_cmd->add_flag("--plain", mon.plain, "Append tables instead of redrawing the screen");
  mon_cmd->add_flag("--json", mon.json,
                    "Print one JSON object per interval instead of the table (schema: docs/design.md, Monitoring)");
  mon_cmd
      ->add_option("--http", mon.http_port,
                   "Also serve a live page with time plots on this port (0: any free one; its address goes to stderr)")
      ->check(CLI::Range(0, 65535));
  mon_cmd
      ->add_option("--bind", mon.bind,
                   "Address the page is served on (read-only and unauthenticated: loopback by default)")
      ->capture_default_str();

  hemo::AnalyzeOptions ana;
  auto* ana_cmd =
      app.add_subcommand("analyze",
                         "Observables of a finished run: CFL, profiles, MSD and D, viscosity, hematocrit, momentum "
                         "balance, platelets on the axis; a bifurcation's outlet shares, and per branch H_D, "
                         "platelet flux and CFL");
  ana_cmd->add_option("run_dir", ana.run_dir, "Run directory")->required()->check(CLI::ExistingDirectory);
  ana_cmd->add_flag("--json", ana.json, "Print JSON instead of the table");
  ana_cmd->add_option("--bins", ana.bins, "Radial bins over [0, R]")->capture_default_str()->check(CLI::PositiveNumber);
  ana_cmd->add_option("--t-fit", ana.t_fit, "s: D from the MSD over [0, t_fit]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  ana_cmd->add_option("--window-start", ana.window_start,
                      "s: start of the averaging window (default: second half of the run, or of [0, end])");
  ana_cmd->add_option("--window-end", ana.window_end, "s: end of the averaging window (default: the last snapshot)");
  ana_cmd
      ->add_option("--slices", ana.slices,
                   "CFL stations: axial slices (default: about 20 RBCs per station; a bifurcation's: " +
                       std::to_string(hemo::analysis::kBranchSlices) + " along each branch)")
      ->check(CLI::NonNegativeNumber);
  ana_cmd->add_option("--sectors", ana.sectors, "CFL stations: angular sectors (default: about 20 RBCs per station)")
      ->check(CLI::NonNegativeNumber);

  hemo::PlotOptions plot;
  auto* plot_cmd = app.add_subcommand(
      "plot",
      "PNG figures of analysed runs: profiles over time, MSD and D, observables against the swept key; a "
      "bifurcation's outlet shares over time against the blood's (phase separation) and CFL along each branch");
  plot_cmd
      ->add_option("run_dirs", plot.run_dirs, "Run directories (analysed first when analysis.json is missing or stale)")
      ->required();
  plot_cmd->add_option("--out", plot.out,
                       "Directory for the PNG files (default RUN_DIR/figures for one run, ./figures for several)");
  plot_cmd->add_option("--key", plot.key,
                       "Swept scene key, dotted (default: the one key whose value differs between the runs)");
  plot_cmd->add_option("--labels", plot.labels, "Names of the runs in the figures, one per run")->delimiter(',');
  plot_cmd->add_flag("--reanalyze", plot.reanalyze, "Analyse again even when analysis.json is up to date");

  hemo::StudyOptions study;
  auto* study_cmd =
      app.add_subcommand("study", "Run every scene of a study (resuming), analyse them, write report.md with figures");
  study_cmd->add_option("study", study.study, "Study name (scenes/studies/<name>.toml) or study file")->required();
  study_cmd->add_option("--out", study.out, "Study directory (default runs/study-<name>, runs/study-<name>-reduced)");
  study_cmd->add_flag("--reduced", study.reduced,
                      "Shrink every scene (vessel, mesh, time) so the study runs in minutes");
  study_cmd->add_flag("--no-plot", study.no_plot, "Write the report without figures");
  study_cmd->add_flag("--check", study.check_only, "Only expand and validate the study's scenes and print the plan");

  hemo::BenchOptions bench;
  auto* bench_cmd = app.add_subcommand("bench",
                                       "Run time against error: run bench suites (scenes/bench), errors against each "
                                       "suite's reference, bench.md with figures");
  bench_cmd->add_option("suites", bench.suites,
                        "Suite names (scenes/bench/<name>.toml, or a group such as 'stress') or files (default: every "
                        "suite but the stress tests)");
  bench_cmd->add_option("--out", bench.out, "Bench directory")->capture_default_str();
  bench_cmd->add_option("--hemocosim", bench.hemocosim,
                        "hemocosim executable for the runs (its nodes are used; default: this one)");
  bench_cmd->add_flag("--no-plot", bench.no_plot, "Write bench.md without figures");
  bench_cmd->add_flag("--check", bench.check_only,
                      "Only expand and validate the suites' scenes (stress suites too) and print the plan");

  CLI11_PARSE(app, argc, argv);
  try {
    if (*run_cmd) return hemo::run_command(run);
    if (*resume_cmd) return hemo::resume_command(resume);
    if (*restart_cmd) return hemo::control_command("restart", restart);
    if (*swap_cmd) return hemo::control_command("swap", swap);
    if (*check_cmd) return list_keys ? hemo::list_keys_command() : hemo::check_command(check_scene, check_out);
    if (*mon_cmd) return hemo::monitor_command(mon);
    if (*ana_cmd) return hemo::analyze_command(ana);
    if (*plot_cmd) return hemo::plot_command(plot);
    if (*study_cmd) return hemo::study_command(study);
    if (*bench_cmd) return hemo::bench_command(bench);
  } catch (const hemo::SceneError& e) {
    for (const auto& p : e.problems())
      fmt::print(stderr, "hemocosim: error: {}\n", p.str(run.scene.empty() ? check_scene : run.scene));
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "hemocosim: error: {}\n", e.what());
    return 1;
  }
  return 0;
}
