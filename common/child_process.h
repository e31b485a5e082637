// Running a program as a child process: its output line by line, its exit status.
// Used by `plot` (the Python script) and `study` (one `hemocosim run` per scene).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

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

// Directory of the running executable (from /proc/self/exe).
std::string executable_dir();

}  // namespace hemo
