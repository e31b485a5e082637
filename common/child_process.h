// Running a program as a child process: the one fork/exec of hemocosim. run_child waits for it
// (`plot` runs the Python script, `study` and `bench` one `hemocosim run` per scene, the fluid
// launcher decomposePar);
// start_child leaves it running (the coordinator's nodes, coordinator/node_process.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <sys/types.h>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace hemo {

struct ChildResult {
  int exit_code = -1;  // the program's exit status, or 128 + signal when a signal ended it
  int signal = 0;      // the signal that ended it, 0 when it exited
  bool ok() const { return exit_code == 0; }
  std::string describe() const;  // "exited with status 2" / "was killed by signal 2 (Interrupt)"
};

// The result of a status from wait(2) of a child that exited or was killed.
ChildResult child_result(int wait_status);

struct ChildOptions {
  std::vector<std::pair<std::string, std::string>> env;  // set in the child only
  // When set, the child's stdout (and its stderr too when merge_stderr) is read through a pipe
  // and handed over line by line ('\n' and '\r' both end a line; empty lines are skipped).
  // Otherwise the child writes to this process's stdout/stderr.
  std::function<void(const std::string&)> on_line;
  bool merge_stderr = false;
  bool quiet = false;  // discard all output (probing a program)
  // When set, polled while the child runs: once it reads non-zero, the child gets SIGINT (a
  // signal handler of the caller sets it, e.g. on SIGTERM from a batch system's time limit,
  // which only reaches this process).
  const volatile int* stop_flag = nullptr;
};

// Runs argv[0] (searched in PATH when it has no '/'); throws std::runtime_error only when the
// child cannot be created. A program that cannot be executed gives exit code 127.
ChildResult run_child(const std::vector<std::string>& argv, const ChildOptions& opt = {});

struct StartOptions {
  std::vector<std::pair<std::string, std::string>> env;  // set in the child only
  // The child's stdout and stderr are appended to this file (created 0644); empty: this
  // process's. A file that cannot be opened throws before anything is started.
  std::string log_path;
  // The child leads a process group of its own, so that kill(-pid, ...) also reaches what it
  // starts (the ranks under mpirun).
  bool own_process_group = false;
  // The child gets SIGTERM when the thread that started it ends, however it ends (SIGKILL
  // included). It is kept across exec, and mpirun passes it on to its ranks.
  bool die_with_parent = false;
  // When >= 0, the child's stdin (e.g. the read end of a pipe whose write end only the caller
  // holds: the child sees end of file when the caller closes it or dies). Else this process's.
  int stdin_fd = -1;
};

// Starts argv[0] (searched in PATH when it has no '/') and returns its pid without waiting; the
// caller reaps it (waitpid / wait4). A program that cannot be executed exits with 127 after a
// line on its stderr; with die_with_parent, one whose parent was already gone exits with 125.
// Throws std::runtime_error when the child cannot be created.
pid_t start_child(const std::vector<std::string>& argv, const StartOptions& opt = {});

// Directory of the running executable (from /proc/self/exe).
std::string executable_dir();

}  // namespace hemo
