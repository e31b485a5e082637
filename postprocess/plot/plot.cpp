// SPDX-License-Identifier: GPL-3.0-or-later
#include "plot.h"

#include "analyze.h"
#include "child_process.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#ifndef HEMO_PLOT_SCRIPT_SOURCE
#define HEMO_PLOT_SCRIPT_SOURCE ""
#endif

namespace fs = std::filesystem;

namespace hemo {

namespace {

constexpr const char* kScriptName = "hemocosim_plot.py";

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw std::runtime_error(path + ": cannot write");
}

// True if `file` exists and was written no earlier than `than` (or `than` does not exist).
bool up_to_date(const fs::path& file, const fs::path& than) {
  std::error_code ec;
  if (!fs::exists(file, ec)) return false;
  if (!fs::exists(than, ec)) return true;
  return fs::last_write_time(file, ec) >= fs::last_write_time(than, ec);
}

// An analysis.json that a reader of this version can use: it parses, names the vessel's shape (a
// narrowing one's "axial" figure) and says whether it is a surface vessel's (whose figures are its
// outlets' and branches'); a tube's declares its observables (the plot script draws the sweep
// figure from that declaration) and has the momentum balance over time (the balance figure).
bool current_analysis(const fs::path& json) {
  std::ifstream in(json);
  try {
    const auto j = nlohmann::json::parse(in);
    if (!j.contains("vessel") || !j["vessel"].contains("shape") || !j["vessel"].contains("surface")) return false;
    if (j["vessel"]["surface"].get<bool>()) return true;
    return j.contains("observables") && j.contains("momentum_balance") && j["momentum_balance"].contains("over_time");
  } catch (const nlohmann::json::exception&) {
    return false;
  }
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

}  // namespace

analysis::Analysis analyze_run_dir(const std::string& run_dir) {
  AnalyzeOptions opt;
  opt.run_dir = run_dir;
  const auto run = analysis::open_run(run_dir);
  auto a = analysis::analyze_run(run, opt);
  const fs::path dir(run_dir);
  write_file((dir / "analysis.json").string(), analysis::format_json(a));
  write_file((dir / "profiles.csv").string(), analysis::format_profiles_csv(a));
  return a;
}

bool ensure_analysis(const std::string& run_dir, bool force) {
  const fs::path dir(run_dir), h5 = dir / "particles.h5";
  if (!force && up_to_date(dir / "analysis.json", h5) && up_to_date(dir / "profiles.csv", h5) &&
      current_analysis(dir / "analysis.json"))
    return false;
  analyze_run_dir(run_dir);
  return true;
}

std::string find_plot_script() {
  std::vector<std::string> tried;
  auto candidate = [&tried](const std::string& p) {
    if (p.empty()) return false;
    tried.push_back(p);
    std::error_code ec;
    return fs::is_regular_file(p, ec);
  };
  if (const char* env = std::getenv("HEMOCOSIM_PLOT_SCRIPT"); env && *env) {
    if (candidate(env)) return env;
    throw std::runtime_error(fmt::format("HEMOCOSIM_PLOT_SCRIPT={} does not exist", env));
  }
  const std::string installed =
      (fs::path(executable_dir()) / ".." / "share" / "hemocosim" / kScriptName).lexically_normal();
  if (candidate(installed)) return installed;
  if (candidate(HEMO_PLOT_SCRIPT_SOURCE)) return HEMO_PLOT_SCRIPT_SOURCE;
  throw std::runtime_error(
      fmt::format("cannot find {} (tried {}); set HEMOCOSIM_PLOT_SCRIPT", kScriptName, join(tried, ", ")));
}

std::string find_python() {
  static std::string found;
  if (!found.empty()) return found;
  std::vector<std::string> candidates;
  if (const char* env = std::getenv("HEMOCOSIM_PYTHON"); env && *env) candidates.push_back(env);
  candidates.push_back("/usr/bin/python3");
  candidates.push_back("python3");
  ChildOptions quiet;
  quiet.quiet = true;
  for (const auto& py : candidates) {
    if (run_child({py, "-c", "import matplotlib, numpy"}, quiet).ok()) return found = py;
  }
  throw std::runtime_error(
      fmt::format("no Python 3 with matplotlib and numpy (tried {}); install python3-matplotlib python3-numpy "
                  "(deploy/install-deps.sh) or set HEMOCOSIM_PYTHON",
                  join(candidates, ", ")));
}

std::vector<std::string> plot_runs(const PlotOptions& opt) {
  if (opt.run_dirs.empty()) throw std::runtime_error("plot: no run directory given");
  if (!opt.labels.empty() && opt.labels.size() != opt.run_dirs.size())
    throw std::runtime_error(fmt::format("plot: {} labels for {} runs", opt.labels.size(), opt.run_dirs.size()));
  for (const auto& d : opt.run_dirs) {
    std::error_code ec;
    if (!fs::is_directory(d, ec)) throw std::runtime_error(d + ": no such run directory");
    if (!fs::exists(fs::path(d) / "scene.toml", ec) && !fs::exists(fs::path(d) / "particles.h5", ec))
      throw std::runtime_error(d + ": not a run directory (no scene.toml, no particles.h5)");
  }
  // Analysis first, so that a run without snapshots fails here with the reader's one line.
  for (const auto& d : opt.run_dirs) ensure_analysis(d, opt.reanalyze);

  const std::string out = !opt.out.empty()           ? opt.out
                          : opt.run_dirs.size() == 1 ? (fs::path(opt.run_dirs[0]) / "figures").string()
                                                     : "figures";
  fs::create_directories(out);
  std::vector<std::string> argv = {find_python(), find_plot_script(), "--out", out};
  if (!opt.key.empty()) argv.insert(argv.end(), {"--key", opt.key});
  if (!opt.labels.empty()) argv.insert(argv.end(), {"--labels", join(opt.labels, ",")});
  if (!opt.xlabel.empty()) argv.insert(argv.end(), {"--xlabel", opt.xlabel});
  argv.insert(argv.end(), opt.run_dirs.begin(), opt.run_dirs.end());

  std::vector<std::string> written;
  ChildOptions child;
  child.env = {{"MPLBACKEND", "Agg"}, {"PYTHONDONTWRITEBYTECODE", "1"}};
  child.on_line = [&written](const std::string& line) { written.push_back(line); };
  const auto r = run_child(argv, child);
  if (!r.ok()) throw std::runtime_error(fmt::format("plot script {} {}", argv[1], r.describe()));
  for (const auto& w : written) {
    std::error_code ec;
    if (!fs::is_regular_file(w, ec) || fs::file_size(w, ec) == 0)
      throw std::runtime_error(fmt::format("plot script reported {} but it is missing or empty", w));
  }
  return written;
}

int plot_command(const PlotOptions& opt) {
  const auto files = plot_runs(opt);
  if (!opt.quiet)
    for (const auto& f : files) fmt::print("{}\n", f);
  return 0;
}

}  // namespace hemo
