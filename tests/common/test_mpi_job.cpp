// How a node becomes an MPI job (common/mpi_job.h): mpirun here or on placed hosts, srun as a
// Slurm job step; and how the slurm launcher shares an allocation's nodes (model/hosts.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <algorithm>
#include <map>

#include "mpi_job.h"

using namespace hemo;

namespace {
// An environment of the test's own, instead of this process's.
struct FakeEnv {
  std::map<std::string, std::string> vars;
  std::function<const char*(const char*)> lookup() const {
    return [this](const char* name) -> const char* {
      const auto it = vars.find(name);
      return it == vars.end() ? nullptr : it->second.c_str();
    };
  }
};

bool has(const std::vector<std::string>& argv, const std::string& word) {
  return std::find(argv.begin(), argv.end(), word) != argv.end();
}

const MpiCommand::Var* var(const MpiCommand& c, const std::string& name) {
  for (const auto& v : c.env)
    if (v.name == name) return &v;
  return nullptr;
}
}  // namespace

TEST(MpiJob, MpirunHereOversubscribesAndExportsWhatTheRanksNeed) {
  MpiJob job;
  job.ranks = 3;
  job.exported = {"WM_PROJECT_DIR"};
  const FakeEnv env;
  const auto c = mpi_job_command(job, {"/bin/node", "--ranks", "3"}, env.lookup(), false);
  const std::vector<std::string> want = {"mpirun", "-np", "3", "-x", "WM_PROJECT_DIR", "/bin/node", "--ranks", "3"};
  EXPECT_EQ(c.argv, want);
  ASSERT_TRUE(var(c, "OMPI_MCA_rmaps_base_oversubscribe"));
  EXPECT_TRUE(var(c, "OMPI_MCA_rmaps_base_oversubscribe")->keep_user_value);
  EXPECT_FALSE(var(c, "OMPI_ALLOW_RUN_AS_ROOT"));  // not root
  EXPECT_TRUE(var(mpi_job_command(job, {"/bin/node"}, env.lookup(), true), "OMPI_ALLOW_RUN_AS_ROOT"));
}

TEST(MpiJob, MpirunOnHostsPlacesExactlyThereWithoutOversubscribing) {
  MpiJob job;
  job.ranks = 4;
  job.hosts = parse_host_list("b:2,c:2");
  const FakeEnv env{{{"HEMOCOSIM_MPIRUN", "/opt/mpi/bin/mpirun"}, {"HEMOCOSIM_MPIRUN_ARGS", " --mca  btl tcp,self "}}};
  const auto c = mpi_job_command(job, {"/bin/node"}, env.lookup(), false);
  const std::vector<std::string> want = {
      "/opt/mpi/bin/mpirun", "-np", "4", "--host", "b:2,c:2", "--mca", "btl", "tcp,self", "/bin/node"};
  EXPECT_EQ(c.argv, want);
  EXPECT_FALSE(var(c, "OMPI_MCA_rmaps_base_oversubscribe"));
}

TEST(MpiJob, SrunIsAPmixJobStepSharingTheAllocationAndEndingWithAFailedRank) {
  MpiJob job;
  job.starter = MpiStarter::srun;
  job.ranks = 1;  // one rank is a job step too
  const FakeEnv env{{{"HEMOCOSIM_SRUN_ARGS", "--cpu-bind=cores"}}};
  const auto c = mpi_job_command(job, {"/bin/node", "--x"}, env.lookup(), true);
  ASSERT_GE(c.argv.size(), 2u);
  EXPECT_EQ(c.argv.front(), "srun");
  for (const char* w : {"--mpi=pmix", "--overlap", "--kill-on-bad-exit=1", "--ntasks=1", "--cpu-bind=cores"})
    EXPECT_TRUE(has(c.argv, w)) << w;
  EXPECT_EQ(std::vector<std::string>(c.argv.end() - 2, c.argv.end()), (std::vector<std::string>{"/bin/node", "--x"}));
  EXPECT_FALSE(has(c.argv, "--distribution=arbitrary"));  // no hosts: Slurm places the ranks
  EXPECT_FALSE(var(c, "SLURM_HOSTFILE"));
  EXPECT_FALSE(var(c, "OMPI_ALLOW_RUN_AS_ROOT"));  // srun starts the ranks, not mpirun
  EXPECT_FALSE(has(c.argv, "-x"));                 // srun passes the environment on by itself
}

