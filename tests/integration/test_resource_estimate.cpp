// `hemocosim check`'s estimate of the disk and memory a scene takes (coordinator/resource_estimate.h)
// against what a real run wrote and used, on a configuration other than the calibration's; and a
// scene that cannot fit any machine refused in one line.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_helpers.h"

#include "placement.h"
#include "resource_estimate.h"
#include "scene.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

using namespace hemo;
using namespace hemo::test;
namespace fs = std::filesystem;

namespace {

double bytes_under(const fs::path& p) {
  if (fs::is_regular_file(p)) return static_cast<double>(fs::file_size(p));
  double sum = 0;
  for (const auto& e : fs::recursive_directory_iterator(p))
    if (e.is_regular_file()) sum += static_cast<double>(e.file_size());
  return sum;
}

// profile.csv's "NODE,peak_memory_MiB,VALUE," row, in bytes.
double peak_memory(const std::string& dir, const std::string& node) {
  std::ifstream in(dir + "/profile.csv");
  const std::string prefix = node + ",peak_memory_MiB,";
  for (std::string line; std::getline(in, line);)
    if (line.rfind(prefix, 0) == 0) return std::stod(line.substr(prefix.size())) * 1024 * 1024;
  return 0;
}

// Estimated and measured agree within `factor` either way.
void expect_within(double estimated, double measured, double factor, const char* what) {
  EXPECT_GT(measured, 0) << what;
  EXPECT_LE(estimated, factor * measured) << what << ": estimated " << estimated << ", measured " << measured;
  EXPECT_GE(estimated, measured / factor) << what << ": estimated " << estimated << ", measured " << measured;
}

}  // namespace

// 36 steps with output every 4 and a checkpoint every 12 (the calibration's were 40 / 10 / 10 and
// 20 / 5 / 10): each part of the estimate within 1.5x of what the run wrote, peak memory too.
TEST(ResourceEstimate, ASmallRunWritesAndUsesWhatCheckSaid) {
  const std::string dir = fresh_run_dir("estimate");
  std::string text = small_scene_text(36);
  const std::string output = "every_steps = 10";
  ASSERT_NE(text.find(output), std::string::npos);
  text.replace(text.find(output), output.size(), "every_steps = 4\ncheckpoint_every_steps = 12");
  std::ofstream(dir + ".toml") << text;
  const auto r = run(bin("hemocosim") + " run " + dir + ".toml --out " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.output;

  const Scene s = load_scene(dir + ".toml");
  const ResourceEstimate e = estimate_resources(s, particles::rbc_count(s) + particles::platelet_count(s));
  EXPECT_EQ(e.outputs, 10);  // step 0 and every 4th of 36
  const double snapshots = bytes_under(dir + "/particles.h5"), fluid = bytes_under(dir + "/fluid"),
               checkpoint = bytes_under(dir + "/checkpoints"), metrics = bytes_under(dir + "/metrics.csv");
  std::printf(
      "estimated / written: particles.h5 %.0f / %.0f, fluid %.0f / %.0f, checkpoint %.0f / %.0f, "
      "metrics %.0f / %.0f B; memory fluid %.1f / %.1f, particles %.1f / %.1f MiB\n",
      e.snapshots_bytes, snapshots, e.fluid_output_bytes, fluid, e.checkpoint_bytes, checkpoint, e.metrics_bytes,
      metrics, e.fluid_rank_bytes / 1048576, peak_memory(dir, "fluid") / 1048576, e.particle_rank_bytes / 1048576,
      peak_memory(dir, "particles") / 1048576);
  expect_within(e.snapshots_bytes, snapshots, 1.5, "particles.h5");
  expect_within(e.fluid_output_bytes, fluid, 1.5, "fluid output");
  expect_within(e.checkpoint_bytes, checkpoint, 1.5, "the checkpoint kept");
  expect_within(e.metrics_bytes, metrics, 1.5, "metrics.csv");
  expect_within(e.fluid_rank_bytes, peak_memory(dir, "fluid"), 1.5, "fluid peak memory");
  expect_within(e.particle_rank_bytes, peak_memory(dir, "particles"), 1.5, "particle peak memory");
}

// 10^9 steps with a snapshot at every one: tens of terabytes, refused with one line, exit non-zero.
TEST(ResourceEstimate, CheckRefusesABillionStepsWithOutputAtEveryOne) {
  std::string text = small_scene_text(1000000000);
  const std::string output = "every_steps = 10";
  ASSERT_NE(text.find(output), std::string::npos);
  text.replace(text.find(output), output.size(), "every_steps = 1");
  const std::string scene = fresh_run_dir("estimate-huge") + ".toml";
  std::ofstream(scene) << text;
  const auto r = run(bin("hemocosim") + " check " + scene);
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("REFUSED"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("TB of disk"), std::string::npos) << r.output;
  EXPECT_NE(error_line(r.output).find("would not fit this machine"), std::string::npos) << r.output;
  // The small scene as it is fits, without a warning.
  const auto ok = run(bin("hemocosim") + " check " + test::scene("coupled_small.toml"));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("  disk        ~"), std::string::npos) << ok.output;
  EXPECT_NE(ok.output.find("  memory      ~"), std::string::npos) << ok.output;
  EXPECT_EQ(ok.output.find("REFUSED"), std::string::npos) << ok.output;
  EXPECT_EQ(ok.output.find("warning"), std::string::npos) << ok.output;
}
