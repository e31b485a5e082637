// SPDX-License-Identifier: GPL-3.0-or-later
#include "child_process.h"

#include <fmt/format.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <poll.h>
#include <filesystem>
#include <stdexcept>
#include <sys/wait.h>
#include <unistd.h>

namespace hemo {

std::string ChildResult::describe() const {
  if (signal != 0) return fmt::format("was killed by signal {} ({})", signal, strsignal(signal));
  return fmt::format("exited with status {}", exit_code);
}

std::string executable_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().string();
}

ChildResult run_child(const std::vector<std::string>& argv, const ChildOptions& opt) {
  if (argv.empty()) throw std::runtime_error("run_child: empty command");
  int fds[2] = {-1, -1};
  const bool piped = static_cast<bool>(opt.on_line);
  if (piped && ::pipe(fds) != 0) throw std::runtime_error(fmt::format("cannot create a pipe: {}", std::strerror(errno)));
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(errno)));
  if (pid == 0) {
    if (piped) {
      ::dup2(fds[1], STDOUT_FILENO);
      if (opt.merge_stderr) ::dup2(fds[1], STDERR_FILENO);
      ::close(fds[0]);
      ::close(fds[1]);
    }
    if (opt.quiet) {
      const int null = ::open("/dev/null", O_WRONLY);
      if (null >= 0) {
        ::dup2(null, STDOUT_FILENO);
        ::dup2(null, STDERR_FILENO);
        ::close(null);
      }
    }
    for (const auto& [k, v] : opt.env) ::setenv(k.c_str(), v.c_str(), 1);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execvp(args[0], args.data());
    if (!opt.quiet) std::fprintf(stderr, "cannot execute %s: %s\n", args[0], std::strerror(errno));
    ::_exit(127);
  }
  bool stop_sent = false;
  auto forward_stop = [&]() {
    if (opt.stop_flag && *opt.stop_flag && !stop_sent) {
      ::kill(pid, SIGINT);
      stop_sent = true;
    }
  };
  if (piped) {
    ::close(fds[1]);
    std::string line;
    char buf[4096];
    for (;;) {
      pollfd p{fds[0], POLLIN, 0};
      const int ready = ::poll(&p, 1, 200);
      forward_stop();
      if (ready == 0 || (ready < 0 && errno == EINTR)) continue;
      const ssize_t n = ::read(fds[0], buf, sizeof buf);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      for (ssize_t i = 0; i < n; ++i) {
        if (buf[i] == '\n' || buf[i] == '\r') {
          if (!line.empty()) opt.on_line(line);
          line.clear();
        } else {
          line += buf[i];
        }
      }
    }
    if (!line.empty()) opt.on_line(line);
    ::close(fds[0]);
  }
  int status = 0;
  for (;;) {
    const pid_t r = ::waitpid(pid, &status, opt.stop_flag ? WNOHANG : 0);
    if (r == pid) break;
    if (r < 0 && errno != EINTR) throw std::runtime_error(fmt::format("waiting for {}: {}", argv[0], std::strerror(errno)));
    if (r == 0) {
      forward_stop();
      ::usleep(100 * 1000);
    }
  }
  ChildResult r;
  if (WIFEXITED(status)) {
    r.exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    r.signal = WTERMSIG(status);
    r.exit_code = 128 + r.signal;
  }
  return r;
}

}  // namespace hemo
