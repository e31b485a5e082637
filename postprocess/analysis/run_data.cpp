// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_data.h"

#include "quiet_hdf5.h"

#include <hdf5.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace hemo::analysis {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw RunDataError(path + ": " + what); }

// Closes an HDF5 handle on scope exit.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

Handle open_file(const std::string& path) {
  if (!std::filesystem::exists(path)) fail(path, "missing");
  if (H5Fis_hdf5(path.c_str()) <= 0) fail(path, "not an HDF5 file (corrupt or truncated?)");
  Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.ok()) fail(path, "cannot open (corrupt?)");
  return f;
}

double read_time_attribute(hid_t group, const std::string& where) {
  if (H5Aexists(group, "time_s") <= 0) fail(where, "no attribute time_s");
  Handle attr(H5Aopen(group, "time_s", H5P_DEFAULT), H5Aclose);
  double t = 0;
  if (!attr.ok() || H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &t) < 0) fail(where, "cannot read attribute time_s");
  return t;
}

// Reads a dataset of `rows` x `cols` (rows < 0: any), converting to the memory type.
template <class T>
std::vector<T> read_dataset(hid_t group, const char* name, hid_t mem_type, long rows, int cols,
                            const std::string& where) {
  if (H5Lexists(group, name, H5P_DEFAULT) <= 0) fail(where, std::string("no dataset '") + name + "'");
  Handle set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!set.ok()) fail(where, std::string("cannot open dataset '") + name + "'");
  Handle space(H5Dget_space(set.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  hsize_t dims[2] = {0, 1};
  if (rank < 1 || rank > 2) fail(where, std::string("dataset '") + name + "' has rank " + std::to_string(rank));
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  const hsize_t got_cols = rank == 2 ? dims[1] : 1;
  if (got_cols != static_cast<hsize_t>(cols) || (rows >= 0 && dims[0] != static_cast<hsize_t>(rows)))
    fail(where, std::string("dataset '") + name + "' has shape " + std::to_string(dims[0]) + "x" +
                    std::to_string(got_cols) + ", expected " + (rows >= 0 ? std::to_string(rows) : "N") + "x" +
                    std::to_string(cols));
  std::vector<T> out(static_cast<std::size_t>(dims[0]) * cols);
  if (!out.empty() && H5Dread(set.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    fail(where, std::string("cannot read dataset '") + name + "'");
  return out;
}

// Parses a whole field as a number; false on trailing junk or an empty field.
bool parse_double(const std::string& s, double& v) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  v = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && errno != ERANGE;
}

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    fields.emplace_back(line, start, comma == std::string::npos ? std::string::npos : comma - start);
    if (comma == std::string::npos) return fields;
    start = comma + 1;
  }
}

}  // namespace

std::vector<SnapshotInfo> list_snapshots(const std::string& path) {
  QuietHdf5 quiet;
  Handle f = open_file(path);
  if (H5Lexists(f.get(), "snapshots", H5P_DEFAULT) <= 0) fail(path, "no group /snapshots");
  Handle g(H5Gopen2(f.get(), "snapshots", H5P_DEFAULT), H5Gclose);
  if (!g.ok()) fail(path, "cannot open /snapshots");
  H5G_info_t info;
  if (H5Gget_info(g.get(), &info) < 0) fail(path, "cannot list /snapshots");
  std::vector<SnapshotInfo> out;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char name[64] = {0};
    H5Lget_name_by_idx(g.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, name, sizeof name, H5P_DEFAULT);
    const std::string where = path + " /snapshots/" + name;
    char* end = nullptr;
    const long step = std::strtol(name, &end, 10);
    if (end == name || *end != '\0') throw RunDataError(where + ": not a step number");
    Handle s(H5Gopen2(g.get(), name, H5P_DEFAULT), H5Gclose);
    if (!s.ok()) throw RunDataError(where + ": not a group");
    out.push_back({step, read_time_attribute(s.get(), where)});
  }
  std::sort(out.begin(), out.end(), [](const SnapshotInfo& a, const SnapshotInfo& b) { return a.step < b.step; });
  return out;
}

