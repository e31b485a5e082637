// One file of a particle checkpoint: named one-dimensional arrays (double, int64, bytes) in an
// HDF5 file, at full precision, written by one rank and read back whole. What goes in which file
// is the business of the state's owner (particle_node.cpp, engine_state.h); this only stores it
// and says in one line what is missing or damaged.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hemo::particles {

class CheckpointWriter {
 public:
  // Creates (truncates) `path`; throws std::runtime_error naming it.
  explicit CheckpointWriter(const std::string& path);
  ~CheckpointWriter();
  CheckpointWriter(const CheckpointWriter&) = delete;
  CheckpointWriter& operator=(const CheckpointWriter&) = delete;

  void put(const std::string& name, const std::vector<double>& values);
  void put(const std::string& name, const std::vector<std::int64_t>& values);
  void put_bytes(const std::string& name, const std::string& bytes);
  void put(const std::string& name, double value) { put(name, std::vector<double>{value}); }
  void put(const std::string& name, std::int64_t value) { put(name, std::vector<std::int64_t>{value}); }

  // Closes the file and forces it to disk (a checkpoint is committed only after this).
  void close();

 private:
  std::string path_;
  long long file_ = -1;  // hid_t
};

class CheckpointReader {
 public:
  // Opens `path`; throws std::runtime_error with a one-line reason (missing, not HDF5, damaged).
  explicit CheckpointReader(const std::string& path);
  ~CheckpointReader();
  CheckpointReader(const CheckpointReader&) = delete;
  CheckpointReader& operator=(const CheckpointReader&) = delete;

  void get(const std::string& name, std::vector<double>& out) const;
  void get(const std::string& name, std::vector<std::int64_t>& out) const;
  // Whether it holds `name` (a field later builds added).
  bool has(const std::string& name) const;
  std::string bytes(const std::string& name) const;
  double real(const std::string& name) const;           // an array of exactly one value
  std::int64_t integer(const std::string& name) const;  // an array of exactly one value
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  long long file_ = -1;  // hid_t
};

}  // namespace hemo::particles
