// A test program, not a node: LIGGGHTS stops on one rank (its real Error::one, with the message
// given on the command line) in a process armed as the particle node arms itself
// (liggghts_errors.h). What must come out: the report with LIGGGHTS's line, on stdout here as the
// node's port would send it, and the same line on stderr, before MPI_Abort ends the process.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "liggghts_errors.h"

#include <error.h>
#include <lammps.h>
#include <mpi.h>

#include <cstdio>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  const std::string message = argc > 1 ? argv[1] : "a probe's error";
  hemo::particles::report_liggghts_exit({}, [](const std::string& why) {
    std::printf("reported: %s\n", why.c_str());
    std::fflush(stdout);
  });
  std::vector<std::string> args = {"probe", "-screen", "none", "-log", "none"};
  std::vector<char*> argv_lmp;
  for (auto& a : args) argv_lmp.push_back(a.data());
  auto* lmp = new LAMMPS_NS::LAMMPS(static_cast<int>(argv_lmp.size()), argv_lmp.data(), MPI_COMM_WORLD);
  lmp->screen = hemo::particles::kept_liggghts_screen();
  lmp->error->one("probe.cpp", 1, message.c_str());  // never returns
  return 0;
}
