// Who waits for whom when a process of a run falls silent (docs/architecture.md, "Liveness").
//
// The coordinator decides whether a run goes on. A node that hears nothing from the coordinator
// for run.node_timeout_s does not end the run by itself while the coordinator may still come
// back: it keeps waiting while the coordinator's process is stopped (SIGSTOP, a suspended
// shell), and up to kCoordinatorPatience timeouts while it runs or cannot be seen (another
// host); it gives up after the timeout when the coordinator's process is gone, or when no
// coordinator said where it runs (a node started by hand or by a test). A process that was
// itself paused does not blame the others for the silence it did not listen to.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <sys/types.h>

#include <string>

namespace hemo {

// How many node timeouts a node waits for a coordinator that runs, or that it cannot see, before
// it gives up (a coordinator whose process is stopped is waited for as long as it is stopped).
inline constexpr double kCoordinatorPatience = 10;

// A gap of this long between two turns of a loop that polls every 50 ms is a pause of the
// process (SIGSTOP, a suspended host, a host swapping hard), not work.
inline constexpr double kPauseGapS = 1.0;

// The state of a process on this host, from /proc/PID/stat (running, stopped or gone); of the
// coordinator also: on another host (elsewhere) or not known (it did not say where it runs).
enum class ProcessState { running, stopped, gone, elsewhere, unknown };
ProcessState process_state(pid_t pid);

// Where the coordinator of a run runs: RUN_DIR/coordinator.process, "host=H pid=P". The
// coordinator writes it when it starts nodes; a node on the same host watches that process.
std::string coordinator_process_file(const std::string& run_dir);
void write_coordinator_process(const std::string& run_dir);
ProcessState coordinator_state(const std::string& run_dir);

// "paused for 41 s (SIGSTOP or a suspended host?)": the words every line about a pause uses.
std::string pause_words(double seconds);

// Measures the gaps between the turns of a polling loop: a gap above kPauseGapS is a pause.
class PauseWatch {
 public:
  PauseWatch();
  // Seconds this process was away since the last turn (0: no pause).
  double turn();

 private:
  double last_;
};

}  // namespace hemo
