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
// decomposePar -force would delete the processor folders. A checkpoint written by another
// number of ranks than N (`hemocosim resume --np-fluid N`) is first redistributed onto N by
// OpenFOAM's own tools, and the case decomposed anew (redistribute_checkpoint).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_case.h"
#include "vessel_mesh.h"

#include <checkpoint.h>
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
#include <iterator>
#include <sstream>
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

// The fluid ranks that wrote a checkpoint: its processor<r> folders (none: one).
int checkpoint_ranks(const std::filesystem::path& checkpoint) {
  int ranks = 0;
  while (std::filesystem::is_directory(checkpoint / ("processor" + std::to_string(ranks)))) ++ranks;
  return std::max(ranks, 1);
}

// The time folder a checkpoint holds its fields in (its one time directory, whole or of rank 0).
std::string checkpoint_time(const std::filesystem::path& checkpoint, int ranks) {
  const auto fields = ranks > 1 ? checkpoint / "processor0" : checkpoint;
  for (const auto& entry : std::filesystem::directory_iterator(fields))
    if (entry.is_directory() && entry.path().filename().string().rfind("processor", 0) != 0)
      return entry.path().filename().string();
  throw std::runtime_error("the fluid checkpoint " + checkpoint.string() + " holds no fields");
}

void copy_folder(const std::filesystem::path& from, const std::filesystem::path& to) {
  std::filesystem::create_directories(to.parent_path());
  std::filesystem::copy(from, to, std::filesystem::copy_options::recursive);
}

// Resuming on `ranks` from a checkpoint of `step` that another number of fluid ranks wrote: its
// fields go onto the new ranks by OpenFOAM's own tools (no field of ours moved by hand), in a
// scratch case RUN_DIR/fluid-redistributed beside the sealed checkpoint, which stays untouched:
// the mesh decomposed as the writing ranks had it (decomposePar -time none, the same
// deterministic split), their fields put in it and joined (reconstructPar), then split for the
// new ranks (decomposePar). Fields go in binary at 17 digits, so every value arrives unchanged;
// the solver reads them from there (restoreCheckpoint.H). The run's case is then decomposed
// anew: its output so far joined into the case's own time folders (reconstructPar), the old
// processor folders replaced by the mesh and the initial fields split for the new ranks (or none
// for one).
// Logs: RUN_DIR/fluid/log.redistribute.*.
void redistribute_checkpoint(const std::string& scene_file, const std::string& run_dir, long step, int ranks) try {
  namespace fs = std::filesystem;
  const fs::path checkpoint = fs::path(hemo::checkpoint_folder(run_dir, step)) / "fluid";
  if (!fs::is_directory(checkpoint)) return;  // the solver names what is missing
  const int written = checkpoint_ranks(checkpoint);
  if (written == ranks) return;
  const hemo::Scene scene = hemo::load_scene(scene_file);
  const fs::path case_dir = fs::path(run_dir) / "fluid", scratch = fs::path(run_dir) / "fluid-redistributed";
  const std::string time = checkpoint_time(checkpoint, written);
  auto tool = [&](const std::string& name, std::vector<std::string> args) {
    args.insert(args.begin(), name);
    run_logged(args, (case_dir / ("log.redistribute." + name)).string());
  };

  fs::remove_all(scratch);
  copy_folder(case_dir / "system", scratch / "system");
  copy_folder(case_dir / "constant", scratch / "constant");
  {
    const fs::path dict = scratch / "system" / "controlDict";
    std::ifstream in(dict);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()), line, out;
    std::istringstream lines(text);
    while (std::getline(lines, line)) {
      if (line.rfind("writeFormat", 0) == 0) line = "writeFormat     binary;";
      if (line.rfind("writePrecision", 0) == 0) line = "writePrecision  17;";
      out += line + "\n";
    }
    std::ofstream(dict, std::ios::trunc) << out;
  }
  if (written > 1) {
    hemo::write_decomposition(scratch.string(), written, scene.mesh);
    tool("decomposePar", {"-case", scratch.string(), "-force", "-time", "none"});
    for (int r = 0; r < written; ++r) {
      const std::string rank = "processor" + std::to_string(r);
      copy_folder(checkpoint / rank / time, scratch / rank / time);
    }
    tool("reconstructPar", {"-case", scratch.string(), "-time", time});
  } else {
    copy_folder(checkpoint / time, scratch / time);
  }
  if (ranks > 1) {
    hemo::write_decomposition(scratch.string(), ranks, scene.mesh);
    tool("decomposePar", {"-case", scratch.string(), "-force", "-time", time});
  }
  std::ofstream(scratch / "redistributed") << "step " << step << " ranks " << ranks << " time " << time << "\n";

  // The run's case: its output joined, then split for the new ranks.
  if (written > 1) tool("reconstructPar", {"-case", case_dir.string()});
  if (ranks > 1) {
    hemo::write_decomposition(case_dir.string(), ranks, scene.mesh);
    tool("decomposePar", {"-case", case_dir.string(), "-force", "-time", "0"});  // the fields a rank starts from
  } else {
    for (int r = 0; r < written; ++r) fs::remove_all(case_dir / ("processor" + std::to_string(r)));
  }
  std::cout << "hemocosim-fluid: the checkpoint of step " << step << " of " << written
            << " fluid ranks redistributed onto " << ranks << " (reconstructPar, decomposePar; "
            << scratch.string() << ")" << std::endl;
} catch (const std::exception& e) {
  throw std::runtime_error("cannot redistribute the fluid checkpoint of step " + std::to_string(step) + " onto " +
                           std::to_string(ranks) + " ranks: " + e.what());
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
  const std::string resume_step = hemo::argv_option(argc, argv, "--resume-step");
  const bool resuming = !resume_step.empty() && std::atol(resume_step.c_str()) > 0;
  const std::string scene = hemo::argv_option(argc, argv, "--scene"), run_dir = hemo::argv_option(argc, argv, "--run-dir");
  if (resuming && !scene.empty() && !run_dir.empty()) {
    try {
      redistribute_checkpoint(scene, std::filesystem::absolute(run_dir).lexically_normal().string(),
                              std::atol(resume_step.c_str()), std::max(ranks, 1));
    } catch (const std::exception& e) {
      std::cerr << "hemocosim-fluid: error: " << e.what() << std::endl;
      return 1;
    }
  }
  if (ranks <= 1 && job.starter == hemo::MpiStarter::mpirun) exec(solver_args);

  try {
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
