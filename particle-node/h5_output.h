// Particle snapshots in RUN_DIR/particles.h5:
//
//   /snapshots/<step, 8 digits>/        attribute time_s (double)
//       id        int64   [N]      LIGGGHTS atom tag; in an open vessel the cells in the vessel
//                                  (not its feeder), and a tag freed by a cell that left is
//                                  given again to a cell that enters
//       species   int8    [N]      0 = RBC, 1 = platelet
//       position  double  [N][3]   m, z unwrapped across the periodic ends
//       velocity     double  [N][3]   m/s
//       orientation  double  [N][4]   unit quaternion (w, x, y, z), body -> world; the body z
//                                     axis is a platelet's symmetry axis; (1, 0, 0, 0) for
//                                     particles whose orientation is not tracked (RBCs, spheres)
//
// The file is flushed after every snapshot so that a crash keeps what was written.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace hemo::particles {

struct ParticleSnapshot {
  long step = 0;
  double time_s = 0;
  std::vector<std::int64_t> id;
  std::vector<std::int8_t> species;
  std::vector<double> position;     // 3 per particle
  std::vector<double> velocity;     // 3 per particle
  std::vector<double> orientation;  // 4 per particle (w, x, y, z)
  std::size_t size() const { return id.size(); }
};

class H5Output {
 public:
  // Creates (truncates) the file; throws std::runtime_error naming the path on failure.
  explicit H5Output(const std::string& path);
  // Goes on with the file of a run resumed after step `last_step`: the snapshots of later steps
  // are removed (the resumed run writes them again; HDF5 does not shrink the file), those up to
  // it kept; listed in `dropped` if given. A missing file is created.
  static std::unique_ptr<H5Output> resume(const std::string& path, long last_step,
                                          std::vector<long>* dropped = nullptr);
  ~H5Output();
  H5Output(const H5Output&) = delete;
  H5Output& operator=(const H5Output&) = delete;

  // Writes one snapshot and flushes; returns false (writes nothing) when that step exists.
  bool write(const ParticleSnapshot& snapshot);
  const std::string& path() const { return path_; }

 private:
  H5Output(const std::string& path, long long file, long long snapshots)
      : path_(path), file_(file), snapshots_(snapshots) {}
  std::string path_;
  long long file_ = -1;       // hid_t
  long long snapshots_ = -1;  // hid_t of /snapshots
};

// Reading back (tests, analysis).
std::vector<long> list_snapshots(const std::string& path);
ParticleSnapshot read_snapshot(const std::string& path, long step);
std::string snapshot_name(long step);  // "00000042"

}  // namespace hemo::particles
