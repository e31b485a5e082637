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
  // The newest step of which both nodes wrote a complete checkpoint (common/checkpoint.h).
  std::optional<long> last_checkpoint() const;
  // Removes every checkpoint but that of `step` (and partial ones of later steps).
  void keep_only_checkpoint(long step) const;
  // Removes the checkpoint of `step`, complete or not.
  void drop_checkpoint(long step) const;
  // Drops the coordinator's metrics of steps after `step` (a resumed run writes them again).
  void drop_metrics_after(long step) const;

  // Creates a fresh run directory (refusing to reuse a non-empty one), copies the scene,
  // and draws a run id, a bus URL of its own (multicast TTL `bus_ttl`: 0 keeps it on this host)
  // and a secret readable by the user only.
  static std::pair<RunDirectory, RunContext> create(const std::string& path, const std::string& scene_path,
                                                    int bus_ttl = 0);
  // Reads the identity of an existing run (for the monitor and resume).
  static std::pair<RunDirectory, RunContext> open(const std::string& path);
};

}  // namespace hemo
