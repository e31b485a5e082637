// SPDX-License-Identifier: GPL-3.0-or-later
#include "h5_output.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

using namespace hemo::particles;

TEST(H5Output, WritesAndReadsBackSnapshots) {
  const auto dir = std::filesystem::temp_directory_path() / ("hemo_h5_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "particles.h5").string();
  ParticleSnapshot s;
  s.step = 42;
  s.time_s = 4.2e-4;
  s.id = {1, 2, 3};
  s.species = {0, 1, 0};
  s.position = {1e-6, 2e-6, 3e-6, 4e-6, 5e-6, -6e-6, 7e-6, 8e-6, 1.2e-3};
  s.velocity = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9};
  s.orientation = {1, 0, 0, 0, 0.5, 0.5, 0.5, 0.5, 1, 0, 0, 0};
  {
    H5Output out(path);
    ParticleSnapshot first = s;
    first.step = 0;
    first.time_s = 0;
    EXPECT_TRUE(out.write(first));
    EXPECT_TRUE(out.write(s));
    EXPECT_FALSE(out.write(s));  // same step twice: kept once
    // Flushed: readable while the writer is still open.
    EXPECT_EQ(list_snapshots(path), (std::vector<long>{0, 42}));
  }
  EXPECT_EQ(snapshot_name(42), "00000042");
  const auto r = read_snapshot(path, 42);
  EXPECT_EQ(r.time_s, s.time_s);
  EXPECT_EQ(r.id, s.id);
  EXPECT_EQ(r.species, s.species);
  EXPECT_EQ(r.position, s.position);
  EXPECT_EQ(r.velocity, s.velocity);
  EXPECT_EQ(r.orientation, s.orientation);
  EXPECT_THROW(read_snapshot(path, 7), std::runtime_error);
  std::filesystem::remove_all(dir);
}
