// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_streaming_neighbours.h"

#include <atom.h>
#include <comm.h>
#include <error.h>
#include <fix.h>
#include <fmt/format.h>
#include <lammps.h>
#include <mpi.h>
#include <neighbor.h>
#include <update.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

namespace hemo::particles::dem {

namespace {

// LIGGGHTS's periodic check, replaced: `every` this many steps, never reached in a run.
constexpr int kNeverEvery = 1000000000;

class FixStreamingNeighbours : public LAMMPS_NS::Fix {
 public:
  // fix ID all hemo/streaming_neighbours RADIUS WALL_SHEAR_RATE
  FixStreamingNeighbours(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) : Fix(lmp, narg, arg) {
    if (narg != 5) error->all(FLERR, "fix hemo/streaming_neighbours needs RADIUS WALL_SHEAR_RATE");
    radius_ = std::atof(arg[3]);
    shear_ = std::atof(arg[4]);
    if (!(radius_ > 0) || !(shear_ >= 0)) error->all(FLERR, "fix hemo/streaming_neighbours: bad RADIUS or rate");
    // Sub-domains that split the box along the stream would see atoms stream out of them between
    // builds (the header says why that is not allowed).
    if (comm->procgrid[2] != 1)
      error->all(FLERR, "fix hemo/streaming_neighbours needs the box unsplit along z (`processors * * 1`)");
    u_max_ = 0.5 * shear_ * radius_;
    force_reneighbor = 1;
    next_reneighbor = -1;
  }

  int setmask() override { return LAMMPS_NS::FixConst::POST_INTEGRATE | LAMMPS_NS::FixConst::PRE_NEIGHBOR; }

  void init() override {
    if (neighbor->dist_check != 0 || neighbor->every < kNeverEvery)
      error->all(FLERR, "fix hemo/streaming_neighbours needs `neigh_modify every 1000000000 check no`");
  }

  // LIGGGHTS is about to build the lists from the atoms as they are now (wrapped, exchanged):
  // they are the reference of the lists' lifetime.
  void setup_pre_neighbor() override { hold(); }
  void pre_neighbor() override { hold(); }

  // After the positions moved, before LIGGGHTS decides on a build in this step.
  void post_integrate() override {
    elapsed_ += update->dt;
    const int n = atom->nlocal;
    double max_sq = 0;
    if (static_cast<std::size_t>(n) * 3 != x0_.size()) {
      max_sq = INFINITY;  // atoms came or went without a build: never, but then rebuild
    } else {
      double** x = atom->x;
      for (int i = 0; i < n; ++i) {
        const double dx = x[i][0] - x0_[3 * i];
        const double dy = x[i][1] - x0_[3 * i + 1];
        const double dz = x[i][2] - x0_[3 * i + 2] - u0_[i] * elapsed_;
        max_sq = std::max(max_sq, dx * dx + dy * dy + dz * dz);
      }
    }
    MPI_Allreduce(MPI_IN_PLACE, &max_sq, 1, MPI_DOUBLE, MPI_MAX, world);
    const double skin = neighbor->skin;
    if (2 * std::sqrt(max_sq) + shear_ * (reach_ + skin) * elapsed_ >= skin) next_reneighbor = update->ntimestep;
  }

 private:
  double streaming_speed(const double* x) const {
    const double r2 = (x[0] * x[0] + x[1] * x[1]) / (radius_ * radius_);
    return u_max_ * (1 - std::min(r2, 1.0));
  }

  void hold() {
    const int n = atom->nlocal;
    x0_.resize(3 * static_cast<std::size_t>(n));
    u0_.resize(static_cast<std::size_t>(n));
    double** x = atom->x;
    double max_radius = 0;
    for (int i = 0; i < n; ++i) {
      std::copy(x[i], x[i] + 3, &x0_[3 * i]);
      u0_[i] = streaming_speed(x[i]);
      max_radius = std::max(max_radius, atom->radius[i]);
    }
    MPI_Allreduce(MPI_IN_PLACE, &max_radius, 1, MPI_DOUBLE, MPI_MAX, world);
    // The largest distance at which LIGGGHTS's granular pair style acts on a pair (contact, or
    // clearing its history), as its list build measures it.
    reach_ = 2 * max_radius * neighbor->contactDistanceFactor;
    elapsed_ = 0;
  }

  double radius_ = 0, shear_ = 0, u_max_ = 0;
  double reach_ = 0;        // m, the largest c_ij
  double elapsed_ = 0;      // s since the last build
  std::vector<double> x0_;  // positions at the last build, 3 per local atom
  std::vector<double> u0_;  // u_s there (axial), per local atom
};

}  // namespace

LAMMPS_NS::Fix* create_streaming_neighbours(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) {
  return new FixStreamingNeighbours(lmp, narg, arg);
}

std::vector<std::string> streaming_neighbour_commands(double radius, double wall_shear_rate) {
  return {
      fmt::format("neigh_modify delay 0 every {} check no", kNeverEvery),
      fmt::format("fix {} all {} {:.17g} {:.17g}", kStreamingNeighbourFix, kStreamingNeighbourStyle, radius,
                  wall_shear_rate),
  };
}

}  // namespace hemo::particles::dem
