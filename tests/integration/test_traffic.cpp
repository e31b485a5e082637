// The bytes each rank sends and receives per coupling step (common/traffic.h), measured on real
// runs of the small scene and checked against what the messages must weigh.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_helpers.h"

#include <momentum_forms.h>
#include <scene.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace hemo::test;

namespace {

// RUN_DIR/profile.csv's NODE,NAME,VALUE rows.
std::map<std::pair<std::string, std::string>, double> read_profile(const std::string& dir) {
  std::ifstream in(dir + "/profile.csv");
  std::string line;
  std::getline(in, line);
  std::map<std::pair<std::string, std::string>, double> p;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string node, name, value;
    std::getline(row, node, ',');
    std::getline(row, name, ',');
    std::getline(row, value, ',');
    if (!value.empty()) p[{node, name}] = std::stod(value);
  }
  return p;
}

// The fluid cells the particle node says it runs in (its log).
long fluid_cells(const std::string& dir) {
  std::smatch m;
  const std::string log = file_text(dir + "/particles.log");
  if (!std::regex_search(log, m, std::regex(R"(in (\d+) fluid cells)")))
    throw std::runtime_error("no cell count in " + dir);
  return std::stol(m[1]);
}

struct SmallRun {
  std::string dir;
  long cells = 0;
  Metrics metrics;
};

SmallRun run_small(const std::string& name, int axial_cells, const std::string& ranks = "") {
  std::string text = small_scene_text(12);
  const std::string axial = "axial_cells = 6";
  if (text.find(axial) == std::string::npos) throw std::runtime_error("coupled_small.toml lost its axial_cells = 6");
  text.replace(text.find(axial), axial.size(), "axial_cells = " + std::to_string(axial_cells));
  SmallRun r;
  r.dir = fresh_run_dir(name);
  const std::string scene_file = r.dir + ".toml";
  std::ofstream(scene_file) << text;
  const auto result = run(bin("hemocosim") + " run " + scene_file + " --out " + r.dir + ranks);
  EXPECT_EQ(result.exit_code, 0) << result.output;
  r.cells = fluid_cells(r.dir);
  r.metrics = read_metrics(r.dir);
  return r;
}

std::vector<double> over_steps(const SmallRun& r, const std::string& node, const std::string& name) {
  return hemo::test::over_steps(r.metrics, node, name);
}

double smallest(const std::vector<double>& v) { return v.empty() ? -1 : *std::min_element(v.begin(), v.end()); }

}  // namespace

// The fluid master's FLUID_STATE bytes are its messages' encoded size: 8 bytes a value, so many
// values a cell as the momentum form publishes, and one header. A step in which a lost or early
// resend request made it publish again counts the message twice, so every step's count is a
// whole number of messages. The particle node counts the same bytes arriving, and refining the
// mesh along its axis adds exactly the new cells' values.
TEST(Traffic, TheFluidMastersStateBytesAreItsMessagesAndGrowWithTheCells) {
  const SmallRun coarse = run_small("traffic-coarse", 6), fine = run_small("traffic-fine", 12);
  ASSERT_EQ(fine.cells, 2 * coarse.cells);
  const hemo::MomentumForm& form = hemo::momentum_form(hemo::Scene{}.momentum);
  const double values_per_cell = 3 + 9 + 3 * form.needs_pressure_gradient() + 3 * form.needs_viscous_force();

  double header = -1;
  for (const SmallRun* r : {&coarse, &fine}) {
    const auto sent = over_steps(*r, "fluid", "bus_sent_fluid_state_B");
    ASSERT_EQ(sent.size(), 12u) << r->dir;
    const double message = smallest(sent);
    for (double s : sent)
      EXPECT_EQ(std::fmod(s, message), 0.0) << r->dir << ": " << s << " B for a " << message << "-B message";
    // The particles received these datagrams, byte for byte.
    EXPECT_EQ(smallest(over_steps(*r, "particles", "bus_received_fluid_state_B")), message) << r->dir;
    const double this_header = message - 8 * values_per_cell * static_cast<double>(r->cells);
    std::printf("[ info ] %ld cells: FLUID_STATE %.0f B (%.0f B a cell + %.0f B)\n", r->cells, message,
                8 * values_per_cell, this_header);
    EXPECT_GT(this_header, 0);
    EXPECT_LT(this_header, 1024);  // the envelope, the mesh hash, time and four lengths
    if (header >= 0) {
      EXPECT_EQ(this_header, header) << "the message's header changed with the mesh";
    }
    header = this_header;

    // One rank: the master's bytes are its bus's, the state among them. The coordinator does
    // not listen to the state: it receives less a step than one state weighs.
    const auto rank0 = over_steps(*r, "fluid", "rank0_sent_B");
    ASSERT_EQ(rank0.size(), sent.size());
    for (std::size_t i = 0; i < rank0.size(); ++i) EXPECT_GE(rank0[i], sent[i]) << r->dir << " step " << i + 1;
    const auto profile = read_profile(r->dir);
    EXPECT_GE(profile.at({"fluid", "rank0_sent_B_per_step"}), message) << r->dir;
    EXPECT_GE(profile.at({"particles", "rank0_received_B_per_step"}), message) << r->dir;
    EXPECT_GT(profile.at({"coordinator", "rank0_sent_B_per_step"}), 0) << r->dir;
    EXPECT_LT(profile.at({"coordinator", "rank0_received_B_per_step"}), message) << r->dir;
    // What loss cost is beside each process's bytes, a part of them (common/traffic.h).
    for (const char* node : {"fluid", "particles", "coordinator"}) {
      EXPECT_LE(profile.at({node, "rank0_resent_B_per_step"}), profile.at({node, "rank0_sent_B_per_step"}))
          << r->dir << " " << node;
      EXPECT_LE(profile.at({node, "rank0_received_again_B_per_step"}), profile.at({node, "rank0_received_B_per_step"}))
          << r->dir << " " << node;
    }
  }
}

