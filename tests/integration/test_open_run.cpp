// Coupled runs in an open vessel fed by a feeder (docs/design.md, "Open ends"): the real nodes
// over real LCM. Red cells leave through the outlet and copies of the feeder's enter at the inlet
// within the run; the particle node's counts balance at every step; the snapshots hold the
// vessel's cells, each once, inside the vessel; a run stopped and resumed from a checkpoint ends
// as the uninterrupted one, counts included.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_helpers.h"

#include <geometry.h>
#include <scene.h>
#include <vessel_ends.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <csignal>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <set>
#include <sstream>
#include <string>

using namespace hemo::test;

namespace {

const char* const kCounts[] = {"rbc_inserted",      "rbc_left_outlet",      "rbc_left_inlet",
                               "platelet_inserted", "platelet_left_outlet", "platelet_left_inlet"};

double count_at(const Metrics& m, const std::string& name, long step) { return m.at({"particles", name}).at(step); }

// A small open scene (open_small.toml, or another of tests/integration/scenes) with checkpoints
// every `every` steps.
std::string open_scene_with_checkpoints(long every, const char* name = "open_small.toml") {
  std::ifstream in(scene(name));
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  const std::string output = "every_steps = 10";
  s.replace(s.find(output), output.size(), output + "\ncheckpoint_every_steps = " + std::to_string(every));
  return s;
}

// Present = created + inserted - left, and none lost, at every step the particle node reported.
void expect_counts_balance(const Metrics& m) {
  const auto& present = m.at({"particles", "particles"});
  const double created = present.begin()->second;
  for (const auto& [step, n] : present) {
    double net = 0;
    for (const char* c : kCounts) {
      const bool in = std::string(c).find("inserted") != std::string::npos;
      net += (in ? 1 : -1) * count_at(m, c, step);
    }
    EXPECT_EQ(n, created + net) << "step " << step;
    EXPECT_EQ(count_at(m, "particles_lost", step), 0) << "step " << step;
  }
}

}  // namespace

