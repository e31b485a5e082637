// A fatal LIGGGHTS error ends the process from inside the library: Error::all writes
// "ERROR: ..." to the LIGGGHTS log, finalises MPI and calls exit(1) (Error::one calls MPI_Abort,
// which no handler survives). So that such an exit still reaches the coordinator as a one-line
// failure, the node arms an exit handler: if the process exits while armed, it reads the last
// "ERROR" line of the LIGGGHTS logs and hands it to `report` (the port's fail).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace hemo::particles {

// The last line starting with "ERROR" in the first of `logs` that has one (newest first), or "".
std::string last_liggghts_error(const std::vector<std::string>& logs);

// Arms the exit handler (once per process; a later call replaces the report and logs).
void report_liggghts_exit(std::vector<std::string> logs, std::function<void(const std::string&)> report);
// The node ends normally: an exit from now on is not a LIGGGHTS failure.
void disarm_liggghts_exit();

}  // namespace hemo::particles
