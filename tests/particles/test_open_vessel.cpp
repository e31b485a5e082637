// SPDX-License-Identifier: GPL-3.0-or-later
// The particle node in an open vessel fed by a feeder (docs/design.md, "Open ends"), without the
// bus, on the real two-region mesh of the fluid node: a flow through both tubes carries cells out
// through the outlet and copies of the feeder's cells in through the inlet. At every step the
// cells present are those created plus those inserted minus those that left; the snapshots hold
// the vessel's cells only, each tag once, none past the outlet, and tags freed at the outlet are
// given again; a node resumed from a checkpoint goes on bit for bit as the node that wrote it,
// its counts included. A single cell's volume crosses each end over the steps its sphere (or
// kernel) takes to cross it, not in one, its centre counted as it crosses. On one rank and on two
// (ctest particles.OpenVessel.ranks2).
#include "checkpoint_case.h"
#include "dem_engine.h"
#include "dem_timing.h"
#include "deposition.h"

#include <solid_fraction_names.h>
#include <vessel_ends.h>
#include <vessel_mesh.h>

#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

using namespace hemo::particles;
using namespace hemo::particles::testing;
namespace fs = std::filesystem;

namespace {

constexpr double kD = 50e-6, kL = 100e-6;
constexpr double kPlug = 0.1;  // m/s: a cell crosses the vessel in 100 coupling steps

hemo::Scene open_scene() {
  auto scene = synthetic::blood_scene(kD, kL, 0.15);
  synthetic::use_paper_closures(scene);
  scene.time.closure_every_dem_steps = 3;  // held closures: a copy's name the vessel's cell
  scene.vessel.ends = "open";
  scene.mesh.core_cells = 4;
  scene.mesh.ring_cells = 2;
  scene.mesh.axial_cells = 4;  // 25 um layers: the feeder is 2 longer (150 um)
  return scene;
}

hemo::mesh_t mesh_of(const hemo::Scene& scene) {
  const auto poly = hemo::make_vessel_mesh(scene.vessel, scene.mesh);
  hemo::mesh_t message;
  hemo::fill_mesh_message(poly, hemo::compute_geometry(poly), scene.vessel, message);
  return message;
}

// A plug flow with Poiseuille flow on it, in each tube about its own axis.
synthetic::FieldAt through_both_tubes(const hemo::FeederLayout& feeder) {
  const synthetic::FieldAt shear = synthetic::poiseuille(kD / 2, 0.05);
  return [=](const std::array<double, 3>& x, std::array<double, 3>& u, std::array<double, 9>& g) {
    const Vec3 local = feeder.in_vessel_frame(Vec3(x[0], x[1], x[2]));
    shear({local.x(), local.y(), local.z()}, u, g);
    u[2] += kPlug;
  };
}

using Diagnostic = std::map<std::string, double>;
Diagnostic diagnostic(ParticleNode& node) {
  Diagnostic d;
  for (const auto& [name, value] : node.diagnostics()) d[name] = value;
  return d;
}

long left_and_entered(const Diagnostic& d, const char* what) {
  return static_cast<long>(d.at(std::string("rbc_") + what) + d.at(std::string("platelet_") + what));
}

}  // namespace

