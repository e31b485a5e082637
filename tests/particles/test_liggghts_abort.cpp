// LIGGGHTS's Error::one (one rank stops: its message goes to its screen alone, then MPI_Abort)
// in a process armed as the particle node arms itself (particle-node/liggghts_errors.h): the
// probe program's real LIGGGHTS error, alone and on each of two ranks under mpirun. Before the
// report, such an abort ended the node with "exited with status 1" and Open MPI's notice.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "run_command.h"

#include <string>

using hemo::test::bin;
using hemo::test::run;

namespace {

const std::string kMessage = "Neighbor list overflow, boost neigh_modify one";

std::string said(int proc) {
  return "LIGGGHTS: ERROR on proc " + std::to_string(proc) + ": " + kMessage + " (probe.cpp:1)";
}

}  // namespace

TEST(LiggghtsErrors, AnErrorOnOneRankIsReportedAndSaidBeforeTheAbort) {
  const auto alone = run(bin("hemocosim-test-liggghts-abort") + " '" + kMessage + "'");
  EXPECT_NE(alone.exit_code, 0);
  EXPECT_NE(alone.output.find("reported: " + said(0)), std::string::npos) << alone.output;
  EXPECT_NE(alone.output.find("hemocosim-particles: error: " + said(0)), std::string::npos) << alone.output;

  const auto two = run("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " + std::string(HEMO_MPIEXEC) +
                       " -np 2 --oversubscribe " + bin("hemocosim-test-liggghts-abort") + " '" + kMessage + "'");
  EXPECT_NE(two.exit_code, 0);
  // Whichever rank aborts first, its line is out before Open MPI kills the job.
  const bool any = two.output.find("hemocosim-particles: error: " + said(0)) != std::string::npos ||
                   two.output.find("hemocosim-particles: error: " + said(1)) != std::string::npos;
  EXPECT_TRUE(any) << two.output;
}
