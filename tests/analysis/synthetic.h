// Synthetic particle data with known answers for the analysis tests.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "observables.h"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>

#include <unistd.h>

namespace hemo::analysis::test {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kUm = 1e-6;

// Appends one particle at cylindrical (r, theta, z) moving axially at vz.
inline void add_particle(Snapshot& s, std::int64_t id, std::int8_t species, double r, double theta, double z,
                         double vz = 0) {
  s.id.push_back(id);
  s.species.push_back(species);
  s.position.insert(s.position.end(), {r * std::cos(theta), r * std::sin(theta), z});
  s.velocity.insert(s.velocity.end(), {0.0, 0.0, vz});
}

// A fresh, empty directory under the system temp dir, unique per process and name, removed
// when the test ends.
class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() / ("hemo-analysis-" + std::to_string(::getpid()) + "-" + name)) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string str() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace hemo::analysis::test