TEST(OpenVessel, CountsBalanceAtEveryStepAndTheCellsFlowThrough) {
  const auto scene = open_scene();
  const auto feeder = hemo::feeder_layout(scene);
  const auto mesh = mesh_of(scene);
  const auto fluid = synthetic::fluid_state(mesh, through_both_tubes(feeder));
  const fs::path dir = checkpoint_case::shared_dir("hemo_open_vessel");
  ParticleNode node(scene, mesh, dir.string(), MPI_COMM_WORLD);
  const Diagnostic start = diagnostic(node);
  const long created = static_cast<long>(start.at("particles"));
  EXPECT_EQ(left_and_entered(start, "inserted"), 0);
  EXPECT_GT(created, static_cast<long>(start.at("particles_in_vessel")));  // the feeder has its own

  const std::string h5 = (dir / "particles.h5").string();
  std::map<long, std::set<std::int64_t>> ids;  // the vessel's tags per step
  const long steps = 130;
  for (long k = 1; k <= steps; ++k) {
    const auto o = checkpoint_case::order(k);
    ASSERT_EQ(node.check(fluid), "");
    ASSERT_EQ(node.advance(o, fluid), "") << "step " << k;
    node.write_output(node.step(), node.time());
    const Diagnostic d = diagnostic(node);
    const long inserted = left_and_entered(d, "inserted"), out = left_and_entered(d, "left_outlet"),
               back = left_and_entered(d, "left_inlet");
    EXPECT_EQ(static_cast<long>(d.at("particles")), created + inserted - out - back) << "step " << k;
    EXPECT_EQ(d.at("particles_lost"), 0) << "step " << k;

    if (checkpoint_case::world_rank() != 0) continue;  // the first rank writes, and holds, particles.h5
    const auto snap = read_snapshot(h5, k);
    EXPECT_EQ(static_cast<double>(snap.size()), d.at("particles_in_vessel")) << "step " << k;
    for (std::size_t i = 0; i < snap.size(); ++i) {
      EXPECT_TRUE(ids[k].insert(snap.id[i]).second) << "tag " << snap.id[i] << " twice at step " << k;
      const double x = snap.position[3 * i], z = snap.position[3 * i + 2];
      EXPECT_LT(x, feeder.split_x) << "a feeder cell written at step " << k;
      EXPECT_GE(z, 0.0) << "tag " << snap.id[i] << " before the inlet at step " << k;
      EXPECT_LT(z, kL) << "tag " << snap.id[i] << " past the outlet at step " << k;
    }
  }
  const Diagnostic end = diagnostic(node);
  std::printf("[ info ] %ld created; by step %ld: %ld inserted (%g RBC), %ld left through the outlet, %ld back\n",
              created, steps, left_and_entered(end, "inserted"), end.at("rbc_inserted"),
              left_and_entered(end, "left_outlet"), left_and_entered(end, "left_inlet"));
  // The plug carries every vessel cell past the outlet within the run, and the feeder's in.
  EXPECT_GT(end.at("rbc_inserted"), 0);
  EXPECT_GT(end.at("platelet_inserted"), 0);
  EXPECT_GT(end.at("rbc_left_outlet"), 0);
  EXPECT_GT(end.at("platelet_left_outlet"), 0);
  EXPECT_EQ(left_and_entered(end, "left_inlet"), 0);  // nothing flows back
  if (checkpoint_case::world_rank() != 0) return;
  std::set<std::int64_t> reused;  // tags in the vessel at step 1, gone, and in it again
  for (const auto id : ids[1])
    for (long a = 2; a < steps && !reused.count(id); ++a)
      if (!ids[a].count(id))
        for (long b = a + 1; b <= steps && !reused.count(id); ++b)
          if (ids[b].count(id)) reused.insert(id);
  EXPECT_FALSE(reused.empty()) << "no tag freed at the outlet was given again";
  fs::remove_all(dir);
}

