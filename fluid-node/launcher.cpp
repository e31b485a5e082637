// hemocosim-fluid: sets up the environment Debian's OpenFOAM needs and becomes the solver.
//
// OpenFOAM reads etc/controlDict while its libraries load, before main() runs, and finds it
// only through WM_PROJECT_DIR. So the solver (hemocosim-fluid-solver, next to this program)
// cannot set that itself: this launcher sets it (keeping a value the user set) and exec()s the
// solver in the same process, so the pid the coordinator supervises stays the same.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#ifndef HEMOCOSIM_OPENFOAM_PROJECT_DIR
#define HEMOCOSIM_OPENFOAM_PROJECT_DIR "/usr/share/openfoam"
#endif

int main(int argc, char* argv[]) {
  ::setenv("WM_PROJECT_DIR", HEMOCOSIM_OPENFOAM_PROJECT_DIR, 0);
  ::setenv("FOAM_ETC", HEMOCOSIM_OPENFOAM_PROJECT_DIR "/etc", 0);

  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const std::filesystem::path dir = ec ? std::filesystem::path(argv[0]).parent_path() : self.parent_path();
  const std::string solver = (dir / "hemocosim-fluid-solver").string();

  std::vector<char*> args(argv, argv + argc);
  args.push_back(nullptr);
  ::execv(solver.c_str(), args.data());
  std::cerr << "hemocosim-fluid: error: cannot start " << solver << ": " << std::strerror(errno) << std::endl;
  return 127;
}
