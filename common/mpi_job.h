// How a node with N ranks becomes an MPI job (docs/hosts.md, docs/slurm.md): started by Open
// MPI's `mpirun` (on this host, or on the hosts the coordinator placed it on), or as a Slurm job
// step by `srun` inside an allocation. Both nodes build their command here, so that the two
// launchers place ranks by the same rules; pure, so that the rules are unit-tested.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "hosts.h"

namespace hemo {

enum class MpiStarter { mpirun, srun };
// The value of `--name VALUE` or `--name=VALUE` in argv (the last one given), or empty: how a
// node's launcher reads its MPI options before its own CLI parses them all.
std::string argv_option(int argc, char** argv, const std::string& name);

// "mpirun" or "srun" (a node's --mpi-starter); throws std::invalid_argument otherwise.
MpiStarter parse_mpi_starter(const std::string& name);

struct MpiJob {
  MpiStarter starter = MpiStarter::mpirun;
  int ranks = 1;
  // Where the ranks go. Empty: mpirun runs them all here (more ranks than cores allowed); srun
  // lets Slurm place them in the allocation.
  std::vector<HostSlots> hosts;
  // Environment variables the ranks need from the starting process (mpirun -x; srun passes the
  // whole environment on by itself).
  std::vector<std::string> exported;
  // srun with hosts: the file that lists one host a rank (SLURM_HOSTFILE, arbitrary
  // distribution), which the caller writes with slurm_hostfile_text().
  std::string slurm_hostfile;
};

struct MpiCommand {
  std::vector<std::string> argv;
  // To set before the exec; `keep_user_value`: a value the user already set wins.
  struct Var {
    std::string name, value;
    bool keep_user_value;
  };
  std::vector<Var> env;
};

// The command that runs `program_and_args` as `job`. HEMOCOSIM_MPIRUN / HEMOCOSIM_SRUN name
// another program, HEMOCOSIM_MPIRUN_ARGS / HEMOCOSIM_SRUN_ARGS add options (white-space
// separated), read from `env_lookup` (getenv outside tests).
MpiCommand mpi_job_command(const MpiJob& job, const std::vector<std::string>& program_and_args,
                           const std::function<const char*(const char*)>& env_lookup, bool as_root);

// The program that starts `starter`'s jobs: HEMOCOSIM_MPIRUN / HEMOCOSIM_SRUN from `env_lookup`
// when set, else mpirun / srun.
std::string starter_program(MpiStarter starter, const std::function<const char*(const char*)>& env_lookup);

// One line a rank: "b\nb\nc\nc\n" for b:2,c:2.
std::string slurm_hostfile_text(const std::vector<HostSlots>& hosts);

// Sets the command's environment in this process and replaces it with the command; returns only
// if the exec fails (errno set).
void exec_mpi_command(const MpiCommand& command);

}  // namespace hemo
