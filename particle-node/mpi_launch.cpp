// SPDX-License-Identifier: GPL-3.0-or-later
#include "mpi_launch.h"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "mpi_job.h"

namespace hemo::particles {

namespace {
int requested_ranks(int argc, char** argv) {
  const std::string value = argv_option(argc, argv, "--ranks");
  char* end = nullptr;
  const long n = std::strtol(value.c_str(), &end, 10);
  return end != value.c_str() && *end == '\0' && n >= 1 && n <= 4096 ? static_cast<int>(n) : 1;
}
}  // namespace

bool inside_mpi_job() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(var) != nullptr) return true;
  return false;
}

int relaunch_as_mpi_job(int argc, char** argv) {
  if (inside_mpi_job()) return 0;
  MpiJob job;
  job.ranks = requested_ranks(argc, argv);
  try {
    const std::string starter = argv_option(argc, argv, "--mpi-starter");
    if (!starter.empty()) job.starter = parse_mpi_starter(starter);
    job.hosts = parse_host_list(argv_option(argc, argv, "--mpi-hosts"));
  } catch (const std::invalid_argument& e) {
    std::cerr << "hemocosim-particles: error: " << e.what() << std::endl;
    return 2;
  }
  if (job.ranks <= 1 && job.starter == MpiStarter::mpirun) return 0;
  if (job.starter == MpiStarter::srun && !job.hosts.empty()) {
    job.slurm_hostfile = std::filesystem::absolute(argv_option(argc, argv, "--run-dir") + "/particles.slurm-hosts");
    std::ofstream(job.slurm_hostfile) << slurm_hostfile_text(job.hosts);
  }
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  std::vector<std::string> program_and_args{ec ? std::string(argv[0]) : self.string()};
  program_and_args.insert(program_and_args.end(), argv + 1, argv + argc);
  exec_mpi_command(mpi_job_command(job, program_and_args, std::getenv, ::geteuid() == 0));
  std::cerr << "hemocosim-particles: error: cannot start the MPI job of " << job.ranks
            << " ranks: " << std::strerror(errno) << std::endl;
  return 127;
}

}  // namespace hemo::particles
