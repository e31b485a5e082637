// SPDX-License-Identifier: GPL-3.0-or-later
// The particle engine on 1 or 2 MPI ranks (ctest runs this under mpirun -np 1 and -np 2): a few
// hundred cells with the paper's closures and contacts in Poiseuille flow. Every rank deposits
// its own atoms and the per-cell arrays are summed over ranks; the sum of the fluid forces on
// the particles must equal minus the sum of the sources the fluid gets, to round-off, the
// deposited solid volume the particles' volume, and the particles' momentum must change by
// exactly the fluid's impulse (nothing touches the wall in this short run).
#include "synthetic_case.h"
#include "cell_fields.h"
#include "dem_engine.h"
#include "cell_halo_sum.h"
#include "cell_plasma.h"
#include "dem_timing.h"
#include "overlap.h"

#include <gtest/gtest.h>
#include <mpi.h>
#include <traffic.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <utility>
#include <vector>

using namespace hemo::particles;
using namespace hemo::particles::synthetic;

namespace {

// A few hundred cells with the paper's closures in Poiseuille flow, within 0.7 R (local Ht 16 %):
// no wall contact in 0.2 ms; cell-cell contacts do happen.
struct PoiseuilleCase {
  static constexpr double R = 25e-6, L = 100e-6, interval = 1e-5;
  hemo::Scene scene;
  hemo::mesh_t mesh = wedge_mesh(16, 10, R, L, "mpi-wedge");
  CellLocator locator{mesh};
  FluidSampler fluid{locator};
  Deposition deposition{locator, make_solid_fraction_model("sphere_overlap", locator)};
  DemEngine engine;
  std::vector<PlacedParticle> placed;
  DemTiming timing;

  explicit PoiseuilleCase(hemo::Scene s)
      : scene(std::move(s)),
        engine(scene, locator, "none", MPI_COMM_WORLD),
        timing(derive_dem_timing(scene, interval)) {
    fluid.set_state(fluid_state(mesh, poiseuille(R, 799 * R / 2)));
    placed = place_particles(0.7 * R, L, 0, placement_requests(scene), 5);
    engine.create_particles(placed);
  }
  static hemo::Scene paper_scene() {
    auto s = blood_scene(2 * R, L, 0.08);
    use_paper_closures(s);
    return s;
  }
};

}  // namespace

