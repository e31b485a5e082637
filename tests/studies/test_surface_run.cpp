// A bifurcation's run, analysed: synthetic counts with a known split (SyntheticRun's surface
// metrics) give each branch's H_D and platelet flux and the outlets' shares over time by hand, and
// cells placed within each branch's own sections its layer's count and bounds.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "analyze.h"
#include "observable_table.h"
#include "scene.h"
#include "synthetic_run.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>

using namespace hemo;
using namespace hemo::studytest;

namespace {

// A 40-um parent, 80 um long, and Murray's daughters (31.7 um, 120 um long) at 60 degrees: a
// daughter's own sections start r cot 30° = 27.5 um from the junction, short of the far half
// where SyntheticRun puts its cells.
std::string bifurcation_scene(const std::string& dir) {
  const std::string path = dir + "/bifurcation.toml";
  write_text(path,
             "[vessel]\ndiameter_um = 40\nlength_um = 80\nshape = \"bifurcation\"\ndaughter_length_um = 120\nends = "
             "\"open\"\n[mesh]\nsurface_cell_size_um = 8\n[driving]\nwall_shear_rate_per_s = 800\n[rbc]\nhematocrit "
             "= 0.1\n[platelet]\nnumber_density_per_ul = 300000\n");
  return path;
}

// A synthetic bifurcation run (SyntheticRun's defaults) in its own scratch folder, analysed over
// [window_start, window_end] (NaN: the default window).
struct AnalysedSurfaceRun {
  explicit AnalysedSurfaceRun(const std::string& name, double window_start = std::nan(""),
                              double window_end = std::nan(""))
      : dir(name), run(dir.str() + "/run") {
    write_synthetic_run(run, bifurcation_scene(dir.str()), spec);
    AnalyzeOptions opt;
    opt.run_dir = run;
    if (std::isfinite(window_start)) opt.window_start = window_start;
    if (std::isfinite(window_end)) opt.window_end = window_end;
    a = analysis::analyze_run(analysis::open_run(run), opt);
  }
  ScratchDir dir;
  std::string run;
  SyntheticRun spec;
  analysis::Analysis a;
};

}  // namespace

// Over steps 30..45 (the window lies between the count samples, a step each 1 ms), the parent
// takes in rbc_in red cells and platelets_in platelets a step with plasma_in, outlet 1 lets out
// rbc_1_late and platelets_1 with plasma_1, outlet 2 the rest. H_D = Q_RBC / (plasma + cells).
TEST(SurfaceRun, EachBranchsDischargeHematocritAndPlateletFluxAreItsEndsCounts) {
  const AnalysedSurfaceRun analysed("surface-analysis", 0.0305, 0.0455);
  const std::string& run = analysed.run;
  const SyntheticRun& spec = analysed.spec;
  const auto& a = analysed.a;
  const Scene scene = load_scene(run + "/scene.toml");
  const double steps = spec.steps_per_snapshot / spec.dt_s;  // per second
  const double v_rbc = scene.rbc.volume, v_plt = scene.platelet.volume;
  const double rbc_2 = spec.rbc_in - spec.rbc_1_late, plt_2 = spec.platelets_in - spec.platelets_1;
  const double plasma[3] = {spec.plasma_in, spec.plasma_1, spec.plasma_in - spec.plasma_1};
  const double rbcs[3] = {spec.rbc_in * steps, spec.rbc_1_late * steps, rbc_2 * steps};
  const double platelets[3] = {spec.platelets_in * steps, spec.platelets_1 * steps, plt_2 * steps};

  ASSERT_EQ(a.branch_layers.size(), 3u);
  ASSERT_EQ(a.ends.size(), 3u);
  const auto json = nlohmann::json::parse(analysis::format_json(a));
  EXPECT_TRUE(json["vessel"]["surface"].get<bool>());
  const std::string table = analysis::format_table(a);
  const char* ends[3] = {"inlet", "outlet_1", "outlet_2"};
  for (int b = 0; b < 3; ++b) {
    const auto& layer = a.branch_layers[static_cast<std::size_t>(b)];
    const auto& j = json["per_branch"][layer.name];
    EXPECT_EQ(j["end"], ends[b]) << layer.name;
    const double blood = plasma[b] + rbcs[b] * v_rbc + platelets[b] * v_plt;
    EXPECT_NEAR(j["discharge_hematocrit"].get<double>(), rbcs[b] * v_rbc / blood, 1e-9) << layer.name;
    EXPECT_NEAR(j["platelets_per_s"].get<double>(), platelets[b], 1e-6 * platelets[b]) << layer.name;
    const double density = platelets[b] / blood;
    EXPECT_NEAR(j["discharge_platelet_density_per_m3"].get<double>(), density, 1e-9 * density) << layer.name;
    // A third of the red cells in each branch, all within its span and at most 0.8 R from its axis.
    EXPECT_DOUBLE_EQ(layer.mean_rbc_count, spec.rbcs / 3.0) << layer.name;
    EXPECT_GE(layer.whole.thickness, 0.2 * layer.radius - scene.rbc.diameter / 2) << layer.name;
    EXPECT_LT(layer.whole.thickness, layer.radius) << layer.name;
    EXPECT_EQ(j["cfl"]["stations"]["thickness_m"].size(), static_cast<std::size_t>(analysis::kBranchSlices));
    EXPECT_NE(table.find(fmt::format("{:<11} {:<9}", layer.name, ends[b])), std::string::npos) << table;
  }
  EXPECT_EQ(a.window_snapshots, 1);  // the snapshot at 0.04 s
}

