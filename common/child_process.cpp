// SPDX-License-Identifier: GPL-3.0-or-later
#include "child_process.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace hemo {

namespace {

using Env = std::vector<std::pair<std::string, std::string>>;

// Where the child's stdout and stderr go: descriptors dup'ed onto them (-1: left as they are).
struct Plumbing {
  int out = -1, err = -1;
  int in = -1;
  int close_in_child = -1;  // the read end of a pipe
};

// Closes a descriptor when it goes out of scope.
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

// The one fork/exec. Everything the child needs is built before the fork: the callers may have
// threads (the coordinator's bus), and then only async-signal-safe calls are safe in the child
// until the exec.
pid_t spawn(const std::vector<std::string>& argv, const Env& env, const Plumbing& io, bool own_group,
            bool die_with_parent) {
  if (argv.empty()) throw std::runtime_error("cannot start a program: empty command");
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::vector<std::string> env_text;
  std::vector<char*> envp;
  if (!env.empty()) {
    for (char** e = environ; *e; ++e) {
      const std::string entry(*e);
      const std::string name = entry.substr(0, entry.find('='));
      bool replaced = false;
      for (const auto& kv : env) replaced = replaced || kv.first == name;
      if (!replaced) env_text.push_back(entry);
    }
    for (const auto& [k, v] : env) env_text.push_back(k + "=" + v);
    for (auto& e : env_text) envp.push_back(e.data());
    envp.push_back(nullptr);
  }
  const pid_t parent = ::getpid();
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error(fmt::format("cannot start {}: {}", argv[0], std::strerror(errno)));
  if (pid == 0) {
    if (own_group) ::setpgid(0, 0);
    if (die_with_parent) {
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      // A parent that died before the line above is no longer ours: the signal will not come.
      if (::getppid() != parent) ::_exit(125);
    }
    if (io.in >= 0) ::dup2(io.in, STDIN_FILENO);
    if (io.out >= 0) ::dup2(io.out, STDOUT_FILENO);
    if (io.err >= 0) ::dup2(io.err, STDERR_FILENO);
    if (io.out > STDERR_FILENO) ::close(io.out);
    if (io.err > STDERR_FILENO && io.err != io.out) ::close(io.err);
    if (io.close_in_child >= 0) ::close(io.close_in_child);
    if (envp.empty())
      ::execvp(args[0], args.data());
    else
      ::execvpe(args[0], args.data(), envp.data());
    std::fprintf(stderr, "cannot execute %s: %s\n", args[0], std::strerror(errno));
    ::_exit(127);
  }
  // Also from this side, so that a signal to the group right after the start cannot miss it.
  if (own_group) ::setpgid(pid, pid);
  return pid;
}

}  // namespace

std::string ChildResult::describe() const {
  if (signal != 0) return fmt::format("was killed by signal {} ({})", signal, strsignal(signal));
  return fmt::format("exited with status {}", exit_code);
}

ChildResult child_result(int wait_status) {
  ChildResult r;
  if (WIFEXITED(wait_status)) {
    r.exit_code = WEXITSTATUS(wait_status);
  } else if (WIFSIGNALED(wait_status)) {
    r.signal = WTERMSIG(wait_status);
    r.exit_code = 128 + r.signal;
  }
  return r;
}

std::string executable_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().string();
}

pid_t start_child(const std::vector<std::string>& argv, const StartOptions& opt) {
  Fd log;
  if (!opt.log_path.empty()) {
    log.fd = ::open(opt.log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (log.fd < 0) throw std::runtime_error(fmt::format("cannot open {}: {}", opt.log_path, std::strerror(errno)));
  }
  Plumbing io{log.fd, log.fd, opt.stdin_fd, -1};
  return spawn(argv, opt.env, io, opt.own_process_group, opt.die_with_parent);
}

ChildResult run_child(const std::vector<std::string>& argv, const ChildOptions& opt) {
  if (argv.empty()) throw std::runtime_error("run_child: empty command");
  Fd read_end, write_end, null;
  Plumbing io;
  const bool piped = static_cast<bool>(opt.on_line);
  if (opt.quiet) {
    null.fd = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    io.out = io.err = null.fd;
  } else if (piped) {
    int fds[2] = {-1, -1};
    if (::pipe2(fds, O_CLOEXEC) != 0)
      throw std::runtime_error(fmt::format("cannot create a pipe: {}", std::strerror(errno)));
    read_end.fd = fds[0];
    write_end.fd = fds[1];
    io.out = write_end.fd;
    if (opt.merge_stderr) io.err = write_end.fd;
    io.close_in_child = read_end.fd;
  }
  const pid_t pid = spawn(argv, opt.env, io, false, false);
  // Only the child may hold the write end now, so that the reader sees its end of output.
  if (write_end.fd >= 0) {
    ::close(write_end.fd);
    write_end.fd = -1;
  }
  bool stop_sent = false;
  auto forward_stop = [&]() {
    if (opt.stop_flag && *opt.stop_flag && !stop_sent) {
      ::kill(pid, SIGINT);
      stop_sent = true;
    }
  };
  if (read_end.fd >= 0) {
    const int fd = read_end.fd;
    std::string line;
    char buf[4096];
    for (;;) {
      pollfd p{fd, POLLIN, 0};
      const int ready = ::poll(&p, 1, 200);
      forward_stop();
      if (ready == 0 || (ready < 0 && errno == EINTR)) continue;
      const ssize_t n = ::read(fd, buf, sizeof buf);
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
  }
  int status = 0;
  for (;;) {
    const pid_t r = ::waitpid(pid, &status, opt.stop_flag ? WNOHANG : 0);
    if (r == pid) break;
    if (r < 0 && errno != EINTR)
      throw std::runtime_error(fmt::format("waiting for {}: {}", argv[0], std::strerror(errno)));
    if (r == 0) {
      forward_stop();
      ::usleep(100 * 1000);
    }
  }
  return child_result(status);
}

}  // namespace hemo