Snapshot read_snapshot(const std::string& path, long step) {
  QuietHdf5 quiet;
  Handle f = open_file(path);
  char name[32];
  std::snprintf(name, sizeof name, "snapshots/%08ld", step);
  const std::string where = path + " /" + name;
  if (H5Lexists(f.get(), "snapshots", H5P_DEFAULT) <= 0 || H5Lexists(f.get(), name, H5P_DEFAULT) <= 0)
    throw RunDataError(where + ": missing");
  Handle g(H5Gopen2(f.get(), name, H5P_DEFAULT), H5Gclose);
  if (!g.ok()) throw RunDataError(where + ": not a group");
  Snapshot s;
  s.step = step;
  s.time_s = read_time_attribute(g.get(), where);
  s.id = read_dataset<std::int64_t>(g.get(), "id", H5T_NATIVE_INT64, -1, 1, where);
  const long n = static_cast<long>(s.id.size());
  s.species = read_dataset<std::int8_t>(g.get(), "species", H5T_NATIVE_INT8, n, 1, where);
  s.position = read_dataset<double>(g.get(), "position", H5T_NATIVE_DOUBLE, n, 3, where);
  s.velocity = read_dataset<double>(g.get(), "velocity", H5T_NATIVE_DOUBLE, n, 3, where);
  return s;
}

namespace {
// Calls `row` with every sample of metrics.csv, in file order; refuses the first bad line.
template <class Row>
void for_each_metric(const std::string& path, Row&& row) {
  std::ifstream in(path);
  if (!in) fail(path, std::filesystem::exists(path) ? "cannot read" : "missing");
  std::string line;
  if (!std::getline(in, line)) fail(path, "empty (expected header step,time_s,node,name,value)");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != "step,time_s,node,name,value")
    fail(path + ":1", "header is '" + line + "', expected step,time_s,node,name,value");
  for (long lineno = 2; std::getline(in, line); ++lineno) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const auto f = split_csv_line(line);
    const std::string where = path + ":" + std::to_string(lineno);
    if (f.size() != 5) fail(where, "expected 5 fields, found " + std::to_string(f.size()));
    MetricSample m;
    double step = 0;
    if (!parse_double(f[0], step) || step != std::floor(step)) fail(where, "step '" + f[0] + "' is not an integer");
    if (!parse_double(f[1], m.time_s)) fail(where, "time_s '" + f[1] + "' is not a number");
    if (!parse_double(f[4], m.value)) fail(where, "value '" + f[4] + "' is not a number");
    m.step = static_cast<long>(step);
    m.node = f[2];
    m.name = f[3];
    row(std::move(m));
  }
}
}  // namespace

std::vector<MetricSample> read_metrics(const std::string& path) {
  std::vector<MetricSample> out;
  for_each_metric(path, [&out](MetricSample&& m) { out.push_back(std::move(m)); });
  return out;
}

MetricSeries read_metric_series(const std::string& path, const std::string& name) {
  MetricSeries s;
  for_each_metric(path, [&](MetricSample&& m) {
    if (m.name != name) return;
    s.time_s.push_back(m.time_s);
    s.value.push_back(m.value);
  });
  return s;
}

MetricSeries metric_series(const std::vector<MetricSample>& metrics, const std::string& name) {
  MetricSeries s;
  for (const auto& m : metrics)
    if (m.name == name) {
      s.time_s.push_back(m.time_s);
      s.value.push_back(m.value);
    }
  return s;
}

RunData open_run(const std::string& dir) {
  if (!std::filesystem::is_directory(dir)) throw RunDataError(dir + ": not a run directory");
  RunData run;
  run.dir = dir;
  const std::string scene_path = dir + "/scene.toml";
  if (!std::filesystem::exists(scene_path)) fail(scene_path, "missing");
  try {
    run.scene = load_scene(scene_path);
  } catch (const SceneError& e) {
    std::string msg;
    for (const auto& p : e.problems()) msg += (msg.empty() ? "" : "; ") + p.str(scene_path);
    throw RunDataError("invalid scene: " + msg);
  }
  run.metrics = read_metrics(dir + "/metrics.csv");
  run.particles_path = dir + "/particles.h5";
  run.snapshots = list_snapshots(run.particles_path);
  return run;
}

}  // namespace hemo::analysis
