// SPDX-License-Identifier: GPL-3.0-or-later
#include "checkpoint_file.h"

#include "quiet_hdf5.h"

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>

namespace hemo::particles {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  // HDF5 says only that a call failed; a write the disk could not take left ENOSPC in errno.
  throw std::runtime_error("checkpoint file " + path + ": " + what +
                           (errno == ENOSPC ? ": no space left on device" : ""));
}

void write_array(hid_t file, const std::string& path, const std::string& name, hid_t mem_type, hid_t file_type,
                 std::size_t n, const void* data) {
  const QuietHdf5 quiet;
  hsize_t dims[1] = {n};
  const hid_t space = H5Screate_simple(1, dims, nullptr);
  const hid_t set = H5Dcreate2(file, name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const herr_t st = set < 0 ? -1 : n > 0 ? H5Dwrite(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) : 0;
  if (set >= 0) H5Dclose(set);
  H5Sclose(space);
  if (st < 0) fail(path, "cannot write '" + name + "'");
}

template <class T>
std::vector<T> read_array(hid_t file, const std::string& path, const std::string& name, hid_t mem_type) {
  const QuietHdf5 quiet;
  if (H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0) fail(path, "no '" + name + "' (damaged or of another version)");
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  if (set < 0) fail(path, "cannot open '" + name + "'");
  const hid_t space = H5Dget_space(set);
  hsize_t dims[1] = {0};
  const bool one_d = H5Sget_simple_extent_ndims(space) == 1 && H5Sget_simple_extent_dims(space, dims, nullptr) == 1;
  std::vector<T> out(one_d ? static_cast<std::size_t>(dims[0]) : 0);
  const herr_t st = !one_d ? -1 : out.empty() ? 0 : H5Dread(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data());
  H5Sclose(space);
  H5Dclose(set);
  if (st < 0) fail(path, "cannot read '" + name + "' (damaged)");
  return out;
}

template <class T>
T single(const std::vector<T>& values, const std::string& path, const std::string& name) {
  if (values.size() != 1) fail(path, "'" + name + "' holds " + std::to_string(values.size()) + " values, not 1");
  return values[0];
}

}  // namespace

CheckpointWriter::CheckpointWriter(const std::string& path) : path_(path) {
  const QuietHdf5 quiet;
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) fail(path, "cannot create it");
  file_ = f;
}

CheckpointWriter::~CheckpointWriter() {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
}

void CheckpointWriter::put(const std::string& name, const std::vector<double>& values) {
  write_array(static_cast<hid_t>(file_), path_, name, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, values.size(), values.data());
}

void CheckpointWriter::put(const std::string& name, const std::vector<std::int64_t>& values) {
  write_array(static_cast<hid_t>(file_), path_, name, H5T_NATIVE_INT64, H5T_STD_I64LE, values.size(), values.data());
}

void CheckpointWriter::put_bytes(const std::string& name, const std::string& bytes) {
  write_array(static_cast<hid_t>(file_), path_, name, H5T_NATIVE_UCHAR, H5T_STD_U8LE, bytes.size(), bytes.data());
}

void CheckpointWriter::close() {
  const QuietHdf5 quiet;
  const herr_t st = H5Fclose(static_cast<hid_t>(file_));
  file_ = -1;
  if (st < 0) fail(path_, "cannot close it");
  // On disk before the checkpoint is committed (renamed): a machine crash must not leave a
  // complete-looking checkpoint with empty files.
  const int fd = ::open(path_.c_str(), O_RDONLY);
  const bool synced = fd >= 0 && ::fsync(fd) == 0;
  if (fd >= 0) ::close(fd);
  if (!synced) fail(path_, "cannot sync it to disk");
}

CheckpointReader::CheckpointReader(const std::string& path) : path_(path) {
  const QuietHdf5 quiet;
  if (::access(path.c_str(), R_OK) != 0) fail(path, "missing or unreadable");
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) fail(path, "not an HDF5 file (damaged)");
  file_ = f;
}

CheckpointReader::~CheckpointReader() {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
}

bool CheckpointReader::has(const std::string& name) const {
  const QuietHdf5 quiet;
  return H5Lexists(static_cast<hid_t>(file_), name.c_str(), H5P_DEFAULT) > 0;
}

void CheckpointReader::get(const std::string& name, std::vector<double>& out) const {
  out = read_array<double>(static_cast<hid_t>(file_), path_, name, H5T_NATIVE_DOUBLE);
}

void CheckpointReader::get(const std::string& name, std::vector<std::int64_t>& out) const {
  out = read_array<std::int64_t>(static_cast<hid_t>(file_), path_, name, H5T_NATIVE_INT64);
}

std::string CheckpointReader::bytes(const std::string& name) const {
  const auto raw = read_array<unsigned char>(static_cast<hid_t>(file_), path_, name, H5T_NATIVE_UCHAR);
  return std::string(raw.begin(), raw.end());
}

double CheckpointReader::real(const std::string& name) const {
  std::vector<double> v;
  get(name, v);
  return single(v, path_, name);
}

std::int64_t CheckpointReader::integer(const std::string& name) const {
  std::vector<std::int64_t> v;
  get(name, v);
  return single(v, path_, name);
}

}  // namespace hemo::particles
