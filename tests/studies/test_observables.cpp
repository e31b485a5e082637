// Every observable declared in postprocess/analysis/observable_table.h reaches every output: the
// text table of `analyze`, analysis.json, a study's summary.csv and its report.md, each with the
// value the analysis computed. A study of synthetic runs (no nodes) provides all four.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "analyze.h"
#include "observable_table.h"
#include "study.h"
#include "synthetic_run.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

using namespace hemo;
using namespace hemo::studytest;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      cells.push_back(cell);
      cell.clear();
    } else {
      cell += c;
    }
  }
  cells.push_back(cell);
  return cells;
}

// summary.csv as one map column -> cell per row.
std::vector<std::map<std::string, std::string>> read_summary(const std::string& path,
                                                             std::vector<std::string>* header) {
  std::istringstream in(read_text(path));
  std::string line;
  std::getline(in, line);
  *header = split_csv_line(line);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    const auto cells = split_csv_line(line);
    EXPECT_EQ(cells.size(), header->size()) << line;
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < cells.size() && i < header->size(); ++i) row[(*header)[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json::json_pointer pointer(const std::string& dotted) {
  std::string p = "/" + dotted;
  for (char& c : p) c = c == '.' ? '/' : c;
  return nlohmann::json::json_pointer(p);
}

// The synthetic runs' observables, through `hemocosim study`'s own runner stand-in.
struct AnalysedStudy {
  ScratchDir dir{"observables"};
  std::string out;
  AnalysedStudy() {
    write_text(dir.str() + "/base.toml", kSmallBaseScene);
    write_text(dir.str() + "/ht.toml",
               "base = \"base.toml\"\n[sweep]\nkey = \"rbc.hematocrit\"\nvalues = [0.1, 0.2]\n");
    StudyOptions opt;
    opt.study = dir.str() + "/ht.toml";
    opt.out = out = dir.str() + "/out";
    opt.quiet = true;
    opt.no_plot = true;
    unsigned seed = 0;
    opt.runner = [&seed](const std::string& scene, const std::string& run_dir, const std::string&,
                         const std::function<void(const std::string&)>&) {
      SyntheticRun spec;
      spec.seed = ++seed;
      write_synthetic_run(run_dir, scene, spec);
      return 0;
    };
    const auto r = run_study(opt);
    EXPECT_EQ(r.failed(), 0);
  }
};

}  // namespace

TEST(Observables, NamesPathsAndLabelsAreUnique) {
  std::set<std::string_view> names, paths, labels;
  for (const auto& o : analysis::observable_table()) {
    EXPECT_TRUE(names.insert(o.name).second) << o.name;
    EXPECT_TRUE(paths.insert(o.json_path).second) << o.json_path;
    EXPECT_TRUE(labels.insert(o.label).second) << o.label;
    EXPECT_FALSE(o.unit.empty()) << o.name;
    EXPECT_FALSE(o.description.empty()) << o.name;
    EXPECT_NE(o.of, nullptr) << o.name;
  }
  // The study's own columns are not observables' names.
  for (const char* own : {"index", "label", "swept_value", "status", "wall_s", "run_dir"})
    EXPECT_EQ(names.count(own), 0u) << own;
}

TEST(Observables, EveryDeclaredObservableReachesTableJsonSummaryAndReport) {
  const AnalysedStudy study;
  std::vector<std::string> header;
  const auto rows = read_summary(study.out + "/summary.csv", &header);
  ASSERT_EQ(rows.size(), 2u);
  const std::string report = read_text(study.out + "/report.md");
  const auto& table = analysis::observable_table();
  ASSERT_FALSE(table.empty());

  // The columns: the study's own around the observables, in the table's order.
  std::vector<std::string> expected_header = {"index", "label", "swept_value", "status"};
  for (const auto& o : table) expected_header.emplace_back(o.name);
  expected_header.insert(expected_header.end(), {"wall_s", "run_dir"});
  EXPECT_EQ(header, expected_header);

  // analysis.json declares them too, in the same order (hemocosim_plot.py draws from that).
  {
    const auto json = nlohmann::json::parse(read_text(rows.front().at("run_dir") + "/analysis.json"));
    ASSERT_TRUE(json.contains("observables"));
    const auto& declared = json["observables"];
    ASSERT_EQ(declared.size(), table.size());
    for (std::size_t i = 0; i < table.size(); ++i) {
      EXPECT_EQ(declared[i]["name"], std::string(table[i].name));
      EXPECT_EQ(declared[i]["path"], std::string(table[i].json_path));
      EXPECT_EQ(declared[i]["sweep_panel"], std::string(table[i].sweep_panel));
    }
  }

  int finite = 0;
  for (const auto& row : rows) {
    const std::string run_dir = row.at("run_dir");
    AnalyzeOptions opt;
    opt.run_dir = run_dir;
    const auto a = analysis::analyze_run(analysis::open_run(run_dir), opt);
    const auto json = nlohmann::json::parse(read_text(run_dir + "/analysis.json"));
    const std::string text = analysis::format_table(a);
    const std::string dir_name = fs::path(run_dir).filename().string();
    const auto report_row_at = report.find("| " + dir_name + " |");
    ASSERT_NE(report_row_at, std::string::npos) << report;
    const std::string report_row = report.substr(report_row_at, report.find('\n', report_row_at) - report_row_at);

    for (const auto& o : table) {
      SCOPED_TRACE(std::string(o.name) + " of " + dir_name);
      const double v = o.value(a);
      finite += std::isfinite(v);
      // analysis.json: a number at its path (null when undefined), exactly the value.
      const auto ptr = pointer(std::string(o.json_path));
      ASSERT_TRUE(json.contains(ptr)) << o.json_path;
      if (std::isfinite(v)) {
        ASSERT_TRUE(json.at(ptr).is_number()) << json.at(ptr);
        EXPECT_EQ(json.at(ptr).get<double>(), v);
      } else {
        EXPECT_TRUE(json.at(ptr).is_null()) << json.at(ptr);
      }
      // summary.csv: the value to its 9 significant digits, empty when undefined.
      const std::string cell = row.at(std::string(o.name));
      if (std::isfinite(v)) {
        ASSERT_FALSE(cell.empty());
        EXPECT_NEAR(std::stod(cell), v, 5e-9 * std::abs(v)) << cell;
      } else {
        EXPECT_EQ(cell, "");
      }
      // The text table: a line of its own with the label and the printed value.
      const auto at = text.find("\n  " + std::string(o.label) + " ");
      ASSERT_NE(at, std::string::npos) << text;
      const std::string line = text.substr(at + 1, text.find('\n', at + 1) - at - 1);
      EXPECT_NE(line.find(" " + o.format(a)), std::string::npos) << line;
      // report.md: its column and, in the run's row, the printed value; its line in the legend.
      EXPECT_NE(report.find("| " + o.header() + " |"), std::string::npos) << o.header();
      EXPECT_NE(report_row.find("| " + o.format(a) + " |"), std::string::npos) << report_row;
      EXPECT_NE(report.find("- " + o.header() + ": " + std::string(o.description)), std::string::npos);
    }
  }
  // Undefined values pass trivially; most of the synthetic runs' must be defined.
  EXPECT_GT(finite, static_cast<int>(table.size()));
}
