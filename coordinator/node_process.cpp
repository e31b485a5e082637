// SPDX-License-Identifier: GPL-3.0-or-later
#include "node_process.h"

#include "child_process.h"

#include <fmt/format.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <chrono>
#include <csignal>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace hemo {

NodeProcess::NodeProcess(std::string name, std::vector<std::string> argv, std::string log_path, int stdin_fd)
    : name_(std::move(name)), log_path_(std::move(log_path)) {
  if (argv.empty()) throw std::runtime_error(name_ + " node: empty command");
  StartOptions opt;
  opt.log_path = log_path_;
  opt.own_process_group = true;  // terminate() signals the group: mpirun's ranks go with the node
  // A coordinator killed with SIGKILL cannot terminate() its nodes: they end with it instead.
  opt.die_with_parent = true;
  opt.stdin_fd = stdin_fd;
  pid_ = start_child(argv, opt);
}

NodeProcess::~NodeProcess() {
  if (pid_ > 0 && ended_.empty()) terminate(1.0);
}

void NodeProcess::reap(int status) {
  status_ = status;
  ended_ = WIFEXITED(status) || WIFSIGNALED(status) ? child_result(status).describe() : "ended";
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

std::string last_said_line(const std::string& log_text) {
  std::istringstream in(log_text);
  std::string line, last, notice_first;
  bool in_notice = false, notice_started = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    if (line.size() >= 20 && line.find_first_not_of('-') == std::string::npos) {  // a notice's frame
      in_notice = !in_notice;
      notice_started = in_notice;
      continue;
    }
    if (in_notice) {
      if (notice_started) notice_first = line, notice_started = false;
      continue;
    }
    // "[vm:05754] 1 more process has sent help message ...": Open MPI's, not the node's.
    static const std::regex open_mpi_note(R"(^\[[^\]\s:]+:[0-9]+\] )");
    if (std::regex_search(line, open_mpi_note)) continue;
    last = line;
  }
  return last.empty() ? notice_first : last;
}

std::string NodeProcess::last_log_line() const {
  std::ifstream in(log_path_);
  std::stringstream text;
  text << in.rdbuf();
  return last_said_line(text.str());
}

}  // namespace hemo
