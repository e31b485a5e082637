// The smallest valid scene: the paper's vessel and wall shear rate, every other key at its
// default. Tests append the tables they are about, and write_temp writes the text to a file.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

namespace hemo::test {

inline constexpr const char* kMinimalScene = R"(
[vessel]
diameter_um = 100
length_um = 600

[driving]
wall_shear_rate_per_s = 799
)";

// `text` in a new file under /tmp whose name ends in `suffix`; returns its path.
inline std::string write_temp(const std::string& text, const std::string& suffix = ".toml") {
  char name[] = "/tmp/hemo_test_XXXXXX";
  const int fd = mkstemp(name);
  close(fd);
  std::string path = std::string(name) + suffix;
  std::rename(name, path.c_str());
  std::ofstream(path) << text;
  return path;
}

}  // namespace hemo::test
