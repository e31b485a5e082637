// A fatal LIGGGHTS error ends the process from inside the library: Error::all writes
// "ERROR: ..." to the LIGGGHTS log, finalises MPI and calls exit(1); Error::one writes
// "ERROR on proc N: ..." to the screen alone and calls MPI_Abort, which no exit handler survives.
// So that either still reaches the coordinator as a one-line failure, the node arms a report:
// if the process exits while armed, it reads the last "ERROR" line of the LIGGGHTS logs; if it
// calls MPI_Abort while armed (this file defines MPI_Abort, ahead of the MPI library's, and goes
// on to PMPI_Abort), the last "ERROR" line LIGGGHTS's screen received. The screen is kept in
// memory for that (kept_liggghts_screen): its last lines, nothing on a disk or a terminal. The
// line goes to `report` (the port's fail, heard on rank 0) and to this rank's stderr (the node's
// log, whose last line the coordinator quotes when the node dies).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace hemo::particles {

// The last line starting with "ERROR" in the first of `logs` that has one (newest first), or "".
std::string last_liggghts_error(const std::vector<std::string>& logs);

// A new FILE for a LIGGGHTS instance's screen (lmp->screen; LAMMPS closes it when it ends): what
// is written to it is kept in memory, for every instance alike, line by line.
std::FILE* kept_liggghts_screen();
// The last line starting with "ERROR" that a kept screen received, or "".
std::string last_screen_error();

// Arms the exit handler (once per process; a later call replaces the report and logs).
void report_liggghts_exit(std::vector<std::string> logs, std::function<void(const std::string&)> report);
// The node ends normally: an exit from now on is not a LIGGGHTS failure.
void disarm_liggghts_exit();

}  // namespace hemo::particles