TEST(OpenRun, CellsFlowThroughAndTheCountsBalanceAtEveryStep) {
  const std::string dir = fresh_run_dir("open-small");
  const auto r = run(bin("hemocosim") + " run " + scene("open_small.toml") + " --out " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const hemo::Scene s = hemo::load_scene(dir + "/scene.toml");
  const hemo::FeederLayout feeder = hemo::feeder_layout(s);

  const auto m = read_metrics(dir);
  const auto& present = m.at({"particles", "particles"});
  ASSERT_EQ(present.size(), 41u);  // step 0 and 40 steps
  const double created = present.at(0);
  expect_counts_balance(m);
  std::printf("  %g cells at the start; by step 40: %g red cells in, %g out, %g back; %g platelets in, %g out\n",
              created, count_at(m, "rbc_inserted", 40), count_at(m, "rbc_left_outlet", 40),
              count_at(m, "rbc_left_inlet", 40), count_at(m, "platelet_inserted", 40),
              count_at(m, "platelet_left_outlet", 40));
  EXPECT_GT(count_at(m, "rbc_inserted", 40), 0);
  EXPECT_GT(count_at(m, "rbc_left_outlet", 40), 0);

  // `analyze` says what passed each end over its window (the second half: 0.4 to 0.8 ms).
  const auto analysis = run(bin("hemocosim") + " analyze " + dir + " --json");
  ASSERT_EQ(analysis.exit_code, 0) << analysis.output;
  const auto j = nlohmann::json::parse(analysis.output);
  const double t0 = j["window"]["start_s"], t1 = j["window"]["end_s"];
  const long k0 = std::lround(t0 / s.time.coupling_interval), k1 = std::lround(t1 / s.time.coupling_interval);
  EXPECT_NEAR(j["ends"]["outlet"]["rbc_per_s"].get<double>() * (t1 - t0),
              count_at(m, "rbc_left_outlet", k1) - count_at(m, "rbc_left_outlet", k0), 1e-9);
  EXPECT_NEAR(j["ends"]["inlet"]["rbc_per_s"].get<double>() * (t1 - t0),
              count_at(m, "rbc_inserted", k1) - count_at(m, "rbc_inserted", k0) -
                  (count_at(m, "rbc_left_inlet", k1) - count_at(m, "rbc_left_inlet", k0)),
              1e-9);
  const double q_in = j["ends"]["inlet"]["plasma_flux_m3_s"], q_out = j["ends"]["outlet"]["plasma_flux_m3_s"];
  EXPECT_GT(q_in, 0);
  EXPECT_NEAR(q_out, q_in, 0.05 * q_in) << "the plasma that enters leaves (to the cells' changing volume)";
  const double hd = j["ends"]["outlet"]["discharge_hematocrit"];
  EXPECT_GT(hd, 0);
  EXPECT_LT(hd, 3 * s.rbc.hematocrit);

  const auto names = snapshot_names(dir + "/particles.h5");
  ASSERT_EQ(names.size(), 5u);
  for (const auto& name : names) {
    const auto snap = read_snapshot(dir + "/particles.h5", name);
    const long step = std::stol(name);
    EXPECT_EQ(static_cast<double>(snap.id.size()), count_at(m, "particles_in_vessel", step)) << name;
    std::set<long long> ids(snap.id.begin(), snap.id.end());
    EXPECT_EQ(ids.size(), snap.id.size()) << name << ": a tag twice";
    for (std::size_t i = 0; i < snap.id.size(); ++i) {
      const double x = snap.position[3 * i], y = snap.position[3 * i + 1], z = snap.position[3 * i + 2];
      EXPECT_LT(x, feeder.split_x) << name << ": a feeder cell written";
      EXPECT_GE(z, 0.0) << name << ", particle " << snap.id[i];
      EXPECT_LT(z, s.vessel.length) << name << ", particle " << snap.id[i];
      EXPECT_LT(std::hypot(x, y), s.vessel.radius()) << name << ", particle " << snap.id[i];
    }
  }
}

// 40 steps in one go, and the same scene stopped after step 20 and resumed: the same snapshots
// and the same counts at every step, bit for bit.
TEST(OpenRun, ResumedRunEqualsTheUninterruptedRunCountsIncluded) {
  const std::string whole = fresh_run_dir("open-whole"), parts = fresh_run_dir("open-parts");
  std::ofstream(whole + ".toml") << open_scene_with_checkpoints(10);
  ASSERT_EQ(run(bin("hemocosim") + " run " + whole + ".toml --out " + whole).exit_code, 0);
  const auto first = run(bin("hemocosim") + " run " + whole + ".toml --out " + parts + " --stop-after-step 20");
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const auto second = run(bin("hemocosim") + " resume " + parts);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_NE(second.output.find("resumes from step 20"), std::string::npos) << second.output;

  const auto ma = read_metrics(whole), mb = read_metrics(parts);
  for (const char* c : kCounts)
    for (long step = 0; step <= 40; ++step) EXPECT_EQ(count_at(ma, c, step), count_at(mb, c, step)) << c << " " << step;
  EXPECT_GT(count_at(ma, "rbc_inserted", 40), count_at(ma, "rbc_inserted", 20));
  expect_same_snapshots(whole, parts);
}

// `hemocosim swap` of the particle node while the run goes (here for the same program): the
// coordinator checkpoints the step, stops both nodes and starts them from it; the counts go on
// from the checkpoint's and balance at every step, each step reported once.
TEST(OpenRun, SwappedParticleNodeGoesOnWithItsCounts) {
  const std::string dir = fresh_run_dir("open-swap");
  std::string text = open_scene_with_checkpoints(0);
  const std::string steps = "coupling_steps = 40";
  text.replace(text.find(steps), steps.size(), "coupling_steps = 120");
  std::ofstream(dir + ".toml") << text;
  auto going =
      std::async(std::launch::async, [&] { return run(bin("hemocosim") + " run " + dir + ".toml --out " + dir); });
  wait_for_step(dir, 30);
  const auto answer =
      run(bin("hemocosim") + " swap " + dir + " particles --with " + bin("hemocosim-particles") + " --timeout 120");
  const auto r = going.get();
  ASSERT_EQ(answer.exit_code, 0) << answer.output << r.output;
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const long k = step_after(r.output, "restarting both nodes from the checkpoint of step ");
  ASSERT_GE(k, 30) << r.output;
  const auto m = read_metrics(dir);
  const auto& present = m.at({"particles", "particles"});
  ASSERT_EQ(present.size(), 121u);  // each step once
  expect_counts_balance(m);
  EXPECT_GT(count_at(m, "rbc_inserted", 120), count_at(m, "rbc_inserted", k)) << "cells entered after the swap";
  EXPECT_GE(count_at(m, "rbc_inserted", k + 1), count_at(m, "rbc_inserted", k)) << "the counts went on";
}

namespace {
// open_small.toml with its feeder developed first for `develop_s` (vessel.feeder_develop_s), a
// checkpoint every 10 steps, `steps` steps, and `run_keys` in its [run] table.
std::string developed_open_scene(const std::string& develop_s, long steps, const std::string& run_keys = "") {
  std::string s = open_scene_with_checkpoints(10);
  const std::string ends = "ends = \"open\"", count = "coupling_steps = 40", run = "[run]";
  s.replace(s.find(ends), ends.size(), ends + "\nfeeder_develop_s = " + develop_s);
  s.replace(s.find(count), count.size(), "coupling_steps = " + std::to_string(steps));
  s.replace(s.find(run), run.size(), run + "\n" + run_keys);
  return s;
}
}  // namespace

// vessel.feeder_develop_s: the coordinator first runs the feeder alone (a periodic tube, 10 steps
// here) into the run's feeder-develop (in the cache given, linked); the run's feeder starts with
// that run's last cells (as many), and the vessel with copies of those of them that fit in it:
// each copy at its source's position (z on the period) moved onto the inlet, with its velocity
// and orientation as the develop run's last snapshot has them. The counts balance at every step.
// A second run of the same scene with the same cache uses the developed feeder as it is; stopped
// and resumed it does not develop it again, and ends as the first, bit for bit.
TEST(OpenRun, ADevelopedFeederStartsTheRunWithTheDevelopRunsLastCells) {
  const std::string a = fresh_run_dir("open-developed"), b = fresh_run_dir("open-developed-parts");
  const std::string cache = fresh_run_dir("open-developed-cache");
  std::ofstream(a + ".toml") << developed_open_scene("2e-4", 20);
  const auto first = run(bin("hemocosim") + " run " + a + ".toml --out " + a + " --feeder-cache " + cache);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_NE(first.output.find("the feeder develops on its own for 0.0002 s (10 steps)"), std::string::npos)
      << first.output;
  const std::string develop = a + "/feeder-develop";
  ASSERT_TRUE(std::filesystem::is_symlink(develop)) << "not linked from the cache";
  EXPECT_EQ(std::filesystem::canonical(develop).parent_path(), std::filesystem::canonical(cache));

  const hemo::Scene open = hemo::load_scene(a + "/scene.toml");
  const hemo::Scene tube = hemo::load_scene(develop + "/scene.toml");
  const hemo::FeederLayout feeder = hemo::feeder_layout(open);
  ASSERT_EQ(tube.time.coupling_steps, 10);
  const auto developed_names = snapshot_names(develop + "/particles.h5");
  ASSERT_EQ(std::stol(developed_names.back()), 10);
  const auto developed = read_snapshot(develop + "/particles.h5", developed_names.back());
  const auto start = read_snapshot(a + "/particles.h5", snapshot_names(a + "/particles.h5").front());
  ASSERT_EQ(start.time_s, 0.0);

  const auto m = read_metrics(a);
  EXPECT_EQ(count_at(m, "particles", 0) - count_at(m, "particles_in_vessel", 0),
            static_cast<double>(developed.id.size()))
      << "the feeder holds the develop run's cells, as many";
  expect_counts_balance(m);

  // The copies the vessel starts with: the develop run's cells inside the vessel's length, clear of
  // its wall by a radius and the placement's gap.
  std::vector<bool> matched(start.id.size(), false);
  std::size_t expected = 0;
  for (std::size_t i = 0; i < developed.id.size(); ++i) {
    const double d = developed.species[i] == 0 ? open.rbc.diameter : open.platelet.diameter;
    const double x = developed.position[3 * i], y = developed.position[3 * i + 1];
    const double z = std::fmod(std::fmod(developed.position[3 * i + 2], feeder.period) + feeder.period, feeder.period);
    if (!(z < feeder.vessel_length && std::hypot(x, y) <= open.vessel.radius() - 0.52 * d)) continue;
    ++expected;
    std::size_t found = start.id.size();
    for (std::size_t k = 0; k < start.id.size(); ++k)
      if (!matched[k] && start.species[k] == developed.species[i] &&
          std::abs(start.position[3 * k] - x - feeder.inlet_x) < 1e-15 &&
          std::abs(start.position[3 * k + 1] - y - feeder.inlet_y) < 1e-15 &&
          std::abs(start.position[3 * k + 2] - z) < 1e-15)
        found = k;
    ASSERT_LT(found, start.id.size()) << "no copy of the develop run's cell " << developed.id[i];
    matched[found] = true;
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(start.velocity[3 * found + c], developed.velocity[3 * i + c]) << developed.id[i];
    for (int c = 0; c < 4 && !developed.orientation.empty(); ++c)
      EXPECT_EQ(start.orientation[4 * found + c], developed.orientation[4 * i + c]) << developed.id[i];
  }
  EXPECT_EQ(start.id.size(), expected) << "the vessel holds copies of the developed cells and nothing else";
  EXPECT_GT(expected, 0u);

  const auto stopped = run(bin("hemocosim") + " run " + a + ".toml --out " + b + " --feeder-cache " + cache +
                           " --stop-after-step 10");
  ASSERT_EQ(stopped.exit_code, 0) << stopped.output;
  EXPECT_NE(stopped.output.find("developed earlier"), std::string::npos) << stopped.output;
  const auto resumed = run(bin("hemocosim") + " resume " + b);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_EQ(resumed.output.find("feeder develops"), std::string::npos) << resumed.output;
  const auto mb = read_metrics(b);
  for (const char* c : kCounts)
    for (long step = 0; step <= 20; ++step) EXPECT_EQ(count_at(m, c, step), count_at(mb, c, step)) << c << " " << step;
  expect_same_snapshots(a, b);
}

// Interrupted (SIGINT) while its feeder develops, the run stops with the develop run's checkpoint
// and before its own nodes start; `hemocosim resume` goes on with the develop run from that
// checkpoint, then runs the scene from its start.
TEST(OpenRun, InterruptedWhileItsFeederDevelopsTheRunResumesTheDevelopRunThenStarts) {
  const std::string dir = fresh_run_dir("open-develop-interrupted");
  std::ofstream(dir + ".toml") << developed_open_scene("1.2e-3", 20);  // 60 develop steps
  {
    Background going(bin("hemocosim") + " run " + dir + ".toml --out " + dir, dir + "-first");
    wait_for_step(dir + "/feeder-develop", 15);
    going.signal(SIGINT);
    const auto stopped = going.done.get();
    EXPECT_NE(stopped.exit_code, 0);
    EXPECT_NE(error_line(file_text(going.err)).find("the feeder's develop run " + dir + "/feeder-develop did not "
                                                    "finish: interrupted after step "),
              std::string::npos)
        << file_text(going.err);
  }
  ASSERT_FALSE(std::filesystem::exists(dir + "/metrics.csv")) << "the run's own nodes started";
  const auto resumed = run(bin("hemocosim") + " resume " + dir);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_NE(resumed.output.find("starts after its feeder's develop run"), std::string::npos) << resumed.output;
  const long from = step_after(resumed.output, "/feeder-develop resumes from step ");
  EXPECT_GE(from, 10) << resumed.output;
  EXPECT_LT(from, 60) << resumed.output;
  const auto m = read_metrics(dir);
  ASSERT_EQ(m.at({"particles", "particles"}).size(), 21u);  // step 0 and 20 steps, each once
  expect_counts_balance(m);
  const auto developed = read_metrics(dir + "/feeder-develop");
  EXPECT_EQ(developed.at({"particles", "particles"}).rbegin()->first, 60);
}

// A develop run that fails (here the fluid's Courant guard, which the derived scene keeps) stops
// the run in one line naming it, before the run's own nodes start.
TEST(OpenRun, AFailedDevelopRunStopsTheRunInOneLineNamingIt) {
  const std::string dir = fresh_run_dir("open-develop-fails");
  std::ofstream(dir + ".toml") << developed_open_scene("2e-4", 20, "max_courant = 1e-9");
  const auto r = run(bin("hemocosim") + " run " + dir + ".toml --out " + dir);
  EXPECT_NE(r.exit_code, 0);
  const std::string line = error_line(r.output);
  EXPECT_NE(line.find("the feeder's develop run " + dir + "/feeder-develop did not finish: "), std::string::npos)
      << r.output;
  EXPECT_NE(line.find("Courant"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/metrics.csv")) << "the run's own nodes started";
}

// Blood through a fed Y bifurcation (scenes/bifurcation.toml's, small): cells leave through both
// outlets within the run, each outlet's count is named, the two add to the whole, and the counts
// balance at every step with none lost and none outside the mesh; the cells that reach the flow
// divider do not stop the run on the overlap guard (bifurcation_small.toml); analyze's shares of
// each kind add to one over the two outlets, each branch reports its end's H_D and platelets and a
// layer, and plot draws the two figures.
TEST(BifurcationRun, CellsLeaveThroughBothOutletsCountedEachAndTheCountsBalance) {
  const std::string dir = fresh_run_dir("bifurcation-small");
  const auto r = run(bin("hemocosim") + " run " + scene("bifurcation_small.toml") + " --out " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto m = read_metrics(dir);
  expect_counts_balance(m);
  const auto& present = m.at({"particles", "particles"});
  ASSERT_EQ(present.size(), 31u);  // step 0 and 30 steps
  for (const auto& [step, n] : present) {
    for (const char* species : {"rbc", "platelet"}) {
      const std::string s(species);
      EXPECT_EQ(count_at(m, s + "_left_outlet_1", step) + count_at(m, s + "_left_outlet_2", step),
                count_at(m, s + "_left_outlet", step))
          << s << " at step " << step;
    }
    EXPECT_EQ(count_at(m, "particles_outside_mesh", step), 0) << "step " << step;
  }
  const long last = present.rbegin()->first;
  EXPECT_GT(count_at(m, "rbc_left_outlet_1", last), 0);
  EXPECT_GT(count_at(m, "rbc_left_outlet_2", last), 0);
  EXPECT_GT(count_at(m, "rbc_inserted", last), 0);

  const auto a = run(bin("hemocosim") + " analyze " + dir + " --json");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  const auto j = nlohmann::json::parse(a.output);
  for (const char* share : {"blood_fraction", "rbc_fraction", "platelet_fraction"}) {
    const double one = j["branches"]["outlet_1"][share].get<double>(),
                 two = j["branches"]["outlet_2"][share].get<double>();
    EXPECT_NEAR(one + two, 1.0, 1e-12) << share;
    EXPECT_GT(one, 0) << share;
  }
  // Per branch: what passes its end (the parent's the inlet's, daughter i's outlet_i's), and the
  // cell-free layer in its own sections, of cells that are there: between 0 and its radius.
  const std::pair<const char*, const char*> branch_ends[] = {
      {"parent", "inlet"}, {"daughter_1", "outlet_1"}, {"daughter_2", "outlet_2"}};
  for (const auto& [branch, end] : branch_ends) {
    const auto& b = j["per_branch"][branch];
    EXPECT_EQ(b["end"], end) << branch;
    EXPECT_EQ(b["discharge_hematocrit"], j["ends"][end]["discharge_hematocrit"]) << branch;
    EXPECT_EQ(b["platelets_per_s"], j["ends"][end]["platelets_per_s"]) << branch;
    EXPECT_GT(b["cfl"]["mean_rbc_count"].get<double>(), 0) << branch;
    const double delta = b["cfl"]["thickness_m"].get<double>();
    EXPECT_GT(delta, 0) << branch;
    EXPECT_LT(delta, b["radius_m"].get<double>()) << branch;
  }
  // `plot` draws a surface run's two figures.
  const auto p = run(bin("hemocosim") + " plot " + dir);
  ASSERT_EQ(p.exit_code, 0) << p.output;
  for (const char* figure : {"_phase_separation.png", "_branches.png"}) {
    const std::string png = dir + "/figures/" + std::filesystem::path(dir).filename().string() + figure;
    EXPECT_GT(std::filesystem::exists(png) ? std::filesystem::file_size(png) : 0, 1000u) << png;
  }
  std::filesystem::remove_all(dir);
}

// The 30-um bifurcation in 2.5-um snapped cubes, narrower than a red cell, the particles shared
// over a Gaussian kernel (bifurcation_kernel_small.toml): the run goes through with cells entering
// from the feeder; the solid volume the particle node deposits is its particles' volume inside the
// open ends to round-off at every step (the kernel's share of each cell inside them: nothing of a
// particle is lost behind the wall, nor added at the ends); the kernel leaves every cell more
// than half plasma; the Courant number is under 1 at most steps; and the cells in the parent's
// core move with the plasma they read over the kernel, within 5 %.
TEST(BifurcationRun, AKernelCarriesRedCellsInCubesNarrowerThanThem) {
  const std::string dir = fresh_run_dir("bifurcation-kernel-small");
  const auto r = run(bin("hemocosim") + " run " + scene("bifurcation_kernel_small.toml") + " --out " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto m = read_metrics(dir);
  expect_counts_balance(m);
  const hemo::Scene s = hemo::load_scene(dir + "/scene.toml");
  const double v_rbc = s.rbc.volume;
  const auto& present = m.at({"particles", "particles"});
  ASSERT_EQ(present.size(), 21u);
  const auto& solid = m.at({"particles", "solid_volume_m3"});
  const double solid0 = solid.begin()->second;
  EXPECT_GT(solid0, 0);
  int calm = 0;
  for (const auto& [step, n] : present) {
    EXPECT_EQ(count_at(m, "particles_outside_mesh", step), 0) << "step " << step;
    EXPECT_NEAR(solid.at(step), count_at(m, "particles_volume_inside_m3", step), 1e-12 * solid0) << "step " << step;
    EXPECT_GT(solid.at(step), 0) << "step " << step;
    // Not more than the cells present (feeder's included) and the straddling ones, each at most a
    // red cell.
    EXPECT_LE(solid.at(step), v_rbc * (n + count_at(m, "particles_straddling", step))) << "step " << step;
    if (step == 0) continue;
    EXPECT_GT(m.at({"fluid", "alpha_min"}).at(step), 0.5) << "step " << step;
    calm += m.at({"fluid", "courant_max"}).at(step) < 1;
    if (step >= 3) {
      const double cells = count_at(m, "core_particle_axial_velocity_m_s", step),
                   plasma = count_at(m, "core_fluid_axial_velocity_m_s", step);
      EXPECT_NEAR(cells / plasma, 1.0, 0.05) << "step " << step;
    }
  }
  EXPECT_GT(count_at(m, "rbc_inserted", present.rbegin()->first), 0) << "cells entered";
  EXPECT_GE(calm, 15) << "steps of 20 with a Courant number under 1";
  std::filesystem::remove_all(dir);
}

// The bifurcation stopped at step 20 and resumed from its checkpoint: every step is reported
// once, the counts balance at every step across the resume, each outlet's with the whole, and the
// cells go on leaving through both outlets. Not bit for bit, unlike the straight open tube's and the
// stenosis' resumes: the particles' forces differ from the uninterrupted run's at 1e-5 from the
// first step after the resume. Not the mesh wall's contact history, which checkpoints do not carry
// (dem_fixes.h): carried (tried), it changed nothing. Cause not found (docs/design.md).
TEST(BifurcationRun, ResumedRunReportsEveryStepOnceAndItsCountsBalance) {
  const std::string whole = fresh_run_dir("bifurcation-whole"), parts = fresh_run_dir("bifurcation-parts");
  std::ofstream(whole + ".toml") << open_scene_with_checkpoints(10, "bifurcation_small.toml");
  const auto first = run(bin("hemocosim") + " run " + whole + ".toml --out " + parts + " --stop-after-step 20");
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const auto second = run(bin("hemocosim") + " resume " + parts);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_NE(second.output.find("resumes from step 20"), std::string::npos) << second.output;

  const auto m = read_metrics(parts);
  ASSERT_EQ(m.at({"particles", "particles"}).size(), 31u);  // step 0 and 30 steps, each once
  expect_counts_balance(m);
  for (long step = 0; step <= 30; ++step)
    for (const char* s : {"rbc", "platelet"})
      EXPECT_EQ(count_at(m, std::string(s) + "_left_outlet_1", step) + count_at(m, std::string(s) + "_left_outlet_2", step),
                count_at(m, std::string(s) + "_left_outlet", step))
          << s << " " << step;
  EXPECT_GT(count_at(m, "rbc_left_outlet_1", 30), count_at(m, "rbc_left_outlet_1", 20));
  EXPECT_GT(count_at(m, "rbc_left_outlet_2", 30), count_at(m, "rbc_left_outlet_2", 20));
}

namespace {

// The shipped scenes/imported.toml beside a copy of its STL, under `root`, with the text
// `replace_from` replaced by `replace_to`. Returns the scene's path.
std::string shipped_imported_scene(const std::filesystem::path& root, const std::string& replace_from = "",
                                   const std::string& replace_to = "") {
  namespace fs = std::filesystem;
  fs::create_directories(root / "surfaces");
  fs::copy_file(fs::path(HEMO_SCENES_DIR) / "surfaces" / "eccentric-stenosis.stl",
                root / "surfaces" / "eccentric-stenosis.stl", fs::copy_options::overwrite_existing);
  std::ifstream in(fs::path(HEMO_SCENES_DIR) / "imported.toml");
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  if (!replace_from.empty()) {
    const auto at = s.find(replace_from);
    if (at == std::string::npos) throw std::runtime_error("scenes/imported.toml has no '" + replace_from + "'");
    s.replace(at, replace_from.size(), replace_to);
  }
  std::ofstream(root / "imported.toml") << s;
  return (root / "imported.toml").string();
}

}  // namespace

// Blood through an imported surface (scenes/imported.toml: a bent 100-um vessel with a plaque on
// one side, a shape no built-in vessel.shape makes), its first 20 steps: cells enter from the
// feeder and leave through the outlet, the counts balance at every step, no cell is outside the
// fluid mesh, and every cell the snapshots hold is inside the STL's surface (the DEM's mesh wall
// holds them: a centre behind the wall is outside it), none but by less than a radius; `analyze`
// gives the outlet all the blood and each end's stretch a layer.
TEST(ImportedRun, CellsFlowThroughTheShippedSurfaceInsideItsWallAndTheCountsBalance) {
  namespace fs = std::filesystem;
  const std::string dir = fresh_run_dir("imported-blood");
  const fs::path root = dir + "-scene";
  const std::string path = shipped_imported_scene(root, "every_steps = 100", "every_steps = 10");
  const auto r = run(bin("hemocosim") + " run " + path + " --out " + dir + " --stop-after-step 20");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto m = read_metrics(dir);
  expect_counts_balance(m);
  const auto& present = m.at({"particles", "particles"});
  ASSERT_EQ(present.size(), 21u);  // step 0 and 20 steps
  for (const auto& [step, n] : present) EXPECT_EQ(count_at(m, "particles_outside_mesh", step), 0) << "step " << step;
  EXPECT_GT(count_at(m, "rbc_left_outlet", 20), 0);
  EXPECT_GT(count_at(m, "platelet_left_outlet", 20), 0);
  EXPECT_GT(count_at(m, "rbc_inserted", 20), 0);

  const hemo::Scene s = hemo::load_scene(path);
  const auto wall = hemo::make_vessel_wall(s.vessel);
  const auto names = snapshot_names(dir + "/particles.h5");
  ASSERT_EQ(names.size(), 3u);  // steps 0, 10, 20
  for (const auto& name : names) {
    const auto snap = read_snapshot(dir + "/particles.h5", name);
    EXPECT_EQ(static_cast<double>(snap.id.size()), count_at(m, "particles_in_vessel", std::stol(name))) << name;
    for (std::size_t i = 0; i < snap.id.size(); ++i) {
      const Eigen::Vector3d x(snap.position[3 * i], snap.position[3 * i + 1], snap.position[3 * i + 2]);
      EXPECT_LT(wall->signed_distance(x), 0) << name << ", particle " << snap.id[i] << " at " << x.transpose();
    }
  }

  const auto a = run(bin("hemocosim") + " analyze " + dir + " --json");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  const auto j = nlohmann::json::parse(a.output);
  EXPECT_EQ(j["branches"]["outlet_1"]["blood_fraction"].get<double>(), 1.0);
  EXPECT_GT(j["ends"]["outlet_1"]["discharge_hematocrit"].get<double>(), 0);
  // Its ends' straight stretches are its branches (SurfaceWall::branches): each reports its end's
  // H_D and a cell-free layer of the cells there, between 0 and its radius.
  const std::pair<const char*, const char*> branch_ends[] = {{"parent", "inlet"}, {"daughter_1", "outlet_1"}};
  for (const auto& [branch, end] : branch_ends) {
    const auto& b = j["per_branch"][branch];
    EXPECT_EQ(b["end"], end) << branch;
    EXPECT_EQ(b["discharge_hematocrit"], j["ends"][end]["discharge_hematocrit"]) << branch;
    EXPECT_GT(b["cfl"]["mean_rbc_count"].get<double>(), 0) << branch;
    const double delta = b["cfl"]["thickness_m"].get<double>();
    EXPECT_GT(delta, 0) << branch;
    EXPECT_LT(delta, b["radius_m"].get<double>()) << branch;
  }
  fs::remove_all(root);
}

// The spherical surrogate's shear lift needs a section's centre-line speed, which an imported
// surface does not define: the particle node refuses it at start-up in one line naming the
// species and its closures.
TEST(ImportedRun, AClosureThatNeedsTheCentreLineSpeedIsRefusedInOneLine) {
  namespace fs = std::filesystem;
  const std::string dir = fresh_run_dir("imported-shear-lift");
  const fs::path root = dir + "-scene";
  const std::string path = shipped_imported_scene(root, "drag = \"oblate\"\nlift = \"oblate\"\ntorque = \"oblate\"",
                                                  "drag = \"schiller_naumann\"\nlift = \"shear_lift\"\ntorque = \"none\"");
  const auto r = run(bin("hemocosim") + " run " + path + " --out " + dir);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("the platelet closures (drag schiller_naumann, lift shear_lift, torque none) need the "
                          "vessel's centre-line speed at each section, which an imported surface does not define"),
            std::string::npos)
      << r.output;
  fs::remove_all(root);
}
