// SPDX-License-Identifier: GPL-3.0-or-later
// hemocosim-dem-bench: the particle node's DEM without a fluid node, and how far it stands from
// LIGGGHTS alone (hemocosim-dem-bench --help; docs/performance.md §6).
//
// The particles of a scene (or of the calibration case) are placed in a box mesh holding the
// Poiseuille flow of the scene's wall shear rate, and stepped as the node steps them:
//   1. N coupling intervals, each one LIGGGHTS `run` of the scene's DEM substeps with our
//      fluid-force callback, the deposition after each (what the node does);
//   2. the same number of DEM steps as one continuous run (what keeping LIGGGHTS in one run
//      would cost);
//   3. with --floor, the floor: a bare LIGGGHTS instance (the same library, none of our fixes, no
//      fluid force) given the particles as `write_data` saved them, with the same settings,
//      contact model, wall, integrator and DEM step, run as many steps, with LIGGGHTS's own
//      neighbour-list policy; and when ours rebuilds in the streaming frame
//      (dem.neighbour_rebuild = "streaming", or --neighbour-rebuild), once more with that.
// Printed, and written as JSON with --json: nanoseconds of wall time per particle-step for each,
// the callback's part and neighbour-list builds (also per 1000 DEM steps); printed, the ratio of
// our DEM (the node's DEM phase, the deposition timed apart) to the floor.
#include "dem_engine.h"
#include "dem_fix_styles.h"
#include "dem_timing.h"
#include "h5_output.h"
#include "mpi_launch.h"
#include "synthetic_case.h"

#include <CLI/CLI.hpp>
#include <lammps.h>
#include <atom.h>
#include <input.h>
#include <neighbor.h>
#include <mpi.h>
#include <nlohmann/json.hpp>
#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

using namespace hemo::particles;
using namespace hemo::particles::synthetic;
namespace fs = std::filesystem;

