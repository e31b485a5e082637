// A coupled run in a stenosed vessel (model/geometry.h): the real nodes over real LCM, the DEM's
// wall a LIGGGHTS mesh from the same shape as the fluid mesh. Nothing is lost, nothing crosses
// the wall.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_helpers.h"

#include <geometry.h>
#include <scene.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

using namespace hemo::test;

// 20 coupling steps of the small stenosis scene: every snapshot holds every particle placed (the
// same ids), the node reports none lost and its count unchanged each step; every particle's
// centre is inside the wall and its sphere overlaps the shape's wall (its signed distance + radius) by at most run.max_overlap of
// its diameter, the guard the run itself keeps; the throat holds particles; the DEM's wall file
// is the mesh the node wrote.
TEST(StenosisRun, ConservesParticlesAndKeepsThemInsideTheWall) {
  const std::string dir = fresh_run_dir("stenosis-small");
  const auto r = run(bin("hemocosim") + " run " + scene("stenosis_small.toml") + " --out " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir + "/vessel_wall.stl"));
  const hemo::Scene s = hemo::load_scene(dir + "/scene.toml");
  const auto g = hemo::make_vessel_geometry(s.vessel);
  ASSERT_FALSE(g->uniform());

  const auto m = read_metrics(dir);
  const auto& counts = m.at({"particles", "particles"});
  ASSERT_EQ(counts.size(), 21u);  // step 0 and 20 steps
  for (const auto& [step, n] : counts) EXPECT_EQ(n, counts.begin()->second) << "step " << step;
  EXPECT_EQ(last(m, "particles", "particles_lost"), 0);

  const auto names = snapshot_names(dir + "/particles.h5");
  ASSERT_EQ(names.size(), 3u);
  const auto first = read_snapshot(dir + "/particles.h5", names.front());
  ASSERT_EQ(static_cast<double>(first.id.size()), counts.begin()->second);
  double worst = -1;
  int in_throat = 0;
  for (const auto& name : names) {
    const auto snap = read_snapshot(dir + "/particles.h5", name);
    ASSERT_EQ(snap.id, first.id) << name;
    for (std::size_t i = 0; i < snap.id.size(); ++i) {
      const double d = snap.species[i] == 0 ? s.rbc.diameter : s.platelet.diameter;
      const hemo::VesselGeometry::Point x(snap.position[3 * i], snap.position[3 * i + 1], snap.position[3 * i + 2]);
      const double overlap = (g->signed_distance(x) + d / 2) / d;
      worst = std::max(worst, overlap);
      EXPECT_LT(g->signed_distance(x), 0) << name << ", particle " << snap.id[i] << ": its centre is outside";
      EXPECT_LE(overlap, s.run.max_overlap) << name << ", particle " << snap.id[i];
      if (name == names.back()) in_throat += std::abs(g->axial(x.z()) - s.vessel.length / 2) < 10e-6;
    }
  }
  std::printf("  %zu particles in every snapshot; deepest into the wall %.2e diameters; %d within 10 um of the "
              "throat at the end\n",
              first.id.size(), worst, in_throat);
  EXPECT_GT(in_throat, 0);
}