// A surface run's observables in a study's table: outlet 1's shares and the in-vivo fit's, and
// none of a tube's (its cell-free layer, rheology and hematocrits are not measured there: n/a,
// not 0).
TEST(SurfaceRun, ItsStudyColumnsAreTheOutletsSharesAndNoneOfATubes) {
  const AnalysedSurfaceRun analysed("surface-columns");
  const auto& a = analysed.a;
  int surface = 0;
  for (const auto& o : analysis::observable_table()) {
    if (o.of_surface) {
      ++surface;
      if (o.name != "outlet_1_rbc_share_in_vivo") {
        EXPECT_TRUE(std::isfinite(o.value(a))) << o.name;
      }
    } else {
      EXPECT_TRUE(std::isnan(o.value(a))) << o.name;
      EXPECT_EQ(o.format(a), "n/a") << o.name;
    }
  }
  EXPECT_EQ(surface, 4);
  const auto blood = [&] {
    for (const auto& o : analysis::observable_table())
      if (o.name == "outlet_1_blood_share") return o.value(a);
    return std::nan("");
  }();
  EXPECT_EQ(blood, a.branches.front().blood);
}

// The outlets' shares over the run: outlet 1 takes rbc_1_early of rbc_in red cells a step over
// the first half and rbc_1_late after; the first and last intervals lie wholly in one half each.
TEST(SurfaceRun, TheOutletsSharesOverTimeFollowTheSplit) {
  const AnalysedSurfaceRun analysed("surface-shares");
  const SyntheticRun& spec = analysed.spec;
  const auto& a = analysed.a;
  ASSERT_GE(a.shares_over_time.size(), 3u);
  const auto& first = a.shares_over_time.front();
  const auto& last = a.shares_over_time.back();
  EXPECT_EQ(first.start, 0);
  EXPECT_NEAR(last.end, (spec.snapshots - 1) * spec.dt_s, 1e-12);
  ASSERT_EQ(first.shares.size(), 2u);
  EXPECT_EQ(first.shares[0].outlet, "outlet_1");
  EXPECT_NEAR(first.shares[0].rbc, spec.rbc_1_early / spec.rbc_in, 1e-9);
  EXPECT_NEAR(last.shares[0].rbc, spec.rbc_1_late / spec.rbc_in, 1e-9);
  EXPECT_NEAR(last.shares[1].rbc, 1 - spec.rbc_1_late / spec.rbc_in, 1e-9);
  EXPECT_NEAR(first.shares[0].platelet, spec.platelets_1 / spec.platelets_in, 1e-9);
  EXPECT_NEAR(first.shares[0].plasma, spec.plasma_1 / spec.plasma_in, 1e-9);
  for (std::size_t k = 1; k < a.shares_over_time.size(); ++k)
    EXPECT_EQ(a.shares_over_time[k].start, a.shares_over_time[k - 1].end);  // consecutive
  const auto json = nlohmann::json::parse(analysis::format_json(a));
  const auto& over = json["shares_over_time"];
  EXPECT_EQ(over["start_s"].size(), a.shares_over_time.size());
  EXPECT_NEAR(over["outlets"]["outlet_1"]["rbc_fraction"].back().get<double>(), spec.rbc_1_late / spec.rbc_in, 1e-9);
  EXPECT_NEAR(over["outlets"]["outlet_2"]["rbc_fraction"].front().get<double>(), 1 - spec.rbc_1_early / spec.rbc_in,
              1e-9);
}