namespace {

struct Options {
  std::string scene_file;
  int steps = 20;
  int ranks = 1;
  bool floor = false;
  std::string json;
  // A run's particles late in its course instead of a fresh placement.
  std::string from_run;
  double at_time = -1;  // s; < 0: the last snapshot
  // Without a scene: the calibration case's vessel, hematocrit and closures.
  double diameter_um = 100, length_um = 600, hematocrit = 0.15;
  std::string closures = "paper";
  int closure_every = 1;
  // The box mesh holding the flow (cells across, cells along).
  int cells = 8, axial_cells = 24;
  DemBookkeeping bookkeeping;
  std::string neighbour_rebuild;  // empty: the scene's dem.neighbour_rebuild
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Wall time of `what` on the slowest rank: every rank starts together.
template <class F>
double timed(MPI_Comm comm, F&& what) {
  MPI_Barrier(comm);
  const auto t0 = std::chrono::steady_clock::now();
  what();
  double s = seconds_since(t0), slowest = 0;
  MPI_Allreduce(&s, &slowest, 1, MPI_DOUBLE, MPI_MAX, comm);
  return slowest;
}

double sum_over_ranks(MPI_Comm comm, double v) {
  double total = 0;
  MPI_Allreduce(&v, &total, 1, MPI_DOUBLE, MPI_SUM, comm);
  return total;
}

double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;  // KiB on Linux
}

struct BareRun {
  double seconds = 0;  // wall time of its `run`
  long builds = 0;     // neighbour-list builds
  long particles = 0;  // atoms it read
};

// The floor: bare LIGGGHTS on the particles of `input`'s data file.
BareRun run_bare_liggghts(const std::vector<std::string>& input, const std::string& log,
                                          MPI_Comm comm) {
  std::vector<std::string> args = {"liggghts", "-screen", "none", "-log", log};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  // A second instance in one process registers LIGGGHTS's styles again, and says so on stderr for
  // each of a few hundred: not ours to show.
  std::cerr.flush();
  std::fflush(stderr);
  const int saved_stderr = dup(STDERR_FILENO);
  const int devnull = open("/dev/null", O_WRONLY);
  dup2(devnull, STDERR_FILENO);
  auto* lmp = new LAMMPS_NS::LAMMPS(static_cast<int>(argv.size()), argv.data(), comm);
  hemo::particles::dem::register_fix_styles(*lmp);
  std::cerr.flush();
  std::fflush(stderr);
  dup2(saved_stderr, STDERR_FILENO);
  close(devnull);
  close(saved_stderr);
  BareRun bare;
  for (const auto& line : input) {
    if (line.rfind("run ", 0) == 0)
      bare.seconds = timed(comm, [&] { lmp->input->one(line.c_str()); });
    else
      lmp->input->one(line.c_str());
  }
  bare.builds = static_cast<long>(lmp->neighbor->ncalls);
  bare.particles = static_cast<long>(lmp->atom->natoms);
  delete lmp;
  return bare;
}

// The particles of `run_dir`'s snapshot nearest `at_time` (the last if negative), z wrapped back
// into the vessel: the configuration a run has reached (margination, a packed core), to time the
// DEM on it. Velocities start from rest (the drag brings them to the flow within microseconds)
// and the engine gives the tags its own spatial order.
std::vector<PlacedParticle> particles_of_run(const std::string& run_dir, double at_time, const hemo::Scene& scene,
                                             double* time_s) {
  const std::string path = run_dir + "/particles.h5";
  const auto steps = list_snapshots(path);
  if (steps.empty()) throw std::runtime_error(path + " holds no snapshot");
  long step = steps.back();
  if (at_time >= 0 && scene.time.adaptive_interval())
    throw std::runtime_error("--at-time needs a run of fixed coupling intervals (this scene adapts them)");
  if (at_time >= 0) {
    double best = INFINITY;
    for (long s : steps)
      if (double d = std::abs(s * scene.time.coupling_interval - at_time); d < best) best = d, step = s;
  }
  const auto snap = read_snapshot(path, step);
  *time_s = snap.time_s;
  const double l = scene.vessel.length;
  std::vector<PlacedParticle> placed;
  placed.reserve(snap.size());
  for (std::size_t i = 0; i < snap.size(); ++i) {
    const int sp = snap.species[i];
    if (sp != kRbc && sp != kPlatelet) throw std::runtime_error(path + ": a particle of unknown species");
    const double z = snap.position[3 * i + 2] - l * std::floor(snap.position[3 * i + 2] / l);
    placed.push_back({sp, sp == kRbc ? scene.rbc.diameter : scene.platelet.diameter,
                      Vec3(snap.position[3 * i], snap.position[3 * i + 1], z < l ? z : 0.0)});
  }
  return placed;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{
      "The particle node's DEM on a scene's particles in a synthetic Poiseuille flow, without a fluid node:\n"
      "nanoseconds per particle-step in coupling intervals (as the node runs), in one continuous LIGGGHTS run,\n"
      "and with --floor in a bare LIGGGHTS run of the same particles (none of our fixes), side by side.",
      "hemocosim-dem-bench"};
  app.add_option("--scene", o.scene_file, "Scene file: its vessel, particles, closures and DEM timing")
      ->check(CLI::ExistingFile);
  app.add_option("--steps", o.steps, "Coupling intervals to run (each the scene's DEM substeps)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  app.add_option("--ranks", o.ranks, "MPI ranks (re-executes itself under mpirun)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  app.add_option("--from-run", o.from_run,
                 "Start from a run's particles (RUN_DIR/particles.h5; its scene.toml unless --scene) instead of a "
                 "fresh placement: the cost late in a run")
      ->check(CLI::ExistingDirectory);
  app.add_option("--at-time", o.at_time, "With --from-run: the snapshot nearest this time (s); default the last");
  app.add_flag("--floor", o.floor, "Also run bare LIGGGHTS on the same particles and report the ratio");
  app.add_option("--json", o.json, "Write the figures to this JSON file");
  auto* no_scene = app.add_option_group("without --scene", "The synthetic calibration case");
  no_scene->add_option("--diameter-um", o.diameter_um, "Vessel diameter (um)")->capture_default_str();
  no_scene->add_option("--length-um", o.length_um, "Vessel length (um)")->capture_default_str();
  no_scene->add_option("--hematocrit", o.hematocrit, "Red-cell volume fraction")->capture_default_str();
  no_scene->add_option("--closures", o.closures, "paper: the paper's closures; stokes: Stokes drag only")
      ->capture_default_str()
      ->check(CLI::IsMember({"paper", "stokes"}));
  no_scene->add_option("--closure-every", o.closure_every, "Closures every this many DEM steps")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  auto* books = app.add_option_group("LIGGGHTS's bookkeeping", "What the node fixes, varied to measure the cost");
  books->add_option("--skin", o.bookkeeping.skin_diameters, "Neighbour skin (largest particle diameters)")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 10.0));
  books->add_option("--sort-every", o.bookkeeping.sort_every_steps, "LIGGGHTS's spatial sort every N DEM steps (0: never)")
      ->capture_default_str()
      ->check(CLI::Range(0L, 1000000000L));
  books->add_option("--neighbour-rebuild", o.neighbour_rebuild,
                    "When the neighbour lists are rebuilt (default: the scene's dem.neighbour_rebuild)")
      ->check(CLI::IsMember(hemo::choice_names<hemo::NeighbourRebuild>()));
  books->add_flag("--mesh-wall", o.bookkeeping.mesh_wall,
                  "The wall as a triangle mesh (fix mesh/surface), as a narrowing vessel has it, not zcylinder");
  books->add_flag("--shuffled-tags", o.bookkeeping.shuffled_tags,
                  "Create the particles in random order, as a run's order is long after its start");
  app.add_option("--cells", o.cells, "Box-mesh cells across the vessel")->capture_default_str()->check(CLI::Range(1, 256));
  app.add_option("--axial-cells", o.axial_cells, "Box-mesh cells along the vessel")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  CLI11_PARSE(app, argc, argv);
  if (const int code = relaunch_as_mpi_job(argc, argv)) return code;

