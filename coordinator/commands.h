// The coordinator's subcommands.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>

namespace hemo {

struct RunOptions {
  std::string scene;
  std::string out;      // run directory; default runs/<name>-<time>
  int fluid_ranks = 0;  // 0: as the scene says
  int particle_ranks = 0;
  long stop_after_step = 0;  // > 0: stop after this step, writing a checkpoint there
  // Placement across hosts (docs/hosts.md); empty: as the scene's [hosts] says.
  std::string fluid_hosts, particle_hosts;
  std::string fluid_hostfile, particle_hostfile;  // Open MPI host files, read into the lists above
  std::string launcher, launch_command;
  int bus_ttl = -1;  // -1: as the scene says (run.bus_ttl)
  // The bus's transport and the TCP relay's address (docs/hosts.md); empty / -1: as the scene says.
  std::string transport, relay_address;
  int relay_port = -1;
  // Where a developed feeder's run goes (vessel.feeder_develop_s, model/feeder_develop.h): empty,
  // into RUN_DIR/feeder-develop; else into this folder's subfolder named by the SHA-256 of its
  // scene, kept for the next run with the same feeder (a study's runs) and linked from RUN_DIR.
  std::string feeder_cache;
};
int run_command(const RunOptions& opt);

// Goes on with a run from its last checkpoint (after an interrupt, --stop-after-step, a failure).
struct ResumeOptions {
  std::string run_dir;
  long stop_after_step = 0;
  int particle_ranks = 0;       // the particle node's rank count from now on (0: as recorded)
  int fluid_ranks = 0;          // the fluid node's likewise
  bool allow_commands = false;  // run node commands the run did not record (RunDirectory::commands_signed)
};
int resume_command(const ResumeOptions& opt);

// Asks a running run's coordinator to restart a node, or to swap it for another program
// (docs/design.md "Checkpoint, restart, swap"): it checkpoints the current step and starts both
// nodes again from there. Waits for the coordinator's answer.
struct ControlOptions {
  std::string run_dir;
  std::string node;  // fluid or particles
  std::string with;  // swap: the program (and arguments) that takes the node's place
  double timeout_s = 300;
};
int control_command(const std::string& action, const ControlOptions& opt);

int check_command(const std::string& scene_path, const std::string& out_dir = "");
int list_keys_command();  // every scene key with its default, as a Markdown table

// A live view of a run's bus (docs/design.md "Monitoring"): from the run directory, or, on a
// host without it, from the bus URL, run id and a copy of the secret file (never the secret on
// the command line, where `ps` shows it).
struct MonitorOptions {
  std::string run_dir;
  std::string url;          // overrides run.toml's
  std::string run_id;       // overrides run.toml's
  std::string secret_file;  // overrides RUN_DIR/secret
  long total_steps = 0;     // for the ETA; 0: the run's scene copy
  double duration_s = 0;    // 0: until Ctrl-C
  double interval_s = 1;
  bool plain = false;  // no screen clearing (logs, tests)
  bool json = false;   // one JSON object per interval instead of the table
  int http_port = -1;  // >= 0: serve the live page (0: any free port)
  std::string bind = "127.0.0.1";
};
int monitor_command(const MonitorOptions& opt);

}  // namespace hemo
