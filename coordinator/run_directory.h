// A run directory: the scene copy, the run's identity on the bus, logs and results.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"
#include "scene.h"

#include <optional>
#include <string>

namespace hemo {

struct RunDirectory {
  std::string path;
  std::string scene_copy() const { return path + "/scene.toml"; }
  std::string info_file() const { return path + "/run.toml"; }
  std::string secret_file() const { return path + "/secret"; }
  std::string metrics_file() const { return path + "/metrics.csv"; }
  std::string log(const std::string& node) const { return path + "/" + node + ".log"; }
  int fluid_ranks = 0;  // as run (0: unknown, a run directory older than resume)
  int particle_ranks = 0;
  std::string fluid_command;  // a node swapped in (`hemocosim swap`); empty: the scene's
  std::string particle_command;
  HostPlacement placement;  // where the nodes run (docs/hosts.md); a resumed run uses it again

  // Copies a surface vessel's STL given by a relative path (below the scene's folder: the scene
  // refuses others) to the same path below the run directory, where the nodes' scene.toml finds
  // it; an absolute path is read where it is.
  void keep_surface(const Scene& scene) const;
  // Remembers the ranks the nodes run on: a resumed run must use the same decomposition.
  void record_ranks(int fluid, int particles);
  // Remembers where the nodes run (`hemocosim resume` places them the same way).
  void record_placement(const HostPlacement& hosts);
  // Remembers the bus's transport and relay (hosts.transport, relay_address, relay_port) in
  // run.toml's [bus]: a resumed run starts its relay the same way. `open` puts them in placement.
  void record_transport(const HostPlacement& hosts);
  bool transport_recorded = false;  // run.toml has [bus] (older run directories do not)
  // The bus URL of the run as it is now (the TCP relay's address and port are known once it listens).
  void record_bus_url(const std::string& url) const;
  // Remembers the program a node was swapped for: a resumed run goes on with it.
  void record_command(const std::string& node, const std::string& command);
  // Signs the commands the nodes run (scene.run.fluid_command / particle_command as the run goes
  // on, a swap's included) in run.toml with the run's secret: a resume runs them without asking,
  // but not a command put there by anything else (commands_signed).
  void sign_commands(const RunContext& ctx, const Scene& scene);
  bool commands_signed(const RunContext& ctx, const Scene& scene) const;
  // The newest step of which both nodes wrote a complete checkpoint (common/checkpoint.h) and
  // the coordinator sealed (seal_checkpoint).
  std::optional<long> last_checkpoint() const;
  // Writes the SHA-256 of every file of the checkpoint of `step` to its SHA256SUMS (sha256sum's
  // format), once both nodes have acknowledged it: only then is it one to go on from.
  void seal_checkpoint(long step) const;
  // Throws a one-line reason when a file of the checkpoint of `step` is not as sealed (changed,
  // missing, added).
  void verify_checkpoint(long step) const;
  // Whether the file system of the run directory is full (under 1 MB free): what a node's failed
  // write (OpenFOAM's "error in IOstream", HDF5's) or the coordinator's came from.
  bool out_of_space() const;
  // Bytes the checkpoint of `step` takes.
  std::uintmax_t checkpoint_bytes(long step) const;
  // Removes every checkpoint but that of `step` (and partial ones of later steps).
  void keep_only_checkpoint(long step) const;
  // Removes the checkpoint of `step`, complete or not.
  void drop_checkpoint(long step) const;
  // Drops the coordinator's metrics of steps after `step` (a resumed run writes them again), and
  // lines that are not rows (a crash's, a full disk's) with a warning.
  void drop_metrics_after(long step) const;

  // Creates a fresh run directory (refusing to reuse a non-empty one, or an empty one that is
  // not the user's own or that others may write), readable by the user only (umask 077), copies
  // the scene, and draws a run id, a bus URL of its own (multicast TTL `bus_ttl`: 0 keeps it on
  // this host) and a secret (OpenSSL's RAND_bytes, created 0600 in one step).
  static std::pair<RunDirectory, RunContext> create(const std::string& path, const std::string& scene_path,
                                                    int bus_ttl = 0);
  // Reads the identity of an existing run (for the monitor, resume, restart and swap), refusing a
  // directory or secret that is not the user's own (common/run_files.h).
  static std::pair<RunDirectory, RunContext> open(const std::string& path);
};

// The run directory's lock (RUN_DIR/lock, flock): held by the coordinator of `run` and `resume`
// for the run's life, so that a second one on the same directory is refused, and `restart` and
// `swap` know whether anyone drives the run. Not inherited by the nodes (close-on-exec).
class RunLock {
 public:
  // Takes the lock; throws a one-line reason when another coordinator holds it.
  explicit RunLock(const std::string& run_dir);
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;
  ~RunLock();
  // Whether a coordinator holds the lock of `run_dir` now.
  static bool held(const std::string& run_dir);

 private:
  int fd_ = -1;
};

}  // namespace hemo
