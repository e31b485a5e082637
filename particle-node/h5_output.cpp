// SPDX-License-Identifier: GPL-3.0-or-later
#include "h5_output.h"

#include <hdf5.h>

#include <fcntl.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

namespace hemo::particles {

namespace {

// HDF5 says only that a call failed; a write the disk could not take left ENOSPC in errno.
[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error("particles.h5: " + what + (errno == ENOSPC ? ": no space left on device" : ""));
}

void write_dataset(hid_t group, const char* name, hid_t mem_type, hid_t file_type, std::size_t rows, std::size_t cols,
                   const void* data) {
  hsize_t dims[2] = {rows, cols};
  hid_t space = H5Screate_simple(cols > 1 ? 2 : 1, dims, nullptr);
  hid_t set = H5Dcreate2(group, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (set < 0) {
    H5Sclose(space);
    fail(std::string("cannot create dataset ") + name);
  }
  herr_t st = rows > 0 ? H5Dwrite(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) : 0;
  H5Dclose(set);
  H5Sclose(space);
  if (st < 0) fail(std::string("cannot write dataset ") + name);
}

template <class T>
std::vector<T> read_dataset(hid_t group, const char* name, hid_t mem_type, std::size_t cols) {
  hid_t set = H5Dopen2(group, name, H5P_DEFAULT);
  if (set < 0) fail(std::string("no dataset ") + name);
  hid_t space = H5Dget_space(set);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space, dims, nullptr);
  std::vector<T> out(static_cast<std::size_t>(dims[0]) * cols);
  herr_t st = out.empty() ? 0 : H5Dread(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data());
  H5Sclose(space);
  H5Dclose(set);
  if (st < 0) fail(std::string("cannot read dataset ") + name);
  return out;
}

// HDF5 writes a snapshot's metadata when its cache chooses and in no order: on a disk that fills
// halfway through, the link to a new group can reach the file while the group's header, past the
// end, does not, and the file then lists a snapshot nobody can open. So the blocks a snapshot will
// take are reserved before HDF5 touches the file: a full disk then fails here, with the file as it
// was. FALLOC_FL_KEEP_SIZE leaves the file's size alone (HDF5 checks it against its end of
// allocation). New objects go at the end of the allocation, so the reserve starts there and holds
// the data twice over plus a mebibyte for headers and the name index growing (it doubles).
void reserve_space(hid_t file, const std::string& path, std::size_t data_bytes) {
  void* handle = nullptr;
  if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 || handle == nullptr) return;  // not a POSIX file
  hsize_t end = 0;
  if (H5Fget_filesize(file, &end) < 0) fail("cannot read the size of " + path);
  const off_t length = static_cast<off_t>(2 * data_bytes + (std::size_t{1} << 20));
  errno = 0;
  if (::fallocate(*static_cast<int*>(handle), FALLOC_FL_KEEP_SIZE, static_cast<off_t>(end), length) == 0) return;
  if (errno == EOPNOTSUPP || errno == ENOSYS) return;  // a file system that cannot reserve: write and hope
  fail("cannot reserve " + std::to_string(length) + " bytes for the next snapshot");
}

}  // namespace

std::string snapshot_name(long step) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%08ld", step);
  return buf;
}

H5Output::H5Output(const std::string& path) : path_(path) {
  hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) fail("cannot create " + path);
  hid_t g = H5Gcreate2(f, "snapshots", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (g < 0) {
    H5Fclose(f);
    fail("cannot create /snapshots in " + path);
  }
  file_ = f;
  snapshots_ = g;
}

std::unique_ptr<H5Output> H5Output::resume(const std::string& path, long last_step, std::vector<long>* dropped) {
  if (!std::filesystem::exists(path)) return std::make_unique<H5Output>(path);
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (f < 0) fail("cannot open " + path + " to go on with it");
  const bool has_group = H5Lexists(f, "snapshots", H5P_DEFAULT) > 0;
  const hid_t g = has_group ? H5Gopen2(f, "snapshots", H5P_DEFAULT)
                            : H5Gcreate2(f, "snapshots", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (g < 0) {
    H5Fclose(f);
    fail("cannot open /snapshots in " + path);
  }
  std::unique_ptr<H5Output> out(new H5Output(path, f, g));
  std::vector<long> later;
  H5G_info_t info;
  H5Gget_info(g, &info);
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char name[64] = {0};
    H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, i, name, sizeof name, H5P_DEFAULT);
    if (std::stol(name) > last_step) later.push_back(std::stol(name));
  }
  for (const long step : later)
    if (H5Ldelete(g, snapshot_name(step).c_str(), H5P_DEFAULT) < 0)
      fail("cannot remove snapshot " + snapshot_name(step) + " from " + path);
  if (H5Fflush(f, H5F_SCOPE_GLOBAL) < 0) fail("cannot flush " + path);
  if (dropped) *dropped = later;
  return out;
}