TEST(MpiJob, SrunOnHostsListsOneHostARankInItsHostFile) {
  MpiJob job;
  job.starter = MpiStarter::srun;
  job.ranks = 3;
  job.hosts = parse_host_list("n2:2,n3:1");
  job.slurm_hostfile = "/runs/r/particles.slurm-hosts";
  const auto c = mpi_job_command(job, {"/bin/node"}, FakeEnv().lookup(), false);
  EXPECT_TRUE(has(c.argv, "--distribution=arbitrary"));
  EXPECT_TRUE(has(c.argv, "--ntasks=3"));
  ASSERT_TRUE(var(c, "SLURM_HOSTFILE"));
  EXPECT_EQ(var(c, "SLURM_HOSTFILE")->value, job.slurm_hostfile);
  EXPECT_FALSE(var(c, "SLURM_HOSTFILE")->keep_user_value);  // the placement, not an inherited file
  EXPECT_EQ(slurm_hostfile_text(job.hosts), "n2\nn2\nn3\n");
  job.slurm_hostfile.clear();
  EXPECT_THROW(mpi_job_command(job, {"/bin/node"}, FakeEnv().lookup(), false), std::invalid_argument);
}

TEST(MpiJob, StarterNamesAreMpirunAndSrunOnly) {
  EXPECT_EQ(parse_mpi_starter("mpirun"), MpiStarter::mpirun);
  EXPECT_EQ(parse_mpi_starter("srun"), MpiStarter::srun);
  EXPECT_THROW(parse_mpi_starter("ssh"), std::invalid_argument);
}

TEST(MpiJob, AnAllocationIsSharedFluidFirstParticlesOnTheRest) {
  // One node: both there.
  EXPECT_EQ(split_allocation({"n1"}, 1, 2), (std::pair<std::string, std::string>{"n1:1", "n1:2"}));
  // Several: the fluid on the first, the particles' ranks in blocks over the others.
  EXPECT_EQ(split_allocation({"n1", "n2", "n3"}, 2, 5), (std::pair<std::string, std::string>{"n1:2", "n2:3,n3:2"}));
  // Fewer particle ranks than nodes: the spare nodes get none.
  EXPECT_EQ(split_allocation({"n1", "n2", "n3", "n4"}, 1, 2),
            (std::pair<std::string, std::string>{"n1:1", "n2:1,n3:1"}));
  // The lists give back the ranks asked for.
  const auto [fluid, particles] = split_allocation({"a", "b", "c", "d"}, 3, 7);
  EXPECT_EQ(total_slots(parse_host_list(fluid)), 3);
  EXPECT_EQ(total_slots(parse_host_list(particles)), 7);
  EXPECT_THROW(split_allocation({}, 1, 1), std::invalid_argument);
}

TEST(MpiJob, ArgvOptionTakesBothFormsAndTheLastGiven) {
  const char* args[] = {"node", "--ranks", "2", "--mpi-hosts=b:2", "--ranks=3", "--scene"};
  char** argv = const_cast<char**>(args);
  EXPECT_EQ(argv_option(6, argv, "--ranks"), "3");
  EXPECT_EQ(argv_option(6, argv, "--mpi-hosts"), "b:2");
  EXPECT_EQ(argv_option(6, argv, "--scene"), "");  // no value after it
  EXPECT_EQ(argv_option(6, argv, "--mpi"), "");    // not a prefix match
  EXPECT_EQ(starter_program(MpiStarter::srun, FakeEnv().lookup()), "srun");
  EXPECT_EQ(starter_program(MpiStarter::mpirun, FakeEnv{{{"HEMOCOSIM_MPIRUN", "/x/mpirun"}}}.lookup()), "/x/mpirun");
}
