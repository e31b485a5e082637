// A node running as a child process of the coordinator, its output captured in a log file.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <sys/types.h>
#include <string>
#include <vector>

namespace hemo {

// The last non-empty line of a log, leaving out what Open MPI adds when a job aborts: its
// notices framed by lines of dashes (MPI_ABORT was invoked ...) and its "[host:pid] N more
// processes ..." lines, which follow the node's own last words in any order. A log with nothing
// else gives the first line of the last notice (mpirun could not launch ...).
std::string last_said_line(const std::string& log_text);

class NodeProcess {
 public:
  // `stdin_fd` >= 0: the child's stdin (StartOptions::stdin_fd).
  NodeProcess(std::string name, std::vector<std::string> argv, std::string log_path, int stdin_fd = -1);
  ~NodeProcess();  // terminates the process if it still runs
  NodeProcess(const NodeProcess&) = delete;
  NodeProcess& operator=(const NodeProcess&) = delete;

  const std::string& name() const { return name_; }
  const std::string& log_path() const { return log_path_; }
  pid_t pid() const { return pid_; }
  bool running();
  // "exited with status 3" / "killed by signal 9"; empty while running.
  std::string how_it_ended() const { return ended_; }
  // SIGTERM, then SIGKILL after `grace_s`.
  void terminate(double grace_s = 3.0);
  // Waits up to `timeout_s` for a clean exit; true if it exited with status 0.
  bool wait_exit(double timeout_s);
  // Peak resident memory of the node process and its children (MPI ranks), once it ended; MiB.
  double peak_memory_mib() const { return peak_rss_kib_ / 1024.0; }
  // The last line of the node's log that says something of its own, for error messages
  // (last_said_line).
  std::string last_log_line() const;

 private:
  void reap(int status);
  std::string name_, log_path_, ended_;
  pid_t pid_ = -1;
  int status_ = -1;
  long peak_rss_kib_ = 0;
};

}  // namespace hemo
