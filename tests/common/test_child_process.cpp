// The child-process helper (common/child_process.h) on /bin/sh: what the coordinator's nodes
// rely on (log file, own process group, death with the parent) and what plot and study rely on
// (lines of output, environment, exit status).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "child_process.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

using namespace hemo;
namespace fs = std::filesystem;

namespace {

std::string temp_log(const std::string& tag) {
  const auto p = fs::temp_directory_path() / ("hemo-child-" + tag + "-" + std::to_string(::getpid()) + ".log");
  fs::remove(p);
  return p.string();
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int wait_for(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

// True once /proc/<pid> is gone or a zombie (an orphan is reaped by whoever adopted it).
bool ends_within(pid_t pid, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < deadline) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!std::getline(stat, line)) return true;
    const auto close = line.rfind(')');
    if (close != std::string::npos && close + 2 < line.size() && line[close + 2] == 'Z') return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

}  // namespace

TEST(ChildProcess, StartedChildWritesStdoutAndStderrToItsLog) {
  const std::string log = temp_log("log");
  { std::ofstream(log) << "before\n"; }
  StartOptions opt;
  opt.log_path = log;
  const pid_t pid = start_child({"/bin/sh", "-c", "echo to-stdout; echo to-stderr >&2; exit 3"}, opt);
  const ChildResult r = child_result(wait_for(pid));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.signal, 0);
  EXPECT_EQ(r.describe(), "exited with status 3");
  // Appended, not truncated: a restarted node's log keeps what came before.
  EXPECT_EQ(read_text(log), "before\nto-stdout\nto-stderr\n");
  fs::remove(log);
}

TEST(ChildProcess, ALogThatCannotBeOpenedThrowsBeforeAnythingStarts) {
  StartOptions opt;
  opt.log_path = "/nonexistent-dir/x.log";
  try {
    start_child({"/bin/true"}, opt);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open /nonexistent-dir/x.log"), std::string::npos) << e.what();
  }
}

TEST(ChildProcess, AProgramThatCannotBeExecutedExitsWith127AndSaysSo) {
  const std::string log = temp_log("noexec");
  StartOptions opt;
  opt.log_path = log;
  const pid_t pid = start_child({"/nonexistent/program", "--x"}, opt);
  EXPECT_EQ(child_result(wait_for(pid)).exit_code, 127);
  EXPECT_NE(read_text(log).find("cannot execute /nonexistent/program"), std::string::npos) << read_text(log);
  fs::remove(log);
}

TEST(ChildProcess, OwnProcessGroupTakesItsChildrenAlongOnAGroupSignal) {
  const std::string log = temp_log("group");
  StartOptions opt;
  opt.log_path = log;
  opt.own_process_group = true;
  // The shell starts a grandchild and prints its pid, as mpirun starts ranks.
  const pid_t pid = start_child({"/bin/sh", "-c", "sleep 60 & echo $!; wait"}, opt);
  EXPECT_EQ(::getpgid(pid), pid);
  pid_t grandchild = 0;
  for (int i = 0; i < 250 && grandchild == 0; ++i) {
    std::istringstream(read_text(log)) >> grandchild;
    if (grandchild == 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_GT(grandchild, 0);
  EXPECT_EQ(::getpgid(grandchild), pid);
  ASSERT_EQ(::kill(-pid, SIGTERM), 0);
  const ChildResult r = child_result(wait_for(pid));
  EXPECT_EQ(r.signal, SIGTERM);
  EXPECT_EQ(r.describe().rfind("was killed by signal 15 (", 0), 0u) << r.describe();
  EXPECT_TRUE(ends_within(grandchild, 5));
  fs::remove(log);
}

TEST(ChildProcess, DieWithParentEndsTheChildWhenItsParentIsKilled) {
  // A stand-in coordinator: it starts a long child, reports its pid, and is then SIGKILLed,
  // which leaves it no chance to clean up.
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t coordinator = ::fork();
  ASSERT_GE(coordinator, 0);
  if (coordinator == 0) {
    ::close(fds[0]);
    StartOptions opt;
    opt.die_with_parent = true;
    opt.own_process_group = true;
    const pid_t node = start_child({"/bin/sh", "-c", "exec sleep 60"}, opt);
    (void)!::write(fds[1], &node, sizeof node);
    ::pause();
    ::_exit(0);
  }
  ::close(fds[1]);
  pid_t node = 0;
  ASSERT_EQ(::read(fds[0], &node, sizeof node), static_cast<ssize_t>(sizeof node));
  ::close(fds[0]);
  ASSERT_GT(node, 0);
  // Until the coordinator dies, the node runs.
  EXPECT_FALSE(ends_within(node, 0.3));
  ::kill(coordinator, SIGKILL);
  wait_for(coordinator);
  EXPECT_TRUE(ends_within(node, 5)) << "node " << node << " outlived its parent";
  ::kill(node, SIGKILL);  // in case it did not end (a failed expectation above)
}

TEST(ChildProcess, RunChildPassesLinesEnvironmentAndStatus) {
  std::vector<std::string> lines;
  ChildOptions opt;
  opt.env = {{"HEMO_CHILD_TEST", "from the parent"}, {"HOME", "/elsewhere"}};
  opt.merge_stderr = true;
  opt.on_line = [&lines](const std::string& l) { lines.push_back(l); };
  const ChildResult r =
      run_child({"sh", "-c", "echo \"$HEMO_CHILD_TEST\"; echo \"$HOME\" >&2; printf 'a\\r\\nlast'; exit 4"}, opt);
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_EQ(lines, (std::vector<std::string>{"from the parent", "/elsewhere", "a", "last"}));
  EXPECT_EQ(::getenv("HEMO_CHILD_TEST"), nullptr);  // set in the child only
}

TEST(ChildProcess, RunChildReportsTheSignalThatEndedIt) {
  ChildOptions opt;
  opt.quiet = true;
  const ChildResult r = run_child({"/bin/sh", "-c", "kill -KILL $$"}, opt);
  EXPECT_EQ(r.signal, SIGKILL);
  EXPECT_EQ(r.exit_code, 128 + SIGKILL);
  EXPECT_FALSE(r.ok());
}
