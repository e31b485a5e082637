// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_command.h"

#include <run_files.h>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

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

namespace {

namespace fs = std::filesystem;

// What a shared run is of, in one text: its SHA-256 names the run (shared_run).
std::string shared_run_manifest(const std::string& scene_text, const std::string& options) {
  std::ostringstream m;
  m << "hemocosim run SCENE --out RUN" << options << "\n";
  // Each process hashes the build's programs once (a few tens of ms).
  static const std::string programs = [] {
    std::vector<fs::path> found;
    for (const auto& e : fs::directory_iterator(HEMO_BIN_DIR))
      if (e.is_regular_file() && e.path().filename().string().rfind("hemocosim", 0) == 0) found.push_back(e.path());
    std::sort(found.begin(), found.end());
    std::string out;
    for (const auto& p : found) out += hemo::sha256_file(p.string()) + "  " + p.filename().string() + "\n";
    struct stat st{};
    if (::stat("/var/lib/dpkg/status", &st) == 0)
      out += "dpkg status: " + std::to_string(st.st_size) + " B, modified " + std::to_string(st.st_mtim.tv_sec) + "." +
             std::to_string(st.st_mtim.tv_nsec) + "\n";
    return out;
  }();
  m << programs << "scene:\n" << scene_text;
  return m.str();
}

}  // namespace

SharedRun shared_run(const std::string& scene_text, const std::string& options) {
  const std::string manifest = shared_run_manifest(scene_text, options);
  const fs::path cache(HEMO_SHARED_RUNS_DIR);
  fs::create_directories(cache);
  const std::string key = hemo::sha256_text(manifest).substr(0, 32);
  // A maker's own directory: a run whose test was killed may go on writing into its own.
  const fs::path entry = cache / key,
                 making = cache / ("." + key + ".making-" + std::to_string(::getpid()) + "-" +
                                   std::to_string(std::random_device{}()));
  SharedRun r{(entry / "run").string(), (entry / "scene.toml").string(), {}};

  // One maker at a time (a test binary run by hand beside ctest): the others wait and take its run.
  struct Lock {
    int fd;
    ~Lock() { ::close(fd); }  // releases the flock
  } lock{::open((cache / ".lock").c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644)};
  if (lock.fd < 0 || ::flock(lock.fd, LOCK_EX) != 0) throw std::runtime_error("cannot lock " + cache.string());

  // An entry appears whole (by the rename below); its manifest compared in full, not only by
  // its hash's prefix, leaves nothing to a collision.
  if (file_text((entry / "manifest").string()) == manifest) {
    r.result.exit_code = 0;
    r.result.output = file_text((entry / "output").string());
    r.result.seconds = std::stod(file_text((entry / "seconds").string()));
    return r;
  }
  fs::remove_all(entry);
  fs::create_directories(making);
  std::ofstream(making / "scene.toml") << scene_text;
  r.result = run(bin("hemocosim") + " run " + (making / "scene.toml").string() + " --out " +
                 (making / "run").string() + options);
  if (r.result.exit_code != 0) {
    r.dir = (making / "run").string();
    r.scene = (making / "scene.toml").string();
    return r;
  }
  for (const auto& [file, text] : {std::pair<std::string, std::string>{"output", r.result.output},
                                   {"seconds", std::to_string(r.result.seconds)},
                                   {"manifest", manifest}}) {
    std::ofstream out(making / file);
    if (!(out << text).flush()) throw std::runtime_error("cannot write " + (making / file).string());
  }
  fs::rename(making, entry);
  return r;
}

}  // namespace hemo::test
