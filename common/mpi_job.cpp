// SPDX-License-Identifier: GPL-3.0-or-later
#include "mpi_job.h"

#include <unistd.h>

#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace hemo {

std::string argv_option(int argc, char** argv, const std::string& name) {
  std::string value;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == name && i + 1 < argc) value = argv[i + 1];
    if (a.rfind(name + "=", 0) == 0) value = a.substr(name.size() + 1);
  }
  return value;
}

MpiStarter parse_mpi_starter(const std::string& name) {
  if (name == "mpirun") return MpiStarter::mpirun;
  if (name == "srun") return MpiStarter::srun;
  throw std::invalid_argument("unknown MPI starter \"" + name + "\" (mpirun or srun)");
}

namespace {
void append_words(std::vector<std::string>& argv, const char* text) {
  if (text == nullptr) return;
  std::istringstream in(text);
  for (std::string w; in >> w;) argv.push_back(w);
}

}  // namespace

std::string starter_program(MpiStarter starter, const std::function<const char*(const char*)>& env_lookup) {
  const bool mpirun = starter == MpiStarter::mpirun;
  const char* given = env_lookup(mpirun ? "HEMOCOSIM_MPIRUN" : "HEMOCOSIM_SRUN");
  return given != nullptr && *given != '\0' ? given : mpirun ? "mpirun" : "srun";
}

MpiCommand mpi_job_command(const MpiJob& job, const std::vector<std::string>& program_and_args,
                           const std::function<const char*(const char*)>& env_lookup, bool as_root) {
  MpiCommand c;
  const std::string ranks = std::to_string(job.ranks);
  if (job.starter == MpiStarter::mpirun) {
    c.argv = {starter_program(job.starter, env_lookup), "-np", ranks};
    // Open MPI refuses root unless told; a waiting rank yields its core, since the other node
    // and the coordinator share the machine.
    if (as_root) {
      c.env.push_back({"OMPI_ALLOW_RUN_AS_ROOT", "1", true});
      c.env.push_back({"OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", true});
    }
    c.env.push_back({"OMPI_MCA_mpi_yield_when_idle", "1", true});
    if (job.hosts.empty()) {
      c.env.push_back({"OMPI_MCA_rmaps_base_oversubscribe", "1", true});  // slower, but the run goes on
    } else {
      // The coordinator's placement: exactly these hosts and slots.
      c.argv.push_back("--host");
      c.argv.push_back(host_list_text(job.hosts));
    }
    for (const auto& var : job.exported) {
      c.argv.push_back("-x");
      c.argv.push_back(var);
    }
    append_words(c.argv, env_lookup("HEMOCOSIM_MPIRUN_ARGS"));
  } else {
    // A job step of the allocation. --overlap: the two nodes' steps share the job's CPUs, as
    // the lockstep alternates them; --kill-on-bad-exit: one failed rank ends the step, and the
    // coordinator sees the node end.
    c.argv = {starter_program(job.starter, env_lookup), "--mpi=pmix", "--overlap", "--kill-on-bad-exit=1",
              "--ntasks=" + ranks};
    c.env.push_back({"OMPI_MCA_mpi_yield_when_idle", "1", true});
    if (!job.hosts.empty()) {
      if (job.slurm_hostfile.empty()) throw std::invalid_argument("srun with hosts needs a host file");
      c.argv.push_back("--distribution=arbitrary");
      c.env.push_back({"SLURM_HOSTFILE", job.slurm_hostfile, false});
    }
    append_words(c.argv, env_lookup("HEMOCOSIM_SRUN_ARGS"));
  }
  c.argv.insert(c.argv.end(), program_and_args.begin(), program_and_args.end());
  return c;
}

std::string slurm_hostfile_text(const std::vector<HostSlots>& hosts) {
  std::string text;
  for (const auto& h : hosts)
    for (int i = 0; i < h.slots; ++i) text += h.host + "\n";
  return text;
}

void exec_mpi_command(const MpiCommand& command) {
  for (const auto& v : command.env) ::setenv(v.name.c_str(), v.value.c_str(), v.keep_user_value ? 0 : 1);
  std::vector<char*> argv;
  for (const auto& a : command.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execvp(argv[0], argv.data());
}

}  // namespace hemo
