// Running the particle node on N MPI ranks (`--ranks N`): when the process is not already part
// of an MPI job and N > 1, or the coordinator asked for a Slurm job step (`--mpi-starter srun`,
// even for one rank), it replaces itself (execvp, same pid for the coordinator) with the MPI job
// of common/mpi_job.h that runs <itself> <args>. The ranks started that way see the MPI job's
// environment and run normally.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

namespace hemo::particles {

// True when this process was started by an MPI launcher (Open MPI, MPICH/Hydra, PMIx, Slurm).
bool inside_mpi_job();

// Execs the MPI job when one is asked for and this is not one yet; returns only when it is not
// asked for (0) or cannot be started (exit code 127 or 2, after a message on stderr).
int relaunch_as_mpi_job(int argc, char** argv);

}  // namespace hemo::particles
