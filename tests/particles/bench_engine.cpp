// SPDX-License-Identifier: GPL-3.0-or-later
// Cost of the particle node's DEM per particle-step on a synthetic Poiseuille flow, without the
// bus: bench_engine [diameter_um length_um hematocrit coupling_steps cells_per_side axial_cells
//                    closures closure_every_dem_steps]
//      bench_engine --scene FILE [coupling_steps]   (a scene's particles, closures and DEM timing
//                                                    on an 8 x 8 x 24 box mesh)
// Defaults: the calibration case (100 um x 600 um, Ht 0.15, 8 x 8 x 24 = 1,536 cells) with the
// paper's closures ("paper"; "stokes": Stokes drag only, no lift, torque or orientation).
// Then the floor, side by side on the same particles: the same number of DEM steps as one bare
// LIGGGHTS run (DemEngine::run_bare: no fluid forces, one `run`), and the ratio of the two.
#include "box_mesh.h"
#include "dem_engine.h"
#include "dem_timing.h"

#include <mpi.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

using namespace hemo::particles;
using namespace hemo::particles::testing;

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  const bool from_file = argc > 2 && std::string(argv[1]) == "--scene";
  const auto number = [&](int i, double fallback) { return !from_file && argc > i ? std::atof(argv[i]) : fallback; };
  const hemo::Scene file_scene = from_file ? hemo::load_scene(argv[2]) : hemo::Scene{};
  const double d = from_file ? file_scene.vessel.diameter : number(1, 100) * 1e-6;
  const double l = from_file ? file_scene.vessel.length : number(2, 600) * 1e-6;
  const double ht = number(3, 0.15);
  const int steps = from_file ? (argc > 3 ? std::atoi(argv[3]) : 20) : static_cast<int>(number(4, 20));
  const int nxy = static_cast<int>(number(5, 8));
  const int nz = static_cast<int>(number(6, 24));
  const std::string closures = from_file ? argv[2] : argc > 7 ? argv[7] : "paper";
  const int closure_every = static_cast<int>(number(8, 1));
  const double R = d / 2, interval = from_file ? file_scene.time.coupling_interval : 1e-5;
  {
    auto scene = from_file ? file_scene : blood_scene(d, l, ht);
    if (closures == "paper") use_paper_closures(scene);
    if (!from_file) scene.time.closure_every_dem_steps = closure_every;
    const auto mesh = box_mesh(nxy, nxy, nz, -R, R, -R, R, l, d);
    const CellLocator locator(mesh);
    FluidSampler fluid(locator);
    fluid.set_state(fluid_state(mesh, poiseuille(R, scene.driving.wall_shear_rate * R / 2)));
    Deposition deposition(locator, make_solid_fraction_model(scene.solid_fraction, locator));
    const auto log = (std::filesystem::temp_directory_path() / "hemo_bench_liggghts.log").string();
    DemEngine engine(scene, locator, log, MPI_COMM_WORLD);
    auto t0 = std::chrono::steady_clock::now();
    const auto placed = place_particles(R, l, 0, placement_requests(scene), 1);
    engine.create_particles(placed);
    auto t1 = std::chrono::steady_clock::now();
    const auto timing = derive_dem_timing(scene, interval);
    for (int k = 1; k <= steps; ++k) {
      const auto err = engine.run(k, timing.substeps, timing.dt, fluid);
      if (!err.empty()) {
        std::fprintf(stderr, "%s\n", err.c_str());
        return 1;
      }
      engine.deposit(deposition);
    }
    auto t2 = std::chrono::steady_clock::now();
    const auto diag = engine.diagnostics(&fluid);
    auto t3 = std::chrono::steady_clock::now();
    const long coupled_builds = engine.neighbour_builds();
    const double bare_s = engine.run_bare(static_cast<long>(steps) * timing.substeps, timing.dt);
    const long bare_builds = engine.neighbour_builds();
    const double run_s = std::chrono::duration<double>(t2 - t1).count();
    const double particle_steps = static_cast<double>(placed.size()) * timing.substeps * steps;
    std::printf(
        "[%s, closures every %d DEM steps] %zu particles, %d coupling steps x %d substeps (dt %.3g s): setup %.2f s, "
        "run %.2f s, "
        "%.1f ns per particle-step; diagnostics %.3f s; 2 s of physics would take %.0f min\n",
        closures.c_str(), scene.time.closure_every_dem_steps, placed.size(), steps, timing.substeps, timing.dt,
        std::chrono::duration<double>(t1 - t0).count(), run_s, 1e9 * run_s / particle_steps,
        std::chrono::duration<double>(t3 - t2).count(), run_s / (steps * interval) * 2 / 60);
    std::printf("floor: the same %d DEM steps as one bare LIGGGHTS run: %.2f s, %.1f ns per particle-step; "
                "coupled / floor = %.2f; neighbour-list builds %ld coupled, %ld bare\n",
                steps * timing.substeps, bare_s, 1e9 * bare_s / particle_steps, run_s / bare_s, coupled_builds,
                bare_builds);
    std::printf("core particle v_z %.6g m/s, fluid %.6g m/s; max overlap %.3g; outside %ld\n",
                diag.core_particle_axial_velocity, diag.core_fluid_axial_velocity, diag.max_overlap, diag.outside_mesh);
  }
  MPI_Finalize();
  return 0;
}