  MPI_Init(&argc, &argv);
  MPI_Comm comm = MPI_COMM_WORLD;
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (o.scene_file.empty() && !o.from_run.empty()) o.scene_file = o.from_run + "/scene.toml";
  const bool from_file = !o.scene_file.empty();
  int code = 0;
  fs::path work;
  try {
    if (size != o.ranks)
      throw std::runtime_error("asked for " + std::to_string(o.ranks) + " MPI ranks, running on " +
                               std::to_string(size));
    hemo::Scene scene = from_file ? hemo::load_scene(o.scene_file) : blood_scene(o.diameter_um * 1e-6, o.length_um * 1e-6, o.hematocrit);
    if (!from_file) {
      if (o.closures == "paper") use_paper_closures(scene);
      scene.time.closure_every_dem_steps = o.closure_every;
    }
    if (!o.neighbour_rebuild.empty()) hemo::choice_named(o.neighbour_rebuild, scene.neighbour_rebuild);
    const bool streaming = scene.neighbour_rebuild == hemo::NeighbourRebuild::streaming;
    const double R = scene.vessel.diameter / 2, l = scene.vessel.length;
    const double interval = from_file ? scene.time.coupling_interval : 1e-5;
    const auto mesh = box_mesh(o.cells, o.cells, o.axial_cells, -R, R, -R, R, l, scene.vessel.diameter);
    const CellLocator locator(mesh);
    FluidSampler fluid(locator);
    fluid.set_state(with_poiseuille_stress(fluid_state(mesh, poiseuille(R, scene.driving.wall_shear_rate * R / 2)),
                                           scene));
    Deposition deposition(locator, make_solid_fraction_model(scene.solid_fraction, locator, scene.kernel_width_diameters));
    long pid = getpid();  // rank 0's: one folder for the job
    MPI_Bcast(&pid, 1, MPI_LONG, 0, comm);
    work = fs::temp_directory_path() / ("hemocosim-dem-bench-" + std::to_string(pid));
    if (rank == 0) fs::create_directories(work);
    MPI_Barrier(comm);
    DemEngine engine(scene, locator, (work / "liggghts.log").string(), comm, false, o.bookkeeping);
    double start_time_s = 0;
    const auto placed = o.from_run.empty() ? place_particles(R, l, 0, placement_requests(scene), 1)
                                           : particles_of_run(o.from_run, o.at_time, scene, &start_time_s);
    const double setup_s = timed(comm, [&] { engine.create_particles(placed); });
    const auto timing = derive_dem_timing(scene, interval);
    const long dem_steps = static_cast<long>(o.steps) * timing.substeps;
    const double particle_steps = static_cast<double>(placed.size()) * dem_steps;
    const auto ns = [&](double seconds) { return 1e9 * seconds / particle_steps; };
    const auto per_1000 = [&](long builds) { return 1000.0 * static_cast<double>(builds) / dem_steps; };

    // The node's DEM phase and its deposition phase, timed apart: the DEM is what bare LIGGGHTS
    // is compared with.
    std::string error;
    double intervals_s = 0, deposition_s = 0;
    for (int k = 1; k <= o.steps && error.empty(); ++k) {
      intervals_s += timed(comm, [&] { error = engine.run(k, timing.substeps, timing.dt, fluid); });
      deposition_s += timed(comm, [&] { engine.deposit(deposition); });
    }
    if (!error.empty()) throw std::runtime_error(error);
    // The callback's time summed over ranks, per rank: the part of each rank's wall time.
    const double intervals_callback_s = sum_over_ranks(comm, engine.take_fluid_force_seconds()) / size;
    const long intervals_builds = engine.neighbour_builds();
    const auto diag = engine.diagnostics(&fluid);
    const double one_run_s =
        timed(comm, [&] { error = engine.run(o.steps + 1, static_cast<int>(dem_steps), timing.dt, fluid); });
    if (!error.empty()) throw std::runtime_error(error);
    const double one_run_callback_s = sum_over_ranks(comm, engine.take_fluid_force_seconds()) / size;
    const long one_run_builds = engine.neighbour_builds() - intervals_builds;  // `pre no`: the count goes on

    nlohmann::json out = {
        {"scene", from_file ? o.scene_file : "synthetic calibration case"},
        {"particles", placed.size()},
        {"from_run", o.from_run},
        {"start_time_s", start_time_s},
        {"ranks", size},
        {"coupling_steps", o.steps},
        {"dem_substeps", timing.substeps},
        {"dem_step_s", timing.dt},
        {"closure_every_dem_steps", scene.time.closure_every_dem_steps},
        {"skin_diameters", o.bookkeeping.skin_diameters},
        {"sort_every_steps", o.bookkeeping.sort_every_steps},
        {"shuffled_tags", o.bookkeeping.shuffled_tags},
        {"mesh_wall", o.bookkeeping.mesh_wall},
        {"neighbour_rebuild", hemo::name_of(scene.neighbour_rebuild)},
        {"setup_s", setup_s},
        {"intervals", {{"ns_per_particle_step", ns(intervals_s)},
                       {"callback_ns", ns(intervals_callback_s)},
                       {"liggghts_ns", ns(intervals_s - intervals_callback_s)},
                       {"neighbour_builds", intervals_builds},
                       {"neighbour_builds_per_1000_steps", per_1000(intervals_builds)}}},
        {"deposition_ns", ns(deposition_s)},
        {"one_run", {{"ns_per_particle_step", ns(one_run_s)},
                     {"callback_ns", ns(one_run_callback_s)},
                     {"liggghts_ns", ns(one_run_s - one_run_callback_s)},
                     {"neighbour_builds", one_run_builds},
                     {"neighbour_builds_per_1000_steps", per_1000(one_run_builds)}}},
        {"max_overlap", diag.max_overlap},
        {"two_s_of_physics_min", intervals_s / (o.steps * interval) * 2 / 60},
    };
    if (o.floor) {
      const std::string data = (work / "particles.data").string();
      engine.liggghts("write_data " + data);
      const auto bare_json = [&](const BareRun& bare) {
        return nlohmann::json{{"ns_per_particle_step", ns(bare.seconds)},
                              {"neighbour_builds", bare.builds},
                              {"neighbour_builds_per_1000_steps", per_1000(bare.builds)},
                              {"particles", bare.particles}};
      };
      out["bare_liggghts"] = bare_json(run_bare_liggghts(engine.bare_liggghts_input(data, timing.dt, dem_steps),
                                                         (work / "bare-liggghts.log").string(), comm));
      if (streaming)
        out["bare_liggghts_streaming"] =
            bare_json(run_bare_liggghts(engine.bare_liggghts_input(data, timing.dt, dem_steps, true),
                                        (work / "bare-liggghts-streaming.log").string(), comm));
    }
    double peak = peak_rss_mib(), peak_max = 0;
    MPI_Allreduce(&peak, &peak_max, 1, MPI_DOUBLE, MPI_MAX, comm);
    out["peak_memory_MiB_per_rank"] = peak_max;

    if (rank == 0) {
      const auto& iv = out["intervals"];
      const auto& one = out["one_run"];
      if (!o.from_run.empty()) std::printf("particles of %s at t = %g s\n", o.from_run.c_str(), start_time_s);
      std::printf("%s: %zu particles on %d rank(s), %d coupling steps x %d DEM steps of %.3g s, closures every %d\n"
                  "  skin %.3g diameters, sort every %ld steps%s, neighbour lists rebuilt by the %s criterion, "
                  "wall %s\n",
                  out["scene"].get<std::string>().c_str(), placed.size(), size, o.steps, timing.substeps, timing.dt,
                  scene.time.closure_every_dem_steps, o.bookkeeping.skin_diameters, o.bookkeeping.sort_every_steps,
                  o.bookkeeping.shuffled_tags ? ", tags shuffled" : "", hemo::name_of(scene.neighbour_rebuild).c_str(),
                  o.bookkeeping.mesh_wall ? "a triangle mesh" : "zcylinder");
      std::printf("  in %d runs of one interval: %.1f ns per particle-step (callback %.1f, LIGGGHTS %.1f); %ld "
                  "neighbour-list builds (%.1f per 1000 steps)\n",
                  o.steps, iv["ns_per_particle_step"].get<double>(), iv["callback_ns"].get<double>(),
                  iv["liggghts_ns"].get<double>(), intervals_builds, per_1000(intervals_builds));
      std::printf("  deposition after each interval: %.1f ns per particle-step\n", out["deposition_ns"].get<double>());
      std::printf("  in one run:                %.1f ns per particle-step (callback %.1f, LIGGGHTS %.1f); %ld builds\n",
                  one["ns_per_particle_step"].get<double>(), one["callback_ns"].get<double>(),
                  one["liggghts_ns"].get<double>(), one_run_builds);
      const auto print_bare = [&](const char* what, const nlohmann::json& bare) {
        std::printf("  %-26s %.1f ns per particle-step; %ld builds (%.1f per 1000 steps); DEM / this = %.2f\n", what,
                    bare["ns_per_particle_step"].get<double>(), bare["neighbour_builds"].get<long>(),
                    bare["neighbour_builds_per_1000_steps"].get<double>(),
                    iv["ns_per_particle_step"].get<double>() / bare["ns_per_particle_step"].get<double>());
      };
      if (o.floor) print_bare("bare LIGGGHTS:", out["bare_liggghts"]);
      if (out.contains("bare_liggghts_streaming"))
        print_bare("bare, streaming criterion:", out["bare_liggghts_streaming"]);
      std::printf("  2 s of physics: %.1f min of DEM; peak memory %.1f MiB per rank; deepest overlap %.3g\n",
                  out["two_s_of_physics_min"].get<double>(), peak_max, diag.max_overlap);
      if (!o.json.empty()) std::ofstream(o.json) << out.dump(2) << "\n";
    }
  } catch (const std::exception& e) {
    if (rank == 0) std::cerr << "hemocosim-dem-bench: error: " << e.what() << "\n";
    code = 1;
  }
  if (rank == 0 && !work.empty()) fs::remove_all(work);
  MPI_Finalize();
  return code;
}