// Two ranks each (the partitioned exchange, test_partitioned_run.cpp): the non-master fluid rank
// takes the order (5 doubles) from the master and its readers' partial feedback straight from the
// particle ranks every step, and sends nothing but its partitions of the state, straight to the
// particle ranks, and its own step reports and heartbeats to the coordinator; each particle rank
// reports the state it took and the feedback it sent on its own channels.
TEST(Traffic, EveryRankOfTwoReportsItsOwnBytes) {
  const SmallRun r = run_small("traffic-2x2", 6, " --np-fluid 2 --np-particles 2");
  const auto received = over_steps(r, "fluid", "rank1_received_B"), sent = over_steps(r, "fluid", "rank1_sent_B");
  const auto partitions = over_steps(r, "fluid", "rank1_sent_fluid_state_B");
  const auto partials = over_steps(r, "fluid", "rank1_received_feedback_B");
  ASSERT_EQ(received.size(), 12u);
  ASSERT_EQ(sent.size(), 12u);
  ASSERT_EQ(partitions.size(), 12u);
  ASSERT_EQ(partials.size(), 12u);
  double all_sent = 0, all_partitions = 0, all_received = 0, all_expected = 0;
  for (std::size_t i = 0; i < received.size(); ++i) {
    // Its own bus also hears every rank's resend requests (the channel is shared).
    EXPECT_GE(received[i], 8 * 5 + partials[i]) << "step " << i + 1;
    EXPECT_GT(partitions[i], 0) << "step " << i + 1;
    EXPECT_GT(partials[i], 0) << "step " << i + 1;
    all_sent += sent[i];
    all_partitions += partitions[i];
    all_received += received[i];
    all_expected += 8 * 5 + partials[i];
  }
  // A resend its own thread answers may fall between the two counts of one step, not of the run.
  // Beside its partitions, the rank sends its own step reports and heartbeats.
  double all_reports = 0;
  for (double b : over_steps(r, "fluid", "rank1_sent_report_B")) all_reports += b;
  EXPECT_GT(all_reports, 0);
  EXPECT_NEAR(all_sent, all_partitions + all_reports, 0.01 * all_partitions)
      << "fluid rank 1 sent more than its partitions and its reports";
  // Beside the order and its partials, it hears only resend requests (their channel is shared):
  // far less than the 40 B a cell a step the scatter of the whole feedback brought.
  EXPECT_LT(all_received - all_expected, 0.25 * 40 * static_cast<double>(r.cells) * 12)
      << "fluid rank 1 received more than the order and its partials";
  for (const char* rank : {"rank0", "rank1"}) {
    for (double b : over_steps(r, "particles", std::string(rank) + "_received_fluid_state_B")) EXPECT_GT(b, 0) << rank;
    for (double b : over_steps(r, "particles", std::string(rank) + "_sent_feedback_B")) EXPECT_GT(b, 0) << rank;
  }
  std::printf("[ info ] 2 x 2 ranks, %ld cells: fluid rank 1 sends %.0f B and receives %.0f B a step\n", r.cells,
              sent.front(), received.front());
}
