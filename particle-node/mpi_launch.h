// Running the particle node on N MPI ranks (RunContext::ranks, from `--ranks N`): when N > 1
// and the process is not already part of an MPI job, it replaces itself (execvp, same pid for
// the coordinator) with `mpirun -np N [--allow-run-as-root] --oversubscribe <itself> <args>`.
// The ranks started that way see the MPI job's environment and run normally.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <vector>

namespace hemo::particles {

// The value of `--ranks N` / `--ranks=N` in argv (1 when absent or malformed).
int requested_ranks(int argc, char** argv);

// True when this process was started by an MPI launcher (Open MPI, MPICH/Hydra, PMIx, Slurm).
bool inside_mpi_job();

// The value of `--mpi-hosts H` / `--mpi-hosts=H` in argv (empty when absent).
std::string requested_hosts(int argc, char** argv);

// The mpirun command line that runs `program` with `args` on `ranks` ranks, placed on `hosts`
// ("b:2,c:2", docs/hosts.md) when given.
std::vector<std::string> mpirun_command(int ranks, const std::string& program, const std::vector<std::string>& args,
                                        const std::string& hosts = "");

// Execs mpirun when more than one rank is requested outside an MPI job; returns only when it
// does not (nothing to do: 0) or cannot (exit code 127, after a message on stderr).
int relaunch_under_mpirun(int argc, char** argv);

}  // namespace hemo::particles
