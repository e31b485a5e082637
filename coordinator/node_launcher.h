// How the lockstep starts its nodes, behind an interface: the coordinator starts child
// processes (ProcessLauncher), the runtime's unit tests start fake nodes in threads, so the
// lockstep, restart and swap logic can be tested without OpenFOAM or LIGGGHTS.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <sys/types.h>

#include <memory>
#include <string>
#include <vector>

#include "scene.h"

namespace hemo {

// What the lockstep needs to know of a running node besides its messages.
class NodeHandle {
 public:
  virtual ~NodeHandle() = default;  // ends the node if it still runs
  virtual bool running() = 0;
  // "exited with status 3" / "was killed by signal 9 (Killed)"; empty while running.
  virtual std::string how_it_ended() const = 0;
  virtual void terminate() = 0;
  virtual pid_t pid() const = 0;
  virtual std::string log_path() const = 0;
  // The last non-empty line of its log, for error messages.
  virtual std::string last_log_line() const = 0;
  // Peak resident memory, once it ended (MiB; 0 if not known).
  virtual double peak_memory_mib() const = 0;
};

class NodeLauncher {
 public:
  virtual ~NodeLauncher() = default;
  // Starts `node` ("fluid" or "particles") as `argv` (the program, then the arguments the
  // lockstep gives every node: --scene, --run-dir, --run-id, ..., --resume-step), its output
  // going to `log_path`.
  virtual std::unique_ptr<NodeHandle> launch(const std::string& node, const std::vector<std::string>& argv,
                                             const std::string& log_path) = 0;
};

// Nodes as child processes (node_process.h).
class ProcessLauncher : public NodeLauncher {
 public:
  std::unique_ptr<NodeHandle> launch(const std::string& node, const std::vector<std::string>& argv,
                                     const std::string& log_path) override;
};

// Nodes placed on hosts (docs/hosts.md, scene [hosts]): a node with hosts and the ssh launcher
// is started on its first host by the site's launch command (hosts.launch_command), and Open MPI
// starts its other ranks; a node without hosts, or with the local launcher, is a child process
// here. The node ends when the launch command's connection closes: when it is terminated and
// when the coordinator dies.
//
// With the slurm launcher a node is a child process here that makes itself a job step of the
// allocation (srun, common/mpi_job.h) on its hosts; srun passes the coordinator's SIGTERM on.
class HostLauncher : public NodeLauncher {
 public:
  HostLauncher(HostPlacement placement, std::string run_dir);
  // Before any node starts: every host of the ssh launcher answers through the launch command
  // (of the slurm launcher, through a one-task srun step) and sees the run directory (a token
  // written here is read back there). Throws one line naming the host.
  void check_hosts() const;
  std::unique_ptr<NodeHandle> launch(const std::string& node, const std::vector<std::string>& argv,
                                     const std::string& log_path) override;

 private:
  std::vector<std::string> check_command(const std::string& host) const;
  HostPlacement placement_;
  std::string run_dir_;
};

// The scene with the slurm launcher's hosts filled in from the allocation the coordinator runs
// in (split_allocation of `scontrol show hostnames $SLURM_JOB_NODELIST`) where the scene or the
// command line gave none; other scenes unchanged. Not kept in run.toml: a requeued job may get
// other nodes. Throws one line outside an allocation.
Scene placed_in_allocation(const Scene& scene);

}  // namespace hemo
