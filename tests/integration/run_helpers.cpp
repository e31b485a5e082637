// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_helpers.h"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <sys/wait.h>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace hemo::test {

std::string scene(const std::string& name) { return std::string(HEMO_TEST_SCENES) + "/" + name; }

std::string small_scene_text(long coupling_steps, const std::string& run_keys, const std::string& more) {
  std::string s = file_text(scene("coupled_small.toml"));
  const std::string steps = "coupling_steps = 40";
  if (s.find(steps) == std::string::npos || s.find("[run]") == std::string::npos)
    throw std::runtime_error("coupled_small.toml lost its [run] table or its 40 coupling steps");
  s.replace(s.find(steps), steps.size(), "coupling_steps = " + std::to_string(coupling_steps));
  s.replace(s.find("[run]"), 5, "[run]\n" + run_keys);
  return s + "\n" + more;
}

bool wait_until_stepping(const std::string& dir, double timeout_s) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < until) {
    std::ifstream m(dir + "/metrics.csv");
    int lines = 0;
    for (std::string line; std::getline(m, line) && lines <= 100;) ++lines;
    if (lines > 100) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}

Background::Background(const std::string& command, const std::string& files)
    : out(files + ".out"), err(files + ".err") {
  const std::string pid_file = files + ".pid", script = files + ".sh";
  std::ofstream(script) << "echo $$ > " << pid_file << "\nexec " << command << " > " << out << " 2> " << err << "\n";
  done = std::async(std::launch::async, [=] { return run("sh " + script); });
  for (int i = 0; i < 100 && pid == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::ifstream(pid_file) >> pid;
  }
}

void Background::signal(int sig) const {
  if (pid > 0) kill(static_cast<pid_t>(pid), sig);
}

Background::~Background() {
  if (!done.valid()) return;
  signal(SIGINT);
  done.wait();
}

std::vector<std::string> snapshot_names(const std::string& h5_path) {
  std::vector<std::string> names;
  const hid_t f = H5Fopen(h5_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) throw std::runtime_error("cannot open " + h5_path);
  const hid_t g = H5Gopen2(f, "/snapshots", H5P_DEFAULT);
  hsize_t n = 0;
  H5Gget_num_objs(g, &n);
  for (hsize_t i = 0; i < n; ++i) {
    char name[256];
    H5Gget_objname_by_idx(g, i, name, sizeof name);
    names.emplace_back(name);
  }
  H5Gclose(g);
  H5Fclose(f);
  return names;
}

namespace {
template <class T>
std::vector<T> read_dataset(hid_t group, const char* name, hid_t mem_type, std::size_t per_row) {
  const hid_t ds = H5Dopen2(group, name, H5P_DEFAULT);
  if (ds < 0) throw std::runtime_error(std::string("snapshot lacks dataset ") + name);
  const hid_t space = H5Dget_space(ds);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space, dims, nullptr);
  std::vector<T> data(dims[0] * per_row);
  if (!data.empty()) H5Dread(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data());
  H5Sclose(space);
  H5Dclose(ds);
  return data;
}
}  // namespace

Snapshot read_snapshot(const std::string& h5_path, const std::string& name) {
  Snapshot s;
  const hid_t f = H5Fopen(h5_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) throw std::runtime_error("cannot open " + h5_path);
  const hid_t g = H5Gopen2(f, ("/snapshots/" + name).c_str(), H5P_DEFAULT);
  const hid_t a = H5Aopen(g, "time_s", H5P_DEFAULT);
  H5Aread(a, H5T_NATIVE_DOUBLE, &s.time_s);
  H5Aclose(a);
  s.id = read_dataset<long long>(g, "id", H5T_NATIVE_LLONG, 1);
  s.species = read_dataset<signed char>(g, "species", H5T_NATIVE_SCHAR, 1);
  s.position = read_dataset<double>(g, "position", H5T_NATIVE_DOUBLE, 3);
  s.velocity = read_dataset<double>(g, "velocity", H5T_NATIVE_DOUBLE, 3);
  if (H5Lexists(g, "orientation", H5P_DEFAULT) > 0)
    s.orientation = read_dataset<double>(g, "orientation", H5T_NATIVE_DOUBLE, 4);
  H5Gclose(g);
  H5Fclose(f);
  return s;
}

long step_after(const std::string& text, const std::string& marker) {
  const auto at = text.find(marker);
  if (at == std::string::npos) return -1;
  return std::stol(text.substr(at + marker.size()));
}

void wait_for_step(const std::string& dir, long step) {
  const std::string marker = std::to_string(step) + ",";
  for (int i = 0; i < 600; ++i) {
    std::ifstream in(dir + "/metrics.csv");
    for (std::string line; std::getline(in, line);)
      if (line.rfind(marker, 0) == 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

void expect_same_snapshots(const std::string& a_dir, const std::string& b_dir) {
  const auto names = snapshot_names(a_dir + "/particles.h5");
  ASSERT_EQ(names, snapshot_names(b_dir + "/particles.h5"));
  for (const auto& name : names) {
    const auto a = read_snapshot(a_dir + "/particles.h5", name), b = read_snapshot(b_dir + "/particles.h5", name);
    ASSERT_EQ(a.id, b.id) << name;
    EXPECT_EQ(a.time_s, b.time_s) << name;
    EXPECT_EQ(a.position, b.position) << name;  // bit for bit
    EXPECT_EQ(a.velocity, b.velocity) << name;
  }
}

}  // namespace hemo::test
