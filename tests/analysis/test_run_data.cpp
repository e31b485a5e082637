// The run-directory reader on small files the test writes in the run's format, its one-line
// errors, and `analyze` end to end on a tiny constructed run.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "analyze.h"
#include "run_data.h"
#include "synthetic.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <hdf5.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

using namespace hemo::analysis;
using namespace hemo::analysis::test;

namespace {

// What to break in a written snapshot.
enum class Flaw { none, no_velocity, flat_position, no_time };

void write_set(hid_t g, const char* name, hid_t mem, hid_t file, hsize_t rows, hsize_t cols, const void* data) {
  hsize_t dims[2] = {rows, cols};
  hid_t space = H5Screate_simple(cols > 1 ? 2 : 1, dims, nullptr);
  hid_t set = H5Dcreate2(g, name, file, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (rows > 0) H5Dwrite(set, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
  H5Dclose(set);
  H5Sclose(space);
}

// particles.h5 in the particle node's format: /snapshots/<8 digits> {time_s; id, species, position, velocity}.
void write_particles(const std::string& path, const std::vector<Snapshot>& snaps, Flaw flaw = Flaw::none) {
  hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  hid_t root = H5Gcreate2(f, "snapshots", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  for (const auto& s : snaps) {
    char name[16];
    std::snprintf(name, sizeof name, "%08ld", s.step);
    hid_t g = H5Gcreate2(root, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (flaw != Flaw::no_time) {
      hid_t scalar = H5Screate(H5S_SCALAR);
      hid_t attr = H5Acreate2(g, "time_s", H5T_IEEE_F64LE, scalar, H5P_DEFAULT, H5P_DEFAULT);
      H5Awrite(attr, H5T_NATIVE_DOUBLE, &s.time_s);
      H5Aclose(attr);
      H5Sclose(scalar);
    }
    const hsize_t n = s.size();
    write_set(g, "id", H5T_NATIVE_INT64, H5T_STD_I64LE, n, 1, s.id.data());
    write_set(g, "species", H5T_NATIVE_INT8, H5T_STD_I8LE, n, 1, s.species.data());
    if (flaw == Flaw::flat_position)
      write_set(g, "position", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, 3 * n, 1, s.position.data());
    else
      write_set(g, "position", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, n, 3, s.position.data());
    if (flaw != Flaw::no_velocity) write_set(g, "velocity", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, n, 3, s.velocity.data());
    H5Gclose(g);
  }
  H5Gclose(root);
  H5Fclose(f);
}

Snapshot small_snapshot(long step, double t, double shift) {
  Snapshot s;
  s.step = step;
  s.time_s = t;
  add_particle(s, 7, kRbc, 3 * kUm + shift, 0.5, 12 * kUm, 1e-3);
  add_particle(s, 3, kPlatelet, 8 * kUm - shift, -1.0, -5 * kUm, 2e-3);
  add_particle(s, 11, kPlatelet, 1 * kUm, 2.0, 700 * kUm, 0.5e-3);
  return s;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const RunDataError& e) {
    return e.what();
  }
  return "";
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(RunData, SnapshotsRoundTripSortedByStep) {
  const TempDir tmp("roundtrip");
  const std::string path = tmp.str() + "/particles.h5";
  write_particles(path, {small_snapshot(10, 2e-4, 1 * kUm), small_snapshot(0, 0, 0)});
  const auto list = list_snapshots(path);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].step, 0);
  EXPECT_EQ(list[1].step, 10);
  EXPECT_DOUBLE_EQ(list[1].time_s, 2e-4);
  const Snapshot want = small_snapshot(10, 2e-4, 1 * kUm);
  const Snapshot got = read_snapshot(path, 10);
  EXPECT_EQ(got.step, 10);
  EXPECT_DOUBLE_EQ(got.time_s, 2e-4);
  EXPECT_EQ(got.id, want.id);
  EXPECT_EQ(got.species, want.species);
  EXPECT_EQ(got.position, want.position);
  EXPECT_EQ(got.velocity, want.velocity);
}

TEST(RunData, MissingOrCorruptParticleFileIsOneClearLine) {
  const TempDir tmp("corrupt");
  const std::string dir = tmp.str();
  EXPECT_EQ(error_of([&] { list_snapshots(dir + "/particles.h5"); }), dir + "/particles.h5: missing");
  write_text(dir + "/junk.h5", "this is not HDF5\n");
  EXPECT_EQ(error_of([&] { list_snapshots(dir + "/junk.h5"); }),
            dir + "/junk.h5: not an HDF5 file (corrupt or truncated?)");
  const auto snap = small_snapshot(0, 0, 0);
  write_particles(dir + "/a.h5", {snap}, Flaw::no_velocity);
  EXPECT_EQ(error_of([&] { read_snapshot(dir + "/a.h5", 0); }),
            dir + "/a.h5 /snapshots/00000000: no dataset 'velocity'");
  write_particles(dir + "/b.h5", {snap}, Flaw::flat_position);
  EXPECT_EQ(error_of([&] { read_snapshot(dir + "/b.h5", 0); }),
            dir + "/b.h5 /snapshots/00000000: dataset 'position' has shape 9x1, expected 3x3");
  write_particles(dir + "/c.h5", {snap}, Flaw::no_time);
  EXPECT_EQ(error_of([&] { list_snapshots(dir + "/c.h5"); }), dir + "/c.h5 /snapshots/00000000: no attribute time_s");
  EXPECT_EQ(error_of([&] { read_snapshot(dir + "/b.h5", 5); }), dir + "/b.h5 /snapshots/00000005: missing");
}

TEST(RunData, MetricsAreReadInLongFormat) {
  const TempDir tmp("metrics");
  const std::string dir = tmp.str();
  write_text(dir + "/metrics.csv",
             "step,time_s,node,name,value\n"
             "1,2e-05,fluid,mean_velocity_m_s,0.0071\n"
             "1,2e-05,particles,compute_s,0.5\n"
             "2,4e-05,fluid,mean_velocity_m_s,0.0073\n");
  const auto m = read_metrics(dir + "/metrics.csv");
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[1].node, "particles");
  EXPECT_EQ(m[2].step, 2);
  const auto u = metric_series(m, "mean_velocity_m_s");
  EXPECT_EQ(u.time_s, (std::vector<double>{2e-5, 4e-5}));
  EXPECT_EQ(u.value, (std::vector<double>{0.0071, 0.0073}));

  write_text(dir + "/bad.csv", "step,time_s,node,name,value\n1,0,fluid,x,1\n2,0,fluid,x,fast\n");
  EXPECT_EQ(error_of([&] { read_metrics(dir + "/bad.csv"); }), dir + "/bad.csv:3: value 'fast' is not a number");
  write_text(dir + "/short.csv", "step,time_s,node,name,value\n1,0,fluid\n");
  EXPECT_EQ(error_of([&] { read_metrics(dir + "/short.csv"); }), dir + "/short.csv:2: expected 5 fields, found 3");
  write_text(dir + "/header.csv", "a,b\n");
  EXPECT_NE(error_of([&] { read_metrics(dir + "/header.csv"); }).find("header"), std::string::npos);
  EXPECT_EQ(error_of([&] { read_metrics(dir + "/none.csv"); }), dir + "/none.csv: missing");
}

TEST(RunData, RunDirectoryNeedsItsThreeFiles) {
  const TempDir tmp("incomplete");
  const std::string dir = tmp.str();
  EXPECT_EQ(error_of([&] { open_run(dir + "/nope"); }), dir + "/nope: not a run directory");
  EXPECT_EQ(error_of([&] { open_run(dir); }), dir + "/scene.toml: missing");
  write_text(dir + "/scene.toml", "[vessel]\ndiameter_um = -1\n");
  EXPECT_NE(error_of([&] { open_run(dir); }).find("invalid scene"), std::string::npos);
}

// A tiny run: 20 um x 40 um vessel, 4 RBCs on the axis region and 2 platelets, three snapshots
// 0.05 s apart; the fluid reports U such that mu_app/mu = 1.25.
TEST(Analyze, EndToEndOnAConstructedRun) {
  const TempDir tmp("run");
  const std::string dir = tmp.str();
  write_text(dir + "/scene.toml",
             "[vessel]\ndiameter_um = 20\nlength_um = 40\n[mesh]\ncore_cells = 2\nring_cells = 2\naxial_cells = 2\n"
             "[driving]\nwall_shear_rate_per_s = 800\n"
             "[rbc]\nhematocrit = 0.1\n[platelet]\nnumber_density_per_ul = 300000\n");
  const double d = 20 * kUm, u = 800 * d / (8 * 1.25);
  std::string csv = "step,time_s,node,name,value\n";
  // The wall shear stress: 0.5 of the imposed mu gamma before 0.05 s, 0.9 of it after.
  const double imposed = 1.2e-3 * 800;
  for (int k = 0; k <= 10; ++k)
    csv += fmt::format("{},{},fluid,mean_velocity_m_s,{}\n{},{},fluid,wall_shear_stress_Pa,{}\n", k, 0.01 * k, u, k,
                       0.01 * k, (k < 5 ? 0.5 : 0.9) * imposed);
  write_text(dir + "/metrics.csv", csv);
  std::vector<Snapshot> snaps;
  for (int k = 0; k < 3; ++k) {
    Snapshot s;
    s.step = 5 * k;
    s.time_s = 0.05 * k;
    for (int i = 0; i < 4; ++i) add_particle(s, i, kRbc, 4 * kUm, i * kPi / 2, (5 + 10 * i) * kUm, u);
    add_particle(s, 100, kPlatelet, 9 * kUm, 0.3, 10 * kUm, u);       // in the layer
    add_particle(s, 101, kPlatelet, (2 + 0.5 * k) * kUm, 0.3, 0, u);  // walks outward 0.5 um per snapshot
    snaps.push_back(s);
  }
  write_particles(dir + "/particles.h5", snaps);

  const auto run = open_run(dir);
  ASSERT_EQ(run.snapshots.size(), 3u);
  hemo::AnalyzeOptions opt;
  opt.run_dir = dir;
  opt.bins = 10;
  const auto a = analyze_run(run, opt);
  EXPECT_TRUE(a.window_is_default);
  EXPECT_DOUBLE_EQ(a.window_start, 0.05);
  EXPECT_EQ(a.window_snapshots, 2);
  EXPECT_NEAR(a.rheology.relative_viscosity, 1.25, 1e-12);
  EXPECT_EQ(a.velocity_samples, 6);
  EXPECT_NEAR(a.tube_hematocrit, 4 * 90e-18 / (kPi * 1e-10 * 40e-6), 1e-12);
  // Stations: 4 RBCs give one station; its edge is 4 + 2.78 um, delta = 10 - 6.78 = 3.22 um.
  EXPECT_EQ(a.stations.count(), 1);
  EXPECT_NEAR(a.cfl_edge.thickness, 3.22 * kUm, 1e-12);
  EXPECT_DOUBLE_EQ(a.margination_index, 0.5);  // platelet 100 at 9 um > 6.78 um; 101 is not
  // MSD: platelet 100 still, 101 moved 0.5 and 1 um: MSD = 0.125 and 0.5 um^2 at 0.05 and 0.1 s;
  // 2D = (0.05 * 0.125 + 0.1 * 0.5) / (0.05^2 + 0.1^2) um^2/s.
  ASSERT_EQ(a.msd.size(), 2u);
  EXPECT_NEAR(a.msd[1].msd_m2, 0.5e-12, 1e-24);
  EXPECT_EQ(a.diffusion.points, 2);
  EXPECT_NEAR(a.diffusion.diffusivity, (0.05 * 0.125 + 0.1 * 0.5) / (0.0025 + 0.01) / 2 * 1e-12, 1e-24);
  // Plug flow, no superficial velocity reported: total flux pi R^2 U, H_D = H_T.
  EXPECT_NEAR(a.discharge_hematocrit, a.tube_hematocrit, 1e-12);
  // The momentum balance over the window [0.05, 0.1] s: 0.9 of the imposed stress, at the
  // rate 0.9 x 800 1/s; its window starts before the flow has settled (0.1 s): not judged.
  EXPECT_EQ(a.balance.samples, 6);
  EXPECT_NEAR(a.balance.ratio(), 0.9, 1e-12);
  EXPECT_NEAR(a.balance.mean, 0.9 * imposed, 1e-12);
  EXPECT_NEAR(a.balance.end, 0.9 * imposed, 1e-12);
  EXPECT_NEAR(a.balance.wall_shear_rate(), 720, 1e-9);
  EXPECT_EQ(a.balance.mesh_ratio, 1.0);  // the default wall polygon, tangent to the circle
  EXPECT_FALSE(a.balance_verdict.judged);

  EXPECT_EQ(hemo::analyze_command(opt), 0);
  const auto json = nlohmann::json::parse(read_text(dir + "/analysis.json"));
  EXPECT_NEAR(json["rheology"]["relative_apparent_viscosity"].get<double>(), 1.25, 1e-12) << json;
  EXPECT_EQ(json["cfl"]["edge"]["method"], "edge");
  EXPECT_NEAR(json["momentum_balance"]["ratio"].get<double>(), 0.9, 1e-12) << json;
  EXPECT_NEAR(json["momentum_balance"]["wall_shear_stress_Pa"].get<double>(), 0.9 * imposed, 1e-12);
  EXPECT_NEAR(json["momentum_balance"]["imposed_wall_shear_stress_Pa"].get<double>(), imposed, 1e-12);
  EXPECT_NEAR(json["momentum_balance"]["wall_shear_rate_per_s"].get<double>(), 720, 1e-9);
  EXPECT_TRUE(json["momentum_balance"]["holds"].is_null());
  // Over time, for `plot`: 11 samples, 11 points (fewer than 200), 0.5 then 0.9.
  const auto& over_time = json["momentum_balance"]["over_time"];
  ASSERT_EQ(over_time["ratio"].size(), 11u) << over_time;
  EXPECT_NEAR(over_time["ratio"][0].get<double>(), 0.5, 1e-12);
  EXPECT_NEAR(over_time["ratio"][10].get<double>(), 0.9, 1e-12);
  EXPECT_NEAR(over_time["time_s"][10].get<double>(), 0.1, 1e-12);
  const std::string csv_out = read_text(dir + "/profiles.csv");
  EXPECT_EQ(std::count(csv_out.begin(), csv_out.end(), '\n'), 1 + 10 * (1 + 3));  // header, window, 3 snapshots

  // Stations given explicitly; a window after the run is refused in one line.
  opt.slices = 2;
  opt.sectors = 3;
  EXPECT_EQ(analyze_run(run, opt).stations.count(), 6);
  opt.window_start = 5;
  EXPECT_NE(error_of([&] { analyze_run(run, opt); }).find("after the last snapshot"), std::string::npos);

  // A window that ends early reads the run as a shorter one: the second half of [0, 0.05] s
  // holds the one snapshot at 0.05 s, where the walking platelet is still at 2.5 um.
  opt.window_start = -1;
  opt.window_end = 0.05;
  const auto early = analyze_run(run, opt);
  EXPECT_FALSE(early.window_is_default);
  EXPECT_DOUBLE_EQ(early.window_start, 0.025);
  EXPECT_DOUBLE_EQ(early.window_end, 0.05);
  EXPECT_EQ(early.window_snapshots, 1);
  EXPECT_EQ(early.velocity_samples, 3);  // the metrics at 0.03, 0.04 and 0.05 s
  opt.window_end = 0.2;
  EXPECT_NE(error_of([&] { analyze_run(run, opt); }).find("window end 0.2 s is after the last snapshot"),
            std::string::npos);
  opt.window_start = 0.1;
  opt.window_end = 0.05;
  EXPECT_NE(error_of([&] { analyze_run(run, opt); }).find("is before its start"), std::string::npos);
}

// The platelets' axis enrichment end to end: 20 platelets, 4 of them within 0.2 R of the axis at
// the first snapshot, 6 at the second and 8 at the last; the window's end picks the snapshot.
TEST(Analyze, PlateletAxisEnrichmentFromTheFirstToTheLastSnapshot) {
  const TempDir tmp("axis");
  const std::string dir = tmp.str();
  write_text(dir + "/scene.toml",
             "[vessel]\ndiameter_um = 20\nlength_um = 40\n[mesh]\ncore_cells = 2\nring_cells = 2\naxial_cells = 2\n"
             "[driving]\nwall_shear_rate_per_s = 800\n"
             "[rbc]\nhematocrit = 0.1\n[platelet]\nnumber_density_per_ul = 300000\n");
  std::string csv = "step,time_s,node,name,value\n";
  for (int k = 0; k <= 20; ++k) csv += fmt::format("{},{},fluid,wall_shear_stress_Pa,0.96\n", k, 0.01 * k);
  write_text(dir + "/metrics.csv", csv);
  std::vector<Snapshot> snaps;
  for (int k = 0; k < 3; ++k) {
    Snapshot s;
    s.step = 10 * k;
    s.time_s = 0.1 * k;
    const int near = 4 + 2 * k;  // R = 10 um: within 2 um of the axis
    for (int i = 0; i < 20; ++i)
      add_particle(s, 100 + i, kPlatelet, (i < near ? 1.5 : 6.0) * kUm, 0.3 * i, 2 * i * kUm);
    add_particle(s, 1, kRbc, 5 * kUm, 0, 0);
    snaps.push_back(s);
  }
  write_particles(dir + "/particles.h5", snaps);
  const auto run = open_run(dir);
  hemo::AnalyzeOptions opt;
  opt.run_dir = dir;
  const auto a = analyze_run(run, opt);
  EXPECT_EQ(a.platelet_axis.start_near, 4);
  EXPECT_EQ(a.platelet_axis.end_near, 8);
  EXPECT_EQ(a.platelet_axis.end_total, 20);
  EXPECT_DOUBLE_EQ(a.platelet_axis.end_time, 0.2);
  EXPECT_DOUBLE_EQ(a.platelet_axis.enrichment, 2.0);
  // The balance: 0.96 Pa of 0.96 imposed over [0.1, 0.2] s, settled: it holds, and no note says otherwise.
  EXPECT_TRUE(a.balance_verdict.judged);
  EXPECT_TRUE(a.balance_verdict.holds);
  for (const auto& n : a.notes) EXPECT_EQ(n.find("momentum balance"), std::string::npos) << n;
  // Read as a run of 0.1 s, its end is the middle snapshot.
  opt.window_end = 0.1;
  const auto shorter = analyze_run(run, opt);
  EXPECT_DOUBLE_EQ(shorter.platelet_axis.end_time, 0.1);
  EXPECT_DOUBLE_EQ(shorter.platelet_axis.enrichment, 1.5);
  const std::string table = format_table(a);
  EXPECT_NE(table.find("axis enrichment"), std::string::npos) << table;
  EXPECT_NE(table.find("4 of 20 at 0 s (0.2000), 8 of 20 at 0.2 s (0.4000)"), std::string::npos) << table;

  // 0.8 of the imposed stress in a settled window: the table's note says so in the summary's words.
  csv = "step,time_s,node,name,value\n";
  for (int k = 0; k <= 20; ++k) csv += fmt::format("{},{},fluid,wall_shear_stress_Pa,{}\n", k, 0.01 * k, 0.8 * 0.96);
  write_text(dir + "/metrics.csv", csv);
  opt.window_end = -1;
  const auto deficit = analyze_run(open_run(dir), opt);
  EXPECT_TRUE(deficit.balance_verdict.judged);
  EXPECT_FALSE(deficit.balance_verdict.holds);
  const std::string note =
      "note              momentum balance: wall shear stress 0.768 Pa is 0.800 of the imposed 0.960 Pa";
  EXPECT_NE(format_table(deficit).find(note), std::string::npos) << format_table(deficit);
}

// The closing line of `hemocosim run` judges tau_w = d dP / (4 l) only in a vessel whose wall is parallel
// to the axis (dP an open vessel's realised drop): the same wall shear stress, 0.8 of the imposed one over a settled window, is named
// for a straight vessel and not for a stenosis, whose wall takes part of the drop as pressure.
TEST(Analyze, TheWallShearBalanceIsJudgedOnlyForAStraightVessel) {
  const TempDir tmp("balance");
  const std::string dir = tmp.str();
  const std::string vessel = "[vessel]\ndiameter_um = 100\nlength_um = 600\n";
  const std::string rest = "[driving]\nwall_shear_rate_per_s = 800\n";
  write_text(dir + "/straight.toml", vessel + rest);
  write_text(dir + "/stenosis.toml",
             vessel + "shape = \"stenosis\"\nstenosis_area_reduction = 0.5\nstenosis_length_um = 300\n" + rest);
  std::string csv = "step,time_s,node,name,value\n";
  for (int k = 0; k <= 100; ++k)
    csv += fmt::format("{},{},fluid,wall_shear_stress_Pa,{}\n", k, 0.01 * k, 0.8 * 1.2e-3 * 800);
  write_text(dir + "/metrics.csv", csv);
  const std::string straight = closing_balance_line(dir, hemo::load_scene(dir + "/straight.toml"));
  EXPECT_NE(straight.find("is 0.800 of the imposed"), std::string::npos) << straight;
  EXPECT_EQ(closing_balance_line(dir, hemo::load_scene(dir + "/stenosis.toml")), "");
  // An open vessel's wall carries the drop its inlet's pressure realises (the outlet holds 0):
  // 0.8 of the imposed stress is the whole of a drop 0.8 of the imposed one, and 0.8 of a drop
  // as large as the imposed one.
  write_text(dir + "/open.toml", vessel + "ends = \"open\"\n" + rest);
  const double imposed_drop = hemo::load_scene(dir + "/open.toml").driving.pressure_drop;
  for (const double drop : {0.8, 1.0}) {
    std::string with_inlet = csv;
    for (int k = 0; k <= 100; ++k)
      with_inlet += fmt::format("{},{},fluid,inlet_pressure_Pa,{}\n", k, 0.01 * k, drop * imposed_drop);
    write_text(dir + "/metrics.csv", with_inlet);
    const std::string open = closing_balance_line(dir, hemo::load_scene(dir + "/open.toml"));
    if (drop == 0.8)
      EXPECT_EQ(open, "") << open;
    else
      EXPECT_NE(open.find("is 0.800 of the"), std::string::npos) << open;
  }
}
