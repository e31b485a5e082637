// SPDX-License-Identifier: GPL-3.0-or-later
#include "h5_output.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

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

// A disk that fills while snapshots are written (a small tmpfs, snapshots of several sizes so that
// it fills at different points of a write): the write that cannot be whole fails naming the full
// disk, and every snapshot the file lists reads back as it was written.
TEST(H5Output, AFullDiskFailsTheWriteAndLeavesEverySnapshotListedReadable) {
  if (::geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root (CI runs as root)";
  const auto dir = std::filesystem::temp_directory_path() / ("hemo_h5_full_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  ASSERT_EQ(std::system(("mount -t tmpfs -o size=6m hemocosim-test " + dir.string()).c_str()), 0);
  struct Unmount {
    std::string at;
    ~Unmount() {
      std::system(("umount -l " + at).c_str());
      std::filesystem::remove_all(at);
    }
  } unmount{dir.string()};
  for (const std::size_t n : {300, 1000, 2500, 4100}) {
    const std::string path = (dir / ("particles-" + std::to_string(n) + ".h5")).string();
    auto snapshot = [n](long step) {
      ParticleSnapshot s;
      s.step = step;
      s.time_s = 1e-4 * static_cast<double>(step);
      for (std::size_t i = 0; i < n; ++i) {
        s.id.push_back(static_cast<std::int64_t>(i));
        s.species.push_back(static_cast<std::int8_t>(i % 2));
        for (int c = 0; c < 3; ++c) s.position.push_back(1e-6 * static_cast<double>(i + c + step));
        for (int c = 0; c < 3; ++c) s.velocity.push_back(1e-3 * static_cast<double>(c) + static_cast<double>(step));
        for (int c = 0; c < 4; ++c) s.orientation.push_back(c == 0 ? 1.0 : 0.0);
      }
      return s;
    };
    std::string error;
    long written = 0;
    {
      H5Output out(path);
      try {
        for (long step = 0;; ++step) out.write(snapshot(step)), written = step + 1;
      } catch (const std::runtime_error& e) {
        error = e.what();
      }
    }
    EXPECT_NE(error.find("no space left on device"), std::string::npos) << n << ": " << error;
    EXPECT_GE(written, 1) << n;
    const auto steps = list_snapshots(path);
    EXPECT_EQ(static_cast<long>(steps.size()), written) << n;
    for (const long step : steps) {
      ParticleSnapshot r;
      ASSERT_NO_THROW(r = read_snapshot(path, step)) << n << " step " << step;
      const auto s = snapshot(step);
      EXPECT_EQ(r.id, s.id) << n << " step " << step;
      EXPECT_EQ(r.position, s.position) << n << " step " << step;
      EXPECT_EQ(r.velocity, s.velocity) << n << " step " << step;
    }
    std::filesystem::remove(path);  // the next size starts on an empty disk
  }
}