TEST(ParticleEngineMpi, FluidForcesEqualMinusDepositedSourcesAndVolumeIsConserved) {
  int size = 1, rank = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  PoiseuilleCase pc(PoiseuilleCase::paper_scene());
  const double interval = pc.interval;
  const hemo::Scene& scene = pc.scene;
  const CellLocator& locator = pc.locator;
  const FluidSampler& fluid = pc.fluid;
  Deposition& deposition = pc.deposition;
  DemEngine& engine = pc.engine;
  const auto& placed = pc.placed;
  ASSERT_GT(placed.size(), 200u);
  double expected_volume = 0;
  for (const auto& p : placed) expected_volume += p.species == kRbc ? scene.rbc.volume : scene.platelet.volume;
  const DemTiming& timing = pc.timing;

  auto momentum = [&] {
    const auto s = engine.snapshot(0, 0);
    Vec3 p = Vec3::Zero();
    for (std::size_t i = 0; i < s.size(); ++i)
      p += (s.species[i] == kRbc ? scene.rbc.mass : scene.platelet.mass) *
           Vec3(s.velocity[3 * i], s.velocity[3 * i + 1], s.velocity[3 * i + 2]);
    return p;
  };
  Vec3 p_before = momentum();
  double worst_balance = 0, worst_momentum = 0;
  Vec3 last_force = Vec3::Zero();
  for (int step = 1; step <= 20; ++step) {
    ASSERT_EQ(engine.run(step, timing.substeps, timing.dt, fluid), "");
    engine.deposit(deposition);
    hemo::particle_feedback_t fb;
    deposition.finish(interval, &fluid, fb);
    const Vec3 force(fb.total_particle_force[0], fb.total_particle_force[1], fb.total_particle_force[2]);
    Vec3 back = Vec3::Zero();
    // scale: the size of the terms the fluid subtracts, S V and K u V (per cell S - K u is a
    // small difference of large terms: particles move nearly with the plasma)
    double solid = 0, scale = 0;
    for (int c = 0; c < fb.n_cells; ++c) {
      const Vec3 s = Eigen::Map<const Vec3>(hemo::source_of(fb, c));
      const Vec3 cell_back = (s - fb.drag_coefficient[c] * fluid.cell_velocity(c)) * locator.volume(c);
      back += cell_back;
      scale += (s.norm() + fb.drag_coefficient[c] * fluid.cell_velocity(c).norm()) * locator.volume(c);
      solid += fb.solid_fraction[c] * locator.volume(c);
    }
    worst_balance = std::max(worst_balance, (force + back).norm() / scale);
    EXPECT_NEAR(solid, expected_volume, 1e-12 * expected_volume) << "step " << step;
    const Vec3 p_after = momentum();
    worst_momentum = std::max(worst_momentum, (p_after - p_before - force * interval).norm() / p_after.norm());
    p_before = p_after;
    last_force = force;
  }
  if (rank == 0)
    std::printf(
        "[ info ] %d rank(s), %zu particles, %d substeps: |sum F + sum (S - K u) V| / sum (|S| + K |u|) V <= %.2e, "
        "|dp - impulse| / |p| <= %.2e, total force z %.10e N\n",
        size, placed.size(), timing.substeps, worst_balance, worst_momentum, last_force.z());
  EXPECT_LT(worst_balance, 1e-12);
  EXPECT_LT(worst_momentum, 1e-11);
  // Each rank holds some of the particles (LIGGGHTS splits the vessel along z).
  EXPECT_GT(engine.local_particle_count(), 0) << "rank " << rank;
  EXPECT_LT(engine.local_particle_count(), static_cast<long>(placed.size()) + (size == 1 ? 1 : 0)) << "rank " << rank;
  const auto d = engine.diagnostics(&fluid);
  EXPECT_EQ(d.particles, static_cast<long>(placed.size()));
  EXPECT_EQ(d.lost, 0);
  EXPECT_EQ(d.outside_mesh, 0);
  // Every rank sees the same, complete snapshot (ids 1..N, unit quaternions).
  const auto snap = engine.snapshot(20, 20 * interval);
  ASSERT_EQ(snap.orientation.size(), 4 * snap.size());
  for (std::size_t i = 0; i < snap.size(); ++i) {
    const Eigen::Map<const Eigen::Vector4d> q(&snap.orientation[4 * i]);
    EXPECT_NEAR(q.norm(), 1.0, 1e-12) << "particle " << snap.id[i];
  }
}

