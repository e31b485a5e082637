// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_command.h"

#include <sys/wait.h>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

namespace hemo::test {

CommandResult run(const std::string& command) {
  CommandResult r;
  const auto start = std::chrono::steady_clock::now();
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) throw std::runtime_error("cannot run " + command);
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe)) r.output += buf;
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

std::string bin(const std::string& program) { return std::string(HEMO_BIN_DIR) + "/" + program; }

std::string fresh_run_dir(const std::string& name) {
  std::random_device rd;
  auto dir = std::filesystem::temp_directory_path() / ("hemocosim-test-" + std::to_string(rd())) / name;
  std::filesystem::create_directories(dir.parent_path());
  return dir.string();
}

std::vector<double> over_steps(const Metrics& m, const std::string& node, const std::string& name) {
  std::vector<double> v;
  const auto it = m.find({node, name});
  if (it == m.end()) return v;
  for (const auto& [step, value] : it->second)
    if (step > 0) v.push_back(value);
  return v;
}

Metrics read_metrics(const std::string& run_dir) {
  std::ifstream in(run_dir + "/metrics.csv");
  if (!in) throw std::runtime_error("no metrics.csv in " + run_dir);
  Metrics m;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string step, time, node, name, value;
    std::getline(ss, step, ',');
    std::getline(ss, time, ',');
    std::getline(ss, node, ',');
    std::getline(ss, name, ',');
    std::getline(ss, value, ',');
    m[{node, name}][std::stol(step)] = std::stod(value);
  }
  return m;
}

double last(const Metrics& m, const std::string& node, const std::string& name) {
  auto it = m.find({node, name});
  if (it == m.end() || it->second.empty()) throw std::runtime_error("no metric " + node + "/" + name);
  return it->second.rbegin()->second;
}

std::string error_line(const std::string& output) {
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("hemocosim: error:", 0) == 0) return line;
  return {};
}

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace hemo::test
