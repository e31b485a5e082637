// SPDX-License-Identifier: GPL-3.0-or-later
#include "node_launcher.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>

#include "child_process.h"
#include "hosts.h"
#include "mpi_job.h"
#include "node_process.h"

namespace hemo {

namespace {
class ProcessHandle : public NodeHandle {
 public:
  ProcessHandle(const std::string& node, const std::vector<std::string>& argv, const std::string& log_path)
      : process_(node, argv, log_path) {}
  bool running() override { return process_.running(); }
  std::string how_it_ended() const override { return process_.how_it_ended(); }
  void terminate() override { process_.terminate(); }
  pid_t pid() const override { return process_.pid(); }
  std::string log_path() const override { return process_.log_path(); }
  std::string last_log_line() const override { return process_.last_log_line(); }
  double peak_memory_mib() const override { return process_.peak_memory_mib(); }

 private:
  NodeProcess process_;
};
}  // namespace

std::unique_ptr<NodeHandle> ProcessLauncher::launch(const std::string& node, const std::vector<std::string>& argv,
                                                    const std::string& log_path) {
  return std::make_unique<ProcessHandle>(node, argv, log_path);
}

}  // namespace hemo

namespace hemo {

namespace {
// A node started on another host by the launch command: the local process is that command
// (ssh), whose stdin is a pipe only this coordinator writes to. Closing it (terminate, or the
// coordinator's death) is what ends the node there (remote_node_command).
class RemoteHandle : public NodeHandle {
 public:
  RemoteHandle(const std::string& node, const std::vector<std::string>& argv, const std::string& log_path) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(node + " node: cannot create a pipe");
    Fd read_end{fds[0]};
    keep_alive_ = fds[1];
    process_ = std::make_unique<NodeProcess>(node, argv, log_path, read_end.fd);
  }
  ~RemoteHandle() override {
    terminate();
    close_pipe();
  }
  bool running() override { return process_->running(); }
  std::string how_it_ended() const override { return process_->how_it_ended(); }
  void terminate() override {
    if (!process_->running()) return;
    close_pipe();
    // The node gets SIGTERM there and SIGKILL 5 s later; then the connection ends.
    if (process_->wait_exit(8.0) || !process_->running()) return;
    process_->terminate(1.0);
  }
  pid_t pid() const override { return process_->pid(); }
  std::string log_path() const override { return process_->log_path(); }
  std::string last_log_line() const override { return process_->last_log_line(); }
  double peak_memory_mib() const override { return 0; }  // not known from here

 private:
  struct Fd {
    int fd;
    ~Fd() { ::close(fd); }
  };
  void close_pipe() {
    if (keep_alive_ >= 0) ::close(keep_alive_);
    keep_alive_ = -1;
  }
  std::unique_ptr<NodeProcess> process_;
  int keep_alive_ = -1;
};

// A node that made itself a Slurm job step: the child here is srun, whose own memory is not the
// node's.
class StepHandle : public ProcessHandle {
 public:
  using ProcessHandle::ProcessHandle;
  double peak_memory_mib() const override { return 0; }  // not known from here
};

std::string random_token() {
  std::random_device rd;
  return fmt::format("{:08x}{:08x}{:08x}", rd(), rd(), rd());
}
}  // namespace

HostLauncher::HostLauncher(HostPlacement placement, std::string run_dir)
    : placement_(std::move(placement)), run_dir_(std::move(run_dir)) {}

// How the check reaches `host`: the ssh launcher's command, or a one-task job step there.
std::vector<std::string> HostLauncher::check_command(const std::string& host) const {
  if (placement_.launcher == Launcher::slurm)
    return {starter_program(MpiStarter::srun, std::getenv),
            "--overlap",
            "--nodes=1",
            "--ntasks=1",
            "--nodelist=" + host,
            "sh",
            "-c",
            remote_check_command(run_dir_)};
  return expand_launch_command(
      placement_.launch_command,
      {{"host", host}, {"command", remote_check_command(run_dir_)}, {"node", "check"}, {"run_dir", run_dir_}});
}

