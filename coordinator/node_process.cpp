// SPDX-License-Identifier: GPL-3.0-or-later
#include "node_process.h"

#include <fmt/format.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <stdexcept>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace hemo {

NodeProcess::NodeProcess(std::string name, std::vector<std::string> argv, std::string log_path)
    : name_(std::move(name)), log_path_(std::move(log_path)) {
  if (argv.empty()) throw std::runtime_error(name_ + " node: empty command");
  const int log = ::open(log_path_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (log < 0) throw std::runtime_error(fmt::format("cannot open {}: {}", log_path_, std::strerror(errno)));
  const pid_t coordinator = ::getpid();
  pid_ = ::fork();
  if (pid_ < 0) throw std::runtime_error(fmt::format("cannot start the {} node: {}", name_, std::strerror(errno)));
  if (pid_ == 0) {
    ::setpgid(0, 0);  // its own process group: mpirun children die with it
    // The node dies with its coordinator, even one killed with SIGKILL: SIGTERM when the
    // coordinator (the thread that forked it) ends. It survives the exec (of the node, and of
    // mpirun when the node becomes one, which passes it on to the ranks). A coordinator that
    // died before this line is no longer our parent.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != coordinator) ::_exit(125);
    ::dup2(log, STDOUT_FILENO);
    ::dup2(log, STDERR_FILENO);
    ::close(log);
    std::vector<char*> args;
    for (auto& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    ::execvp(args[0], args.data());
    std::fprintf(stderr, "cannot execute %s: %s\n", args[0], std::strerror(errno));
    ::_exit(127);
  }
  ::close(log);
}

NodeProcess::~NodeProcess() {
  if (pid_ > 0 && ended_.empty()) terminate(1.0);
}

void NodeProcess::reap(int status) {
  status_ = status;
  if (WIFEXITED(status))
    ended_ = fmt::format("exited with status {}", WEXITSTATUS(status));
  else if (WIFSIGNALED(status))
    ended_ = fmt::format("was killed by signal {} ({})", WTERMSIG(status), strsignal(WTERMSIG(status)));
  else
    ended_ = "ended";
}

bool NodeProcess::running() {
  if (!ended_.empty()) return false;
  int status = 0;
  struct rusage usage {};
  const pid_t r = ::wait4(pid_, &status, WNOHANG, &usage);
  if (r == pid_) {
    peak_rss_kib_ = usage.ru_maxrss;  // the largest of the process and its waited-for children
    reap(status);
    return false;
  }
  return true;
}

bool NodeProcess::wait_exit(double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (running() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  return !running() && WIFEXITED(status_) && WEXITSTATUS(status_) == 0;
}

void NodeProcess::terminate(double grace_s) {
  if (!running()) return;
  ::kill(-pid_, SIGTERM);
  if (wait_exit(grace_s) || !running()) return;
  ::kill(-pid_, SIGKILL);
  int status = 0;
  struct rusage usage {};
  if (::wait4(pid_, &status, 0, &usage) == pid_) {
    peak_rss_kib_ = usage.ru_maxrss;
    reap(status);
  }
}

std::string NodeProcess::last_log_line() const {
  std::ifstream in(log_path_);
  std::string line, last;
  while (std::getline(in, line))
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  return last;
}

}  // namespace hemo
