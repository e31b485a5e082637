// SPDX-License-Identifier: GPL-3.0-or-later
#include "mpi_launch.h"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>

namespace hemo::particles {

int requested_ranks(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    std::string value;
    if (a == "--ranks" && i + 1 < argc)
      value = argv[i + 1];
    else if (a.rfind("--ranks=", 0) == 0)
      value = a.substr(8);
    else
      continue;
    char* end = nullptr;
    const long n = std::strtol(value.c_str(), &end, 10);
    return end != value.c_str() && *end == '\0' && n >= 1 && n <= 4096 ? static_cast<int>(n) : 1;
  }
  return 1;
}

bool inside_mpi_job() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(var) != nullptr) return true;
  return false;
}

std::string requested_hosts(int argc, char** argv) {
  std::string hosts;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--mpi-hosts" && i + 1 < argc)
      hosts = argv[i + 1];
    else if (a.rfind("--mpi-hosts=", 0) == 0)
      hosts = a.substr(12);
  }
  return hosts;
}

std::vector<std::string> mpirun_command(int ranks, const std::string& program, const std::vector<std::string>& args,
                                        const std::string& hosts) {
  std::vector<std::string> cmd = {"mpirun", "-np", std::to_string(ranks)};
  if (::geteuid() == 0) cmd.push_back("--allow-run-as-root");
  if (!hosts.empty()) {
    // The coordinator's placement: exactly these hosts and slots, so no oversubscription.
    cmd.push_back("--host");
    cmd.push_back(hosts);
  } else {
    cmd.push_back("--oversubscribe");  // ranks beyond the cores: slower, but the run goes on
  }
  cmd.push_back(program);
  cmd.insert(cmd.end(), args.begin(), args.end());
  return cmd;
}

int relaunch_under_mpirun(int argc, char** argv) {
  const int ranks = requested_ranks(argc, argv);
  if (ranks <= 1 || inside_mpi_job()) return 0;
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const std::string program = ec ? std::string(argv[0]) : self.string();
  const auto cmd =
      mpirun_command(ranks, program, std::vector<std::string>(argv + 1, argv + argc), requested_hosts(argc, argv));
  // A rank waiting for the other (or, on rank 1, for rank 0's bus traffic) yields its core
  // instead of spinning on it: the fluid node and the coordinator share the machine (the fluid
  // launcher does the same). A setting of the user's wins.
  ::setenv("OMPI_MCA_mpi_yield_when_idle", "1", 0);
  std::vector<char*> c_args;
  for (const auto& s : cmd) c_args.push_back(const_cast<char*>(s.c_str()));
  c_args.push_back(nullptr);
  ::execvp(c_args[0], c_args.data());
  std::cerr << "hemocosim-particles: error: cannot start mpirun for " << ranks << " ranks: " << std::strerror(errno)
            << std::endl;
  return 127;
}

}  // namespace hemo::particles