H5Output::~H5Output() {
  if (snapshots_ >= 0) H5Gclose(static_cast<hid_t>(snapshots_));
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
}

bool H5Output::write(const ParticleSnapshot& s) {
  const std::size_t n = s.id.size();
  if (s.species.size() != n || s.position.size() != 3 * n || s.velocity.size() != 3 * n ||
      s.orientation.size() != 4 * n)
    fail("snapshot arrays of step " + std::to_string(s.step) + " have inconsistent sizes");
  const std::string name = snapshot_name(s.step);
  const hid_t parent = static_cast<hid_t>(snapshots_);
  if (H5Lexists(parent, name.c_str(), H5P_DEFAULT) > 0) return false;
  reserve_space(static_cast<hid_t>(file_), path_,
                n * (sizeof(std::int64_t) + sizeof(std::int8_t) + (3 + 3 + 4) * sizeof(double)));
  // The snapshot is built in a group with no name and linked under its name only when whole: a
  // write the disk cuts short (ENOSPC) leaves no half snapshot for a reader or a resume to find.
  hid_t g = H5Gcreate_anon(parent, H5P_DEFAULT, H5P_DEFAULT);
  if (g < 0) fail("cannot create group " + name);
  try {
    hid_t scalar = H5Screate(H5S_SCALAR);
    hid_t attr = H5Acreate2(g, "time_s", H5T_IEEE_F64LE, scalar, H5P_DEFAULT, H5P_DEFAULT);
    const herr_t written = attr >= 0 ? H5Awrite(attr, H5T_NATIVE_DOUBLE, &s.time_s) : -1;
    if (attr >= 0) H5Aclose(attr);
    H5Sclose(scalar);
    if (written < 0) fail("cannot write the time of " + name);
    write_dataset(g, "id", H5T_NATIVE_INT64, H5T_STD_I64LE, n, 1, s.id.data());
    write_dataset(g, "species", H5T_NATIVE_INT8, H5T_STD_I8LE, n, 1, s.species.data());
    write_dataset(g, "position", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, n, 3, s.position.data());
    write_dataset(g, "velocity", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, n, 3, s.velocity.data());
    write_dataset(g, "orientation", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, n, 4, s.orientation.data());
  } catch (...) {
    H5Gclose(g);
    throw;
  }
  const herr_t linked = H5Olink(g, parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
  H5Gclose(g);
  if (linked < 0) fail("cannot link group " + name);
  if (H5Fflush(static_cast<hid_t>(file_), H5F_SCOPE_GLOBAL) < 0) fail("cannot flush " + path_);
  return true;
}

std::vector<long> list_snapshots(const std::string& path) {
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) fail("cannot open " + path);
  hid_t g = H5Lexists(f, "snapshots", H5P_DEFAULT) > 0 ? H5Gopen2(f, "snapshots", H5P_DEFAULT) : -1;
  std::vector<long> steps;
  if (g >= 0) {
    H5G_info_t info;
    H5Gget_info(g, &info);
    for (hsize_t i = 0; i < info.nlinks; ++i) {
      char name[64] = {0};
      H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, i, name, sizeof name, H5P_DEFAULT);
      steps.push_back(std::stol(name));
    }
    H5Gclose(g);
  }
  H5Fclose(f);
  std::sort(steps.begin(), steps.end());
  return steps;
}

ParticleSnapshot read_snapshot(const std::string& path, long step) {
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) fail("cannot open " + path);
  const std::string name = "snapshots/" + snapshot_name(step);
  const bool exists = H5Lexists(f, "snapshots", H5P_DEFAULT) > 0 && H5Lexists(f, name.c_str(), H5P_DEFAULT) > 0;
  hid_t g = exists ? H5Gopen2(f, name.c_str(), H5P_DEFAULT) : -1;
  if (g < 0) {
    H5Fclose(f);
    fail("no snapshot " + name + " in " + path);
  }
  ParticleSnapshot s;
  s.step = step;
  hid_t attr = H5Aopen(g, "time_s", H5P_DEFAULT);
  H5Aread(attr, H5T_NATIVE_DOUBLE, &s.time_s);
  H5Aclose(attr);
  s.id = read_dataset<std::int64_t>(g, "id", H5T_NATIVE_INT64, 1);
  s.species = read_dataset<std::int8_t>(g, "species", H5T_NATIVE_INT8, 1);
  s.position = read_dataset<double>(g, "position", H5T_NATIVE_DOUBLE, 3);
  s.velocity = read_dataset<double>(g, "velocity", H5T_NATIVE_DOUBLE, 3);
  if (H5Lexists(g, "orientation", H5P_DEFAULT) > 0)
    s.orientation = read_dataset<double>(g, "orientation", H5T_NATIVE_DOUBLE, 4);
  H5Gclose(g);
  H5Fclose(f);
  return s;
}

}  // namespace hemo::particles
