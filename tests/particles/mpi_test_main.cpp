// SPDX-License-Identifier: GPL-3.0-or-later
// The main of the particle tests that run LIGGGHTS in-process: MPI around GoogleTest (LIGGGHTS
// needs MPI initialised, also on one rank).
#include <gtest/gtest.h>
#include <mpi.h>

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  const int result = RUN_ALL_TESTS();
  MPI_Finalize();
  return result;
}
