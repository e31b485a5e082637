// The line of a node's log the coordinator quotes when the node dies (last_said_line,
// coordinator/node_process.h): the node's own last words, not what Open MPI adds after them when
// a job aborts, in either order; Open MPI's notice itself when the node said nothing else.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "node_process.h"

using hemo::last_said_line;

namespace {

// What Open MPI 4 prints when a rank calls MPI_Abort (copied from a run of the LIGGGHTS abort
// probe, tests/particles/liggghts_abort_probe.cpp).
constexpr const char* kAbortNotice =
    "--------------------------------------------------------------------------\n"
    "MPI_ABORT was invoked on rank 0 in communicator MPI_COMM_WORLD\n"
    "with errorcode 1.\n"
    "\n"
    "NOTE: invoking MPI_ABORT causes Open MPI to kill all MPI processes.\n"
    "You may or may not see output from other processes, depending on\n"
    "exactly when Open MPI kills them.\n"
    "--------------------------------------------------------------------------\n";

}  // namespace

TEST(NodeLog, TheLastLineIsTheNodesOwnNotOpenMpisAbortNotice) {
  EXPECT_EQ(last_said_line(""), "");
  EXPECT_EQ(last_said_line("step 1\nstep 2\n\n  \n"), "step 2");
  const std::string said = "hemocosim-particles: error: LIGGGHTS: ERROR on proc 1: two (probe.cpp:1)";
  // One rank: the node's line, then the notice.
  EXPECT_EQ(last_said_line("starting\n" + said + "\n" + kAbortNotice), said);
  // Two ranks under mpirun: the notice first, then the ranks' lines, then mpirun's help notes.
  EXPECT_EQ(last_said_line(std::string(kAbortNotice) + said + "\n" +
                           "[vm:05754] 1 more process has sent help message help-mpi-api.txt / mpi-abort\n"
                           "[vm:05754] Set MCA parameter \"orte_base_help_aggregate\" to 0 to see all help / error "
                           "messages\n"),
            said);
  // A log line of the node's that starts with a bracket is its own (spdlog's).
  EXPECT_EQ(last_said_line("[2026-12-07 06:31:04.199] [error] step 3: the fluid state is not finite\n"),
            "[2026-12-07 06:31:04.199] [error] step 3: the fluid state is not finite");
}

TEST(NodeLog, ANoticeAloneIsQuotedByItsFirstLine) {
  EXPECT_EQ(last_said_line("--------------------------------------------------------------------------\n"
                           "mpirun was unable to launch the specified application as it could not access\n"
                           "or execute an executable:\n"
                           "--------------------------------------------------------------------------\n"),
            "mpirun was unable to launch the specified application as it could not access");
}
