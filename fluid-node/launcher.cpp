// hemocosim-fluid: sets up the environment Debian's OpenFOAM needs and becomes the solver,
// serial or decomposed.
//
// OpenFOAM reads etc/controlDict while its libraries load, before main() runs, and finds it
// only through WM_PROJECT_DIR. So the solver (hemocosim-fluid-solver, next to this program)
// cannot set that itself: this launcher sets it (keeping a value the user set) and exec()s the
// solver in the same process, so the pid the coordinator supervises stays the same.
//
// With --ranks N > 1 it first writes the case RUN_DIR/fluid (as the serial solver would) and
// its decomposition into N subdomains along the vessel axis (decomposePar, log in
// RUN_DIR/fluid/log.decomposePar), then exec()s the MPI job of common/mpi_job.h that runs
//   hemocosim-fluid-solver ARGS --parallel
// on N ranks: `mpirun -np N -x WM_PROJECT_DIR -x FOAM_ETC ...`, placed with `--host H` on the
// hosts of --mpi-hosts H when the coordinator gives them, or, with --mpi-starter srun, a Slurm
// job step (`srun --mpi=pmix ...`, also for one rank, then without --parallel).
//
// With --resume-step K (passed on to the solver, which restores checkpoint K) the case and its
// decomposition are those the run already has: they hold its output up to step K, and
// decomposePar -force would delete the processor folders.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_case.h"
#include "vessel_mesh.h"

#include <child_process.h>
#include <mpi_job.h>
#include <scene.h>

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#ifndef HEMOCOSIM_OPENFOAM_PROJECT_DIR
#define HEMOCOSIM_OPENFOAM_PROJECT_DIR "/usr/share/openfoam"
#endif

namespace {

// Replaces this process with the program (same pid for the coordinator): not a child.
[[noreturn]] void exec(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execvp(argv[0], argv.data());
  std::cerr << "hemocosim-fluid: error: cannot start " << args[0] << ": " << std::strerror(errno) << std::endl;
  std::exit(127);
}

// Runs a program to completion with its output in `log`; throws with a one-line reason on failure.
void run_logged(const std::vector<std::string>& args, const std::string& log) {
  std::ofstream out(log, std::ios::trunc);
  hemo::ChildOptions opt;
  opt.merge_stderr = true;
  opt.on_line = [&](const std::string& line) { out << line << '\n'; };
  const hemo::ChildResult r = hemo::run_child(args, opt);
  if (!r.ok()) throw std::runtime_error(args[0] + " " + r.describe() + " (see " + log + ")");
}

// Writes and decomposes the case of an N-rank run.
void prepare_decomposed_case(const std::string& scene_file, const std::string& run_dir, int ranks) try {
  const hemo::Scene scene = hemo::load_scene(scene_file);
  const hemo::FluidSettings fluid = hemo::fluid_settings(scene);
  const hemo::PolyMesh mesh = hemo::make_vessel_mesh(scene.vessel, scene.mesh);
  const std::string case_dir = (std::filesystem::path(run_dir) / "fluid").string();
  hemo::write_case(case_dir, fluid, scene.vessel, mesh, hemo::compute_geometry(mesh), hemo::InitialFlow::poiseuille);
  hemo::write_decomposition(case_dir, ranks, scene.mesh);
  run_logged({"decomposePar", "-case", case_dir, "-force"}, case_dir + "/log.decomposePar");
  std::cout << "hemocosim-fluid: case " << case_dir << " decomposed into " << ranks << " subdomains along the axis"
            << std::endl;
} catch (const std::exception& e) {
  throw std::runtime_error(std::string("cannot decompose the fluid case: ") + e.what());
}

// A resumed N-rank run goes on in the case as the run decomposed it: N subdomains.
void check_decomposed_case(const std::string& run_dir, int ranks) {
  const std::filesystem::path case_dir = std::filesystem::path(run_dir) / "fluid";
  if (!std::filesystem::is_directory(case_dir / ("processor" + std::to_string(ranks - 1))) ||
      std::filesystem::is_directory(case_dir / ("processor" + std::to_string(ranks))))
    throw std::runtime_error("cannot resume on " + std::to_string(ranks) + " ranks: the fluid case " +
                             case_dir.string() + " is not decomposed into " + std::to_string(ranks) + " subdomains");
}

}  // namespace

int main(int argc, char* argv[]) {
  ::setenv("WM_PROJECT_DIR", HEMOCOSIM_OPENFOAM_PROJECT_DIR, 0);
  ::setenv("FOAM_ETC", HEMOCOSIM_OPENFOAM_PROJECT_DIR "/etc", 0);

  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const std::filesystem::path dir = ec ? std::filesystem::path(argv[0]).parent_path() : self.parent_path();
  const std::string solver = (dir / "hemocosim-fluid-solver").string();

  std::vector<std::string> solver_args{solver};
  for (int i = 1; i < argc; ++i) solver_args.emplace_back(argv[i]);

  int ranks = 1;
  const std::string ranks_text = hemo::argv_option(argc, argv, "--ranks");
  if (!ranks_text.empty()) ranks = std::atoi(ranks_text.c_str());
  hemo::MpiJob job;
  job.ranks = std::max(ranks, 1);
  job.exported = {"WM_PROJECT_DIR", "FOAM_ETC"};
  try {
    const std::string starter = hemo::argv_option(argc, argv, "--mpi-starter");
    if (!starter.empty()) job.starter = hemo::parse_mpi_starter(starter);
    job.hosts = hemo::parse_host_list(hemo::argv_option(argc, argv, "--mpi-hosts"));
  } catch (const std::exception& e) {
    std::cerr << "hemocosim-fluid: error: " << e.what() << std::endl;
    return 2;
  }
  if (ranks <= 1 && job.starter == hemo::MpiStarter::mpirun) exec(solver_args);

  const std::string resume_step = hemo::argv_option(argc, argv, "--resume-step");
  const bool resuming = !resume_step.empty() && std::atol(resume_step.c_str()) > 0;
  try {
    const std::string scene = hemo::argv_option(argc, argv, "--scene"),
                      run_dir = hemo::argv_option(argc, argv, "--run-dir");
    if (scene.empty() || run_dir.empty()) throw std::runtime_error("--ranks needs --scene and --run-dir");
    const std::string dir = std::filesystem::absolute(run_dir).lexically_normal().string();
    if (ranks > 1 && resuming)
      check_decomposed_case(dir, ranks);
    else if (ranks > 1)
      prepare_decomposed_case(scene, dir, ranks);
    if (job.starter == hemo::MpiStarter::srun && !job.hosts.empty()) {
      job.slurm_hostfile = dir + "/fluid.slurm-hosts";
      std::ofstream(job.slurm_hostfile) << hemo::slurm_hostfile_text(job.hosts);
    }
  } catch (const std::exception& e) {
    std::cerr << "hemocosim-fluid: error: " << e.what() << std::endl;
    return 1;
  }

  if (ranks > 1) solver_args.emplace_back("--parallel");
  hemo::exec_mpi_command(hemo::mpi_job_command(job, solver_args, std::getenv, ::geteuid() == 0));
  std::cerr << "hemocosim-fluid: error: cannot start the MPI job of " << ranks << " ranks: " << std::strerror(errno)
            << std::endl;
  return 127;
}