TEST(OpenVessel, ResumedNodeGoesOnBitForBitWithItsCounts) {
  const auto scene = open_scene();
  const auto feeder = hemo::feeder_layout(scene);
  const auto mesh = mesh_of(scene);
  const auto fluid = synthetic::fluid_state(mesh, through_both_tubes(feeder));
  const long K = 40, N = 8;  // by step 40 cells have left and entered
  const fs::path a_dir = checkpoint_case::shared_dir("hemo_open_a"), b_dir = checkpoint_case::shared_dir("hemo_open_b");
  std::map<long, hemo::particle_feedback_t> written;
  std::map<long, Diagnostic> counted;
  {
    ParticleNode node(scene, mesh, a_dir.string(), MPI_COMM_WORLD);
    for (long k = 1; k <= K + N; ++k) {
      const auto o = checkpoint_case::order(k);
      ASSERT_EQ(node.advance(o, fluid), "") << "step " << k;
      written[k] = node.feedback();
      node.write_output(node.step(), node.time());
      if (k == K) node.write_checkpoint();
      counted[k] = diagnostic(node);
    }
  }
  EXPECT_GT(counted[K].at("rbc_inserted"), 0);
  EXPECT_GT(counted[K].at("rbc_left_outlet"), 0);
  EXPECT_GT(counted[K + N].at("rbc_inserted"), counted[K].at("rbc_inserted"));
  if (checkpoint_case::world_rank() == 0) fs::copy(a_dir, b_dir, fs::copy_options::recursive);
  MPI_Barrier(MPI_COMM_WORLD);
  ParticleNode resumed(scene, mesh, b_dir.string(), MPI_COMM_WORLD, K);
  checkpoint_case::expect_same_feedback(resumed.feedback(), written[K], K);
  resumed.diagnostics();
  const std::string a_h5 = (a_dir / "particles.h5").string(), b_h5 = (b_dir / "particles.h5").string();
  for (long k = K + 1; k <= K + N; ++k) {
    const auto o = checkpoint_case::order(k);
    ASSERT_EQ(resumed.advance(o, fluid), "") << "step " << k;
    checkpoint_case::expect_same_feedback(resumed.feedback(), written[k], k);
    resumed.write_output(resumed.step(), resumed.time());
    if (checkpoint_case::world_rank() == 0) checkpoint_case::expect_same_snapshot(a_h5, b_h5, k);
    const Diagnostic d = diagnostic(resumed);
    for (const char* count : {"particles", "rbc_inserted", "platelet_inserted", "rbc_left_outlet",
                              "platelet_left_outlet", "rbc_left_inlet", "platelet_left_inlet"})
      EXPECT_EQ(d.at(count), counted[k].at(count)) << count << " at step " << k;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  if (checkpoint_case::world_rank() == 0) {
    fs::remove_all(a_dir);
    fs::remove_all(b_dir);
  }
}

namespace {

// A thin open tube in cubes of about 2.5 um (narrower than a red cell, as a Gaussian kernel
// carries them), one red cell on its axis 8 um short of the outlet and one on the feeder's axis
// 30 um short of its end, in a plug flow of kU: the first leaves, then the second's copy enters.
// Each coupling step: the solid volume deposited in the vessel's cells, whether each is in the
// vessel (its centre inside, as the snapshot says) and the counts.
constexpr double kThinD = 24e-6, kThinL = 40e-6, kU = 0.02;
struct Crossing {
  std::vector<double> solid;   // m^3, the vessel's cells' sum of phi V
  std::vector<double> total;   // m^3, every cell's (the feeder's too)
  std::vector<double> inside;  // m^3, the particles' volume inside the ends (particles_volume_inside_m3)
  std::vector<long> in_vessel, left, inserted, straddling, present;
  // N s along z, every cell's: the co-relaxed plasma's momentum at the interval's end (sum of
  // M_c shift_c) and the particles' fluid impulse deposited (what the fluid is handed)
  std::vector<double> plasma_momentum, deposited_impulse;
  double volume = 0, step_length = 0, diameter = 0;
};

// How the crossing is run: the plug flow's speed and how far short of the outlet the leaving
// cell starts (m), and the plasma's answer to the drag.
struct CrossingRun {
  double u = kU, leaving_short = 8e-6;
  hemo::ImplicitDrag implicit_drag = hemo::ImplicitDrag::interval_response;
};

Crossing cross_both_ends(const std::string& solid_fraction, int steps, const CrossingRun& how = {}) {
  auto scene = synthetic::blood_scene(kThinD, kThinL, 0.15);
  synthetic::use_paper_closures(scene);
  scene.vessel.ends = "open";
  scene.mesh.core_cells = 4;
  scene.mesh.ring_cells = 2;
  scene.mesh.axial_cells = 16;  // 2.5-um layers
  scene.solid_fraction = solid_fraction;
  scene.implicit_drag = how.implicit_drag;
  const auto feeder = hemo::feeder_layout(scene);
  const auto mesh = mesh_of(scene);
  const CellLocator locator(mesh, hemo::make_vessel_wall(scene.vessel), feeder);
  FluidSampler fluid(locator);
  fluid.set_state(synthetic::fluid_state(mesh, [&how](const std::array<double, 3>&, std::array<double, 3>& u,
                                                      std::array<double, 9>& g) {
    u = {0, 0, how.u};
    g.fill(0);
  }));
  Deposition deposition(locator, make_solid_fraction_model(solid_fraction, locator, scene.kernel_width_diameters));
  fluid.read_over(&deposition.model());
  const double interval = 1e-5;
  const DemTiming timing = derive_dem_timing(scene, interval);
  const std::string log = (fs::temp_directory_path() / ("hemo_crossing_" + std::to_string(::getpid()) + ".log")).string();
  DemEngine engine(scene, locator, log, MPI_COMM_WORLD);
  const double d = scene.rbc.diameter;
  engine.create_particles({PlacedParticle{kRbc, d, Vec3(0, 0, kThinL - how.leaving_short)},
                           PlacedParticle{kRbc, d, Vec3(feeder.axis_x, 0, feeder.period - 30e-6)}});
  Crossing c;
  c.volume = scene.rbc.volume;
  c.step_length = how.u * interval;
  c.diameter = d;
  for (int k = 0; k <= steps; ++k) {
    if (k > 0) {
      EXPECT_EQ(engine.run(k, timing.substeps, timing.dt, fluid), "") << "step " << k;
    }
    if (const CellPlasmaRelaxation* plasma = engine.cell_plasma()) {
      double momentum = 0;  // before deposit(), which sets the next interval's plasma masses
      for (int cell = 0; cell < locator.n_cells(); ++cell) momentum += plasma->plasma_mass(cell) * plasma->shift(cell).z();
      c.plasma_momentum.push_back(momentum);
    }
    engine.deposit(deposition);
    double impulse = 0;
    for (int cell = 0; cell < locator.n_cells(); ++cell) impulse += deposition.data()[cell * Deposition::kStride + 2];
    c.deposited_impulse.push_back(impulse);
    double solid = 0;
    for (int cell = 0; cell < locator.n_cells(); ++cell)
      if (!feeder.in_feeder(locator.centre(cell).x())) solid += deposition.solid_volume(cell);
    const EngineDiagnostics diag = engine.diagnostics(&fluid);
    const auto counts = engine.end_counts();
    c.solid.push_back(solid);
    c.total.push_back(deposition.total_volume());
    c.inside.push_back(diag.volume_inside);
    c.in_vessel.push_back(diag.in_vessel);
    c.left.push_back(counts.left_outlet[kRbc]);
    c.inserted.push_back(counts.inserted[kRbc]);
    c.straddling.push_back(diag.straddling);
    c.present.push_back(engine.particle_count());
  }
  fs::remove(log);
  return c;
}

}  // namespace

// The cell leaving: from the step its sphere (or kernel) first reaches past the outlet plane the
// vessel's cells hold only the share of it inside, which falls to 0 over the steps it takes to
// move its reach twice; the feeder's cell's copy enters the same way from 0. So the solid volume in
// the vessel's cells changes by at most about V_p (U dt / d) a step (1.5 of that for the sphere's
// cap at its steepest, 0.94 for the kernel's Gaussian of one diameter), where the cells handed
// over the step their centres crossed took or gave V_p at once. All along it is the particles'
// volume inside the ends (particles_volume_inside_m3) to round-off; a cell is in the vessel (in
// its count and snapshot) from the step its centre crosses the inlet to the step it crosses the
// outlet, counted then.
TEST(OpenVessel, ASingleCellsVolumeCrossesEachEndOverManyStepsAndItsCentreIsCounted) {
  for (const std::string model : {"sphere_overlap", "gaussian_kernel"}) {
    SCOPED_TRACE(model);
    const int steps = 200;  // 40 um at 0.2 um a step
    const Crossing c = cross_both_ends(model, steps);
    const double V = c.volume;
    EXPECT_NEAR(c.solid.front(), V, 1e-12 * V) << "the leaving cell wholly inside at the start";
    EXPECT_NEAR(c.solid.back(), V, 1e-12 * V) << "the entering copy wholly inside at the end";
    double largest = 0;
    int partial = 0;
    for (int k = 0; k <= steps; ++k) {
      EXPECT_NEAR(c.total[k], c.inside[k], 1e-12 * V) << "step " << k;
      if (k > 0) largest = std::max(largest, std::abs(c.solid[k] - c.solid[k - 1]));
      partial += c.solid[k] > 1e-9 * V && c.solid[k] < (1 - 1e-9) * V;
      // The centre-crossing counts: the leaving cell is in the vessel until it is counted out,
      // the copy from when it is counted in.
      EXPECT_EQ(c.in_vessel[k], (c.left[k] == 0 ? 1 : 0) + c.inserted[k]) << "step " << k;
      EXPECT_EQ(c.present[k], 2 + c.inserted[k] - c.left[k]) << "step " << k;
      // Straddling: the leaving cell counted out and the copy not yet counted in, while in the DEM.
      EXPECT_LE(c.straddling[k], 1) << "step " << k;
    }
    EXPECT_EQ(c.left.back(), 1);
    EXPECT_EQ(c.inserted.back(), 1);
    const double smooth = V * c.step_length / c.diameter;
    std::printf("[ info ] %s: largest one-step change of the vessel's solid volume %.3g V_p = %.2f V_p (U dt / d); "
                "%d steps partly inside; handed over at once it was 1 V_p\n",
                model.c_str(), largest / V, largest / smooth, partial);
    EXPECT_LT(largest, 2 * smooth);
    // Both crossings: a sphere's 2 d at U dt, a kernel's reach twice, each over many steps.
    EXPECT_GT(partial, 2 * 0.8 * c.diameter / c.step_length);
  }
}

// coupling.implicit_drag = "co_relaxed" with a cell straddling an end: the plasma inside answers
// only the share of its drag that the fluid is handed (the share inside the end's plane; the rest
// is the plasma's beyond the end). A red cell from rest, its centre on the outlet's plane (half of
// it inside), in a slow plug flow: over one interval it moves 1 nm, a ten-thousandth of its
// kernel's reach, so the share the plasma answers at each DEM step and the share the deposit takes
// at the interval's end agree to about that (measured 2.4e-4 of the impulse), and the plasma's
// momentum gained is what the deposited impulse says the cells took from it. With the whole drag
// the straddling cell's part was twice that: the sum off by a third, the feeder's cell included.
TEST(OpenVessel, CoRelaxedPlasmaTakesAStraddlingCellsInsideShareOfItsDrag) {
  CrossingRun how;
  how.u = 1e-4;
  how.leaving_short = 0;
  how.implicit_drag = hemo::ImplicitDrag::co_relaxed;
  const Crossing c = cross_both_ends("gaussian_kernel", 1, how);
  ASSERT_EQ(c.plasma_momentum.size(), 2u);
  const double impulse = c.deposited_impulse[1], momentum = c.plasma_momentum[1];
  std::printf("[ info ] deposited impulse %.4g N s, the plasma's momentum %.4g N s\n", impulse, momentum);
  EXPECT_GT(impulse, 0.0) << "the flow drags the cell along";
  EXPECT_NEAR(momentum, -impulse, 1e-3 * impulse);
}

// The box's gap past the vessel holds the cells straddling the outlet and the inlet and a pair's
// reach between them: the thin tube's 25-um gap holds a kernel one diameter wide (2 x 7.1 um of
// straddling and 7.1 um of pair and skin) and refuses one 1.5 diameters wide (2 x 10.6 um and
// 7.1 um), in one line naming both.
TEST(OpenVessel, AFeederTooShortForTheCellsStraddlingItsEndsIsRefused) {
  for (const double width : {1.0, 1.5}) {
    auto scene = synthetic::blood_scene(kThinD, kThinL, 0.15);
    scene.vessel.ends = "open";
    scene.mesh.core_cells = 4;
    scene.mesh.ring_cells = 2;
    scene.mesh.axial_cells = 16;
    scene.solid_fraction = "gaussian_kernel";
    scene.kernel_width_diameters = width;
    const auto feeder = hemo::feeder_layout(scene);
    const auto mesh = mesh_of(scene);
    const CellLocator locator(mesh, hemo::make_vessel_wall(scene.vessel), feeder);
    DemEngine engine(scene, locator, "none", MPI_COMM_WORLD);
    const std::vector<PlacedParticle> cell = {PlacedParticle{kRbc, scene.rbc.diameter, Vec3(0, 0, kThinL / 2)}};
    if (width == 1.0) {
      EXPECT_NO_THROW(engine.create_particles(cell));
      continue;
    }
    try {
      engine.create_particles(cell);
      ADD_FAILURE() << "a 25-um gap taken for cells straddling 10.6 um past each end";
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("straddling the outlet and the inlet"), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }
}
