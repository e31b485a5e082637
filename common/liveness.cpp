// SPDX-License-Identifier: GPL-3.0-or-later
#include "liveness.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <fstream>
#include <sstream>

namespace hemo {

namespace {
double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

std::string host_name() {
  char host[256] = {0};
  ::gethostname(host, sizeof host - 1);
  return host;
}
}  // namespace

ProcessState process_state(pid_t pid) {
  if (pid <= 0) return ProcessState::gone;
  // /proc/PID/stat: "pid (comm) S ...", comm may hold spaces and parentheses: the state follows the last ')'.
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  std::getline(in, stat);
  const auto paren = stat.rfind(')');
  if (paren == std::string::npos || paren + 2 >= stat.size())
    return ::kill(pid, 0) == 0 || errno == EPERM ? ProcessState::running : ProcessState::gone;
  switch (stat[paren + 2]) {
    case 'T':  // stopped by a signal
    case 't':  // stopped by a debugger
      return ProcessState::stopped;
    case 'Z':
    case 'X':
      return ProcessState::gone;
    default:
      return ProcessState::running;
  }
}

std::string coordinator_process_file(const std::string& run_dir) { return run_dir + "/coordinator.process"; }

void write_coordinator_process(const std::string& run_dir) {
  std::ofstream(coordinator_process_file(run_dir)) << fmt::format("host={} pid={}\n", host_name(), ::getpid());
}

ProcessState coordinator_state(const std::string& run_dir) {
  std::ifstream in(coordinator_process_file(run_dir));
  std::string host_field, pid_field;
  if (!(in >> host_field >> pid_field) || pid_field.rfind("pid=", 0) != 0) return ProcessState::unknown;
  if (host_field != "host=" + host_name()) return ProcessState::elsewhere;
  try {
    return process_state(static_cast<pid_t>(std::stol(pid_field.substr(4))));
  } catch (const std::exception&) {
    return ProcessState::unknown;
  }
}

std::string pause_words(double seconds) {
  return fmt::format("paused for {:.0f} s (SIGSTOP or a suspended host?)", seconds);
}

PauseWatch::PauseWatch() : last_(now()) {}

double PauseWatch::turn() {
  const double t = now(), gap = t - last_;
  last_ = t;
  return gap > kPauseGapS ? gap : 0.0;
}

}  // namespace hemo