// The diagnostics' largest speed and overlap, and a run's largest Reynolds numbers and shortest
// relaxation time, are maxima (minima) over every rank's particles, taken in one reduction each:
// the speed is the snapshot's largest to the last bit, the overlap what a grid of all particles
// finds, and every rank holds the same values. A crossflow drives the cells against the wall and
// each other, so that there are overlaps to find.
TEST(ParticleEngineMpi, TheLargestSpeedAndOverlapAreTheWholeNodes) {
  PoiseuilleCase pc(PoiseuilleCase::paper_scene());
  const FieldAt crossflow = [](const std::array<double, 3>&, std::array<double, 3>& u, std::array<double, 9>& g) {
    u = {5e-2, 0, 0};
    g.fill(0.0);
  };
  pc.fluid.set_state(fluid_state(pc.mesh, crossflow));
  double largest_overlap = 0;
  for (int step = 1; step <= 20; ++step) {
    ASSERT_EQ(pc.engine.run(step, pc.timing.substeps, pc.timing.dt, pc.fluid), "");
    const EngineDiagnostics d = pc.engine.diagnostics(&pc.fluid);
    const ParticleSnapshot s = pc.engine.snapshot(step, step * pc.interval);
    double speed = 0;
    std::vector<Vec3> x(s.size());
    std::vector<double> diameters(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
      speed = std::max(speed, Vec3(s.velocity[3 * i], s.velocity[3 * i + 1], s.velocity[3 * i + 2]).norm());
      x[i] = Vec3(s.position[3 * i], s.position[3 * i + 1], s.position[3 * i + 2]);
      diameters[i] = s.species[i] == kRbc ? pc.scene.rbc.diameter : pc.scene.platelet.diameter;
    }
    EXPECT_EQ(d.max_speed, speed) << "step " << step;
    const double reference = measure_overlaps(x, diameters, PoiseuilleCase::R, PoiseuilleCase::L, 0).max_relative;
    EXPECT_NEAR(d.max_overlap, reference, 1e-9 * reference + 1e-15) << "step " << step;
    largest_overlap = std::max(largest_overlap, reference);
    // The same on every rank: the lowest and the highest over the ranks agree.
    double values[4] = {d.max_speed, d.max_overlap, pc.engine.max_reynolds(kRbc), pc.engine.min_relaxation_time()};
    double low[4], high[4];
    MPI_Allreduce(values, low, 4, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(values, high, 4, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(low[k], high[k]) << "value " << k << ", step " << step;
    EXPECT_GT(pc.engine.max_reynolds(kRbc), 0);
    EXPECT_GT(pc.engine.min_relaxation_time(), 0);
  }
  EXPECT_GT(largest_overlap, 0);  // the comparison saw contacts
}

// coupling.implicit_drag = "co_relaxed" across ranks: every rank must see the same plasma
// answer in every cell (its particles' drag summed over the ranks at each DEM step), and the
// plasma must lose exactly what the particles gained from it over the run: the sum over cells of
// M_c shift_c equals minus the interval's deposited impulse, to round-off.
TEST(ParticleEngineMpi, CoRelaxedPlasmaIsTheSameOnEveryRankAndConservesMomentum) {
  auto scene = PoiseuilleCase::paper_scene();
  scene.implicit_drag = hemo::ImplicitDrag::co_relaxed;
  scene.time.mass_scaling = 10;  // the cells' mass near their cells' plasma: a large answer
  PoiseuilleCase pc(scene);
  const CellLocator& locator = pc.locator;
  ASSERT_EQ(pc.engine.run(1, pc.timing.substeps, pc.timing.dt, pc.fluid), "");
  const CellPlasmaRelaxation* plasma = pc.engine.cell_plasma();
  ASSERT_NE(plasma, nullptr);
  Vec3 answer = Vec3::Zero();
  double scale = 0;
  for (int c = 0; c < locator.n_cells(); ++c) {
    answer += plasma->plasma_mass(c) * plasma->shift(c);
    scale += plasma->plasma_mass(c) * plasma->shift(c).norm();
  }
  pc.engine.deposit(pc.deposition);
  const Vec3 impulse = pc.deposition.total_force(pc.interval) * pc.interval;
  EXPECT_GT(scale, 0);
  EXPECT_LT((answer + impulse).norm(), 1e-12 * scale)
      << "plasma " << answer.transpose() << ", particles " << impulse.transpose();
  double lo[3] = {answer.x(), answer.y(), answer.z()}, hi[3] = {answer.x(), answer.y(), answer.z()};
  MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(lo[k], hi[k]) << "component " << k;
}

namespace {

// Rank p of `ranks` needs a slab of `cells` cells and one cell either side, cyclically; the
// overlap map of those needs, all from fluid rank 0 (the halo sum's tests).
bool slab_needs(int cells, int ranks, int p, int c) {
  const int lo = p * cells / ranks - 1, hi = (p + 1) * cells / ranks;  // [lo, hi], cyclic
  for (int k = lo; k <= hi; ++k)
    if ((k + cells) % cells == c) return true;
  return false;
}
hemo::OverlapMap slab_overlap(int cells, int ranks) {
  hemo::OverlapMap map;
  map.from.resize(static_cast<std::size_t>(ranks));
  for (int p = 0; p < ranks; ++p)
    for (int c = 0; c < cells; ++c)
      if (slab_needs(cells, ranks, p, c)) map.from[static_cast<std::size_t>(p)][0].push_back(c);
  return map;
}

}  // namespace

// The co-relaxation's sums over the ranks sharing each cell (CellPlasmaRelaxation::relax with a
// CellHaloSum) move every cell a rank takes exactly as the whole-mesh all-reduce does, on every
// rank that takes it (the same slabs as above; integer impulses, so that any order of adding
// gives the same bits), and a step's bytes are 32 B a shared cell and peer, whatever the mesh:
// the all-reduce moved 32 B for every cell of it.
TEST(CellHaloSum, TheCoRelaxedPlasmaMovesAsWithTheWholeMeshAllReduce) {
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  constexpr int kCells = 24;
  auto needs = [&](int p, int c) { return slab_needs(kCells, ranks, p, c); };
  const hemo::OverlapMap map = slab_overlap(kCells, ranks);
  const CellHaloSum halo(map, rank, MPI_COMM_WORLD);
  CellPlasmaRelaxation with_halo(kCells), whole(kCells);
  for (CellPlasmaRelaxation* plasma : {&with_halo, &whole})
    for (int c = 0; c < kCells; ++c) plasma->set_plasma_mass(c, 64.0 + c);
  hemo::RankTraffic::take();
  std::uint64_t halo_bytes = 0;
  for (int step = 0; step < 3; ++step) {
    // Each rank's particles in every other cell it takes (a few cells of its own untouched).
    for (int c = 0; c < kCells; ++c)
      if (needs(rank, c) && (c + step + rank) % 2 == 0)
        for (CellPlasmaRelaxation* plasma : {&with_halo, &whole})
          plasma->add(c, Vec3(1.0 + rank, -2.0 * step, 3.0), 2.0 + c % 3);
    with_halo.relax(&halo, MPI_COMM_WORLD);
    halo_bytes += hemo::RankTraffic::take().halo;
    whole.relax(nullptr, MPI_COMM_WORLD);
    hemo::RankTraffic::take();
    for (int c = 0; c < kCells; ++c) {
      if (!needs(rank, c)) continue;
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(with_halo.shift(c)[k], whole.shift(c)[k]) << "cell " << c << ", step " << step;
      }
    }
  }
  EXPECT_EQ(halo_bytes, 3 * halo.bytes(4));
  std::uint64_t shared = 0;  // cells shared, once per peer
  for (int p = 0; p < ranks; ++p)
    if (p != rank)
      for (int c = 0; c < kCells; ++c) shared += needs(rank, c) && needs(p, c);
  EXPECT_EQ(halo.bytes(4), 32 * shared);
  if (ranks > 1) {
    EXPECT_GT(shared, 0u);
  }
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank != 0) {  // one rank reports
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int result = RUN_ALL_TESTS();
  MPI_Finalize();
  return result;
}

// The unwrapped z (ParticleTracking) stays continuous while cells stream through the periodic end
// and from one rank's slab to the other's (LIGGGHTS splits the vessel along z): a rank hands on
// the records of the cells it no longer has, and the rank that has them takes them. A record
// left behind would jump a cell's unwrapped z by a period at its next crossing. Checked on every
// snapshot of a flow fast enough that the cells cross the period several times.
TEST(ParticleEngineMpi, UnwrappedZIsContinuousWhileCellsChangeRanksAndCrossThePeriod) {
  int size = 1, rank = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  PoiseuilleCase pc(PoiseuilleCase::paper_scene());
  const double u_max = 0.4;  // m/s: 4 um, a 25th of the period, per interval at the axis
  pc.fluid.set_state(fluid_state(pc.mesh, poiseuille(PoiseuilleCase::R, u_max)));
  auto before = pc.engine.snapshot(0, 0);
  const long n = static_cast<long>(before.size());
  long crossings = 0, moved = 0;
  const long local_at_start = pc.engine.local_particle_count();
  long local_changed = 0;
  for (int step = 1; step <= 60; ++step) {
    ASSERT_EQ(pc.engine.run(step, pc.timing.substeps, pc.timing.dt, pc.fluid), "");
    const auto after = pc.engine.snapshot(step, step * pc.interval);
    ASSERT_EQ(static_cast<long>(after.size()), n);
    for (long i = 0; i < n; ++i) {
      ASSERT_EQ(after.id[i], before.id[i]);
      const double z0 = before.position[3 * i + 2], z1 = after.position[3 * i + 2];
      // At most the axis's speed for an interval, and never backwards by much.
      EXPECT_LT(std::abs(z1 - z0), 1.5 * u_max * pc.interval) << "particle " << after.id[i] << " at step " << step;
      crossings += std::floor(z1 / PoiseuilleCase::L) != std::floor(z0 / PoiseuilleCase::L);
      moved += z1 > z0;
    }
    local_changed += pc.engine.local_particle_count() != local_at_start;
    before = after;
  }
  long changed_anywhere = local_changed;
  MPI_Allreduce(MPI_IN_PLACE, &changed_anywhere, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  if (rank == 0)
    std::printf("[ info ] %d rank(s), %ld particles, 60 intervals: %ld crossings of the period\n", size, n, crossings);
  EXPECT_GT(crossings, n);  // each cell about twice on average
  if (size > 1) {
    EXPECT_GT(changed_anywhere, 0) << "no cell changed ranks: the test would not test the hand-over";
  }
}

// The partitioned exchange's halo sum (cell_halo_sum.h): 12 cells, rank p of P needs a slab of
// them and one cell either side (cyclically), and holds values only there. After the sum every
// cell it needs holds the sum over every rank that needs it (exact: integers), the cells it does
// not need are untouched, and two ranks sharing a cell hold the same bits (fractions this time).
TEST(CellHaloSum, EachRankGetsTheSumOverTheRanksSharingItsCellsAndNoOther) {
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  constexpr int kCells = 12;
  auto needs = [&](int p, int c) { return slab_needs(kCells, ranks, p, c); };
  const hemo::OverlapMap map = slab_overlap(kCells, ranks);
  const CellHaloSum halo(map, rank, MPI_COMM_WORLD);

  std::vector<double> values(2 * kCells, -1.0);  // two values a cell; -1 where not needed
  for (int c = 0; c < kCells; ++c)
    if (needs(rank, c)) {
      values[2 * c] = 100.0 * (rank + 1) + c;
      values[2 * c + 1] = 1.0 / (3.0 + rank + c);
    }
  halo.sum(values, 2);
  std::vector<double> all(static_cast<std::size_t>(ranks) * values.size());
  MPI_Allgather(values.data(), static_cast<int>(values.size()), MPI_DOUBLE, all.data(),
                static_cast<int>(values.size()), MPI_DOUBLE, MPI_COMM_WORLD);
  for (int c = 0; c < kCells; ++c) {
    if (!needs(rank, c)) {
      EXPECT_EQ(values[2 * c], -1.0) << "cell " << c;
      continue;
    }
    double want = 0;
    for (int p = 0; p < ranks; ++p)
      if (needs(p, c)) want += 100.0 * (p + 1) + c;
    EXPECT_EQ(values[2 * c], want) << "cell " << c;
    for (int p = 0; p < ranks; ++p) {
      if (!needs(p, c)) continue;
      EXPECT_EQ(all[static_cast<std::size_t>(p) * values.size() + 2 * c + 1], values[2 * c + 1])
          << "cell " << c << " on ranks " << rank << " and " << p;
    }
  }
  EXPECT_EQ(halo.shared().empty(), ranks == 1);
}