void HostLauncher::check_hosts() const {
  if (placement_.launcher == Launcher::local) return;
  std::vector<std::string> hosts;
  for (const auto& list : {placement_.fluid, placement_.particles})
    for (const auto& h : parse_host_list(list))
      if (std::find(hosts.begin(), hosts.end(), h.host) == hosts.end()) hosts.push_back(h.host);
  const std::string token = random_token();
  const std::string token_file = run_dir_ + "/" + kHostsCheckFile;
  std::ofstream(token_file) << token << "\n";
  for (const auto& host : hosts) {
    const auto argv = check_command(host);
    std::vector<std::string> lines;
    ChildOptions opt;
    opt.on_line = [&lines](const std::string& line) { lines.push_back(line); };
    opt.merge_stderr = true;
    const auto result = run_child(argv, opt);
    const std::string last = lines.empty() ? "no output" : lines.back();
    if (placement_.launcher == Launcher::slurm && !result.ok() && (lines.empty() || last.rfind("srun", 0) == 0))
      throw std::runtime_error(fmt::format("cannot start a job step on node {} with `{}` ({}): {}", host, argv.front(),
                                           result.describe(), last));
    if (result.exit_code == 255 || result.exit_code == 127)  // ssh's own failure; no such program
      throw std::runtime_error(
          fmt::format("cannot reach host {} with `{}` ({}): {}", host, argv.front(), result.describe(), last));
    if (!result.ok() || lines.empty() || lines.front() != token)
      throw std::runtime_error(
          fmt::format("host {} does not see the run directory {} ({} there: {}); it must be on a filesystem every host "
                      "shares, at the same path (docs/hosts.md)",
                      host, run_dir_, kHostsCheckFile, result.ok() ? "another token" : last));
  }
  std::filesystem::remove(token_file);
}

std::unique_ptr<NodeHandle> HostLauncher::launch(const std::string& node, const std::vector<std::string>& argv,
                                                 const std::string& log_path) {
  const auto hosts = parse_host_list(node == "fluid" ? placement_.fluid : placement_.particles);
  if (placement_.launcher == Launcher::slurm) {
    std::ofstream(log_path, std::ios::app)
        << "hemocosim: starting the " << node << " node as a Slurm job step on " << host_list_text(hosts) << "\n";
    return std::make_unique<StepHandle>(node, argv, log_path);
  }
  if (hosts.empty() || placement_.launcher == Launcher::local) return ProcessLauncher().launch(node, argv, log_path);
  const auto command =
      expand_launch_command(placement_.launch_command, {{"host", hosts.front().host},
                                                        {"command", remote_node_command(run_dir_, argv)},
                                                        {"node", node},
                                                        {"run_dir", run_dir_}});
  std::ofstream(log_path, std::ios::app) << "hemocosim: starting the " << node << " node on " << hosts.front().host
                                         << " (ranks on " << host_list_text(hosts) << ")\n";
  return std::make_unique<RemoteHandle>(node, command, log_path);
}

Scene placed_in_allocation(const Scene& scene) {
  if (scene.hosts.launcher != Launcher::slurm || (!scene.hosts.fluid.empty() && !scene.hosts.particles.empty())) return scene;
  const char* job = std::getenv("SLURM_JOB_ID");
  const char* nodelist = std::getenv("SLURM_JOB_NODELIST");
  if (job == nullptr || nodelist == nullptr)
    throw std::runtime_error(
        "hosts.launcher = \"slurm\" starts the nodes as steps of a Slurm job, and this is not one (SLURM_JOB_ID "
        "is not set): run it from sbatch or salloc (docs/slurm.md)");
  std::vector<std::string> nodes;
  ChildOptions opt;
  opt.on_line = [&nodes](const std::string& line) {
    if (!line.empty()) nodes.push_back(line);
  };
  const auto result = run_child({"scontrol", "show", "hostnames", nodelist}, opt);
  if (!result.ok() || nodes.empty())
    throw std::runtime_error(fmt::format("cannot list the nodes of Slurm job {} (scontrol show hostnames {}: {})", job,
                                         nodelist, result.describe()));
  Scene placed = scene;
  const auto [fluid, particles] = split_allocation(nodes, scene.run.fluid_ranks, scene.run.particle_ranks);
  if (placed.hosts.fluid.empty()) placed.hosts.fluid = fluid;
  if (placed.hosts.particles.empty()) placed.hosts.particles = particles;
  return placed;
}

}  // namespace hemo
