// SPDX-License-Identifier: GPL-3.0-or-later
#include "study.h"

#include "checkpoint.h"
#include "child_process.h"
#include "observable_table.h"
#include "plot.h"
#include "scene.h"

#include <fmt/format.h>

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

namespace hemo {

namespace {

volatile int interrupted = 0;  // set by study_command's SIGINT/SIGTERM handler
void on_signal(int) { interrupted = 1; }

// FNV-1a, 64 bit: a stable fingerprint of a scene's text for the finished marker.
std::string fingerprint(const std::string& text) {
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  return fmt::format("{:016x}", h);
}

std::string utc_now() {
  char buf[32];
  const std::time_t t = std::time(nullptr);
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The last line of a log that says what went wrong.
std::string failure_line(const std::string& log_path) {
  std::ifstream in(log_path);
  std::string line, last, error;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    last = line;
    if (line.find("error") != std::string::npos) error = line;
  }
  return !error.empty() ? error : last;
}

// Removes an unfinished run directory before it is redone; refuses anything that does not look
// like one (a run directory always has its scene.toml from the first moment).
void remove_unfinished(const std::string& run_dir) {
  std::error_code ec;
  if (!fs::exists(run_dir, ec)) return;
  if (!fs::is_directory(run_dir) || (!fs::is_empty(run_dir) && !fs::exists(fs::path(run_dir) / "scene.toml")))
    throw StudyError(run_dir + " exists and is not a run directory; move it away");
  fs::remove_all(run_dir);
}

// The checkpoint an unfinished run of this very scene can go on from (none: it is redone).
std::optional<long> resumable_from(const std::string& run_dir, const std::string& scene_text) {
  std::ifstream in(fs::path(run_dir) / "scene.toml");
  if (!in) return std::nullopt;
  std::stringstream ran;
  ran << in.rdbuf();
  if (ran.str() != scene_text) return std::nullopt;
  const auto last = last_complete_checkpoint(run_dir);
  // With adaptive intervals the number of steps is not known in advance: a checkpoint at the
  // end resumes into a run that is done at once.
  const Timing time = load_scene((fs::path(run_dir) / "scene.toml").string()).time;
  if (!last || (!time.adaptive_interval() && *last >= time.coupling_steps)) return std::nullopt;
  return last;
}

// `hemocosim run SCENE --out RUN_DIR`, or `hemocosim resume RUN_DIR` when RUN_DIR was kept.
// A developed feeder (vessel.feeder_develop_s) is kept in `feeder_cache` for the runs whose feeder
// is the same (a swept key that is not the feeder's: each is developed once).
SceneRunner child_runner(const std::string& hemocosim, const std::string& feeder_cache) {
  return [hemocosim, feeder_cache](const std::string& scene, const std::string& run_dir, const std::string& log_path,
                                   const std::function<void(const std::string&)>& progress) {
    const std::vector<std::string> args =
        fs::exists(fs::path(run_dir) / "scene.toml")
            ? std::vector<std::string>{hemocosim, "resume", run_dir}
            : std::vector<std::string>{hemocosim, "run", scene, "--out", run_dir, "--feeder-cache", feeder_cache};
    std::ofstream log(log_path, std::ios::app);
    log << "$";
    for (const auto& a : args) log << " " << a;
    log << "\n";
    log.flush();
    ChildOptions opt;
    opt.merge_stderr = true;
    opt.stop_flag = &interrupted;  // SIGTERM (batch time limit) reaches only us: pass it on as SIGINT
    opt.on_line = [&](const std::string& line) {
      log << line << "\n";
      log.flush();
      if (progress && (line.rfind("step ", 0) == 0 || line.find("error") != std::string::npos ||
                       line.find("the feeder develops") != std::string::npos))
        progress(line);
    };
    const auto r = run_child(args, opt);
    log << "# hemocosim " << args[1] << " " << r.describe() << "\n";
    return r.exit_code;
  };
}

// ---- Report ----------------------------------------------------------------------------------

std::string csv_num(double v) { return std::isfinite(v) ? fmt::format("{:.9g}", v) : ""; }

const char* state_name(StudyRunStatus::State s) {
  switch (s) {
    case StudyRunStatus::State::ran:
      return "ran";
    case StudyRunStatus::State::skipped:
      return "finished earlier";
    case StudyRunStatus::State::failed:
      return "failed";
  }
  return "";
}

struct Row {
  const StudyRunStatus* run = nullptr;
  bool analysed = false;
  analysis::Analysis a;
  std::string error;
};

std::string swept_header(const Study& s) {
  std::string h;
  for (const auto& k : s.keys) h += (h.empty() ? "" : ", ") + k;
  return h;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string summary_csv(const Study& study, const std::vector<Row>& rows) {
  const auto& observables = analysis::observable_table();
  std::string c = "index,label,swept_value,status";
  for (const auto& o : observables) c += fmt::format(",{}", o.name);
  c += ",wall_s,run_dir\n";
  for (const auto& r : rows) {
    const auto& st = *r.run;
    c += fmt::format("{},{},{},{}", st.study_case.index + 1, csv_field(st.study_case.label),
                     csv_field(study.value_text(st.study_case.index)), state_name(st.state));
    for (const auto& o : observables) c += "," + (r.analysed ? csv_num(o.value(r.a)) : std::string());
    c += fmt::format(",{:.1f},{}\n", st.wall_s, csv_field(st.run_dir));
  }
  return c;
}

std::string report_md(const Study& study, const StudyOptions& opt, const Reduction* reduction, const std::string& out,
                      const std::vector<Row>& rows, const std::vector<std::string>& figures,
                      const std::string& figure_error) {
  std::string m;
  m += fmt::format("# Study: {}\n\n", study.name);
  if (!study.title.empty()) m += study.title + "\n\n";
  m += fmt::format("- study file: `{}` (copy: `study.toml`)\n", study.path);
  m += fmt::format("- base scene: `{}`\n", study.base);
  m += fmt::format("- swept: `{}` over {} values\n", swept_header(study), study.size());
  if (!study.set_toml.empty()) m += "- fixed for every run ([set] of the study file): see `study.toml`\n";
  m +=
      fmt::format("- generated: {} by `hemocosim study {}{}`\n", utc_now(), opt.study, opt.reduced ? " --reduced" : "");
  if (reduction)
    m += fmt::format("- **reduced** (`--reduced`): {}\n", reduction->describe());
  else
    m += "- full size: the scenes as the study file and base scene give them\n";
  if (!study.expectation.empty())
    m += fmt::format("\nExpected (the study file's `expectation`; the paper's own studies: docs/model.md §4): {}\n",
                     study.expectation);
  if (reduction)
    m += "\nThese are reduced runs: compare them with the expectation above only where they are long enough to "
         "show it; the numbers below are what the reduced runs give, nothing more.\n";

  const auto& observables = analysis::observable_table();
  m += "\n## Observables\n\n";
  for (const auto& o : observables) m += fmt::format("- {}: {}\n", o.header(), o.description);
  m += "\nWindow: second half of each run.\n\n";
  m += fmt::format("| {} | run |", swept_header(study));
  for (const auto& o : observables) m += fmt::format(" {} |", o.header());
  m += " wall (s) | status |\n|---|---|";
  for (std::size_t i = 0; i < observables.size(); ++i) m += "---|";
  m += "---|---|\n";
  for (const auto& r : rows) {
    const auto& st = *r.run;
    m += fmt::format("| {} | {} |", study.value_text(st.study_case.index), st.study_case.dir_name);
    for (const auto& o : observables) m += r.analysed ? fmt::format(" {} |", o.format(r.a)) : std::string(" |");
    const char* status = r.analysed                                  ? state_name(st.state)
                         : st.state == StudyRunStatus::State::failed ? "failed"
                                                                     : "not analysed";
    m += fmt::format(" {:.1f} | {} |\n", st.wall_s, status);
  }
  m += "\nThe same as CSV: `summary.csv`. Each run's full analysis: `runs/<run>/analysis.json` "
       "(`hemocosim analyze runs/<run>` prints it as a table).\n";

  m += "\n## Figures\n\n";
  if (!figure_error.empty()) m += fmt::format("Figures not drawn: {}\n", figure_error);
  for (const auto& f : figures) {
    const std::string rel = fs::path(f).lexically_relative(out).string();
    m += fmt::format("![{}]({})\n\n", fs::path(f).stem().string(), rel);
  }

  std::string notes;
  for (const auto& r : rows) {
    for (const auto& n : r.a.notes) notes += fmt::format("- {}: {}\n", r.run->study_case.dir_name, n);
    if (!r.error.empty()) notes += fmt::format("- {}: {}\n", r.run->study_case.dir_name, r.error);
    if (!r.run->why.empty()) notes += fmt::format("- {}: {}\n", r.run->study_case.dir_name, r.run->why);
  }
  if (!notes.empty()) m += "\n## Notes\n\n" + notes;
  return m;
}

}  // namespace

int StudyResult::failed() const {
  int n = 0;
  for (const auto& r : runs) n += r.state == StudyRunStatus::State::failed;
  return n;
}

void write_finished_marker(const std::string& run_dir, const std::string& scene_text, double wall_s) {
  std::ofstream out(fs::path(run_dir) / kFinishedMarker);
  out << "# Written by `hemocosim study` when this run ended cleanly; a study skips runs that have it.\n";
  out << fmt::format("scene_fingerprint = \"{}\"\nwall_s = {:.3f}\nfinished = \"{}\"\n", fingerprint(scene_text),
                     wall_s, utc_now());
  if (!out) throw StudyError(run_dir + ": cannot write " + kFinishedMarker);
}

bool run_finished(const std::string& run_dir, const std::string& scene_text, std::string* why, double* wall_s) {
  auto say = [why](const std::string& s) {
    if (why) *why = s;
    return false;
  };
  std::error_code ec;
  if (!fs::exists(run_dir, ec)) return say("no run yet");
  const fs::path marker = fs::path(run_dir) / kFinishedMarker;
  if (!fs::exists(marker, ec)) return say("unfinished (no " + std::string(kFinishedMarker) + "): redone");
  toml::table t;
  try {
    t = toml::parse_file(marker.string());
  } catch (const toml::parse_error&) {
    return say("unreadable " + std::string(kFinishedMarker) + ": redone");
  }
  if (t["scene_fingerprint"].value_or(std::string()) != fingerprint(scene_text))
    return say("the scene changed since it ran: redone");
  if (wall_s) *wall_s = t["wall_s"].value_or(0.0);
  if (why) why->clear();
  return true;
}

StudyResult run_study(const StudyOptions& opt) {
  const Study study = load_study(resolve_study(opt.study));
  const Reduction reduction_spec;
  const Reduction* reduction = opt.reduced ? &reduction_spec : nullptr;
  StudyResult result;
  result.out = !opt.out.empty() ? opt.out : fmt::format("runs/study-{}{}", study.name, opt.reduced ? "-reduced" : "");
  const fs::path out(result.out);
  fs::create_directories(out / "runs");
  fs::create_directories(out / "logs");
  fs::copy_file(study.path, out / "study.toml", fs::copy_options::overwrite_existing);
  const auto cases = expand_study(study, (out / "scenes").string(), reduction,
                                  opt.check_placement ? SceneCheck::placement : SceneCheck::values);

  auto say = [&opt](const std::string& line) {
    if (!opt.quiet) fmt::print(stderr, "{}\n", line);
  };
  const std::string hemocosim =
      !opt.hemocosim.empty() ? opt.hemocosim : (fs::path(executable_dir()) / "hemocosim").string();
  const SceneRunner runner = opt.runner ? opt.runner : child_runner(hemocosim, (out / "feeder-develop").string());

  // Decide first, so that the plan is printed before anything runs.
  std::vector<bool> done(cases.size());
  std::vector<std::string> why(cases.size());
  std::vector<double> earlier_wall(cases.size(), 0.0);
  std::size_t todo = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const std::string dir = (out / "runs" / cases[i].dir_name).string();
    done[i] = run_finished(dir, cases[i].scene_text, &why[i], &earlier_wall[i]);
    todo += !done[i];
  }
  say(fmt::format("study {}: {} runs of {} in {}{}; {} finished earlier, {} to run", study.name, cases.size(),
                  swept_header(study), result.out, opt.reduced ? " (reduced)" : "", cases.size() - todo, todo));

  const auto n = cases.size();
  double ran_s = 0;  // wall time of the runs done in this call, for the estimate of the rest
  std::size_t ran = 0, failed_now = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& c = cases[i];
    if (interrupted)
      throw StudyError(fmt::format("interrupted before run {}; rerun the same command to resume", c.dir_name));
    StudyRunStatus st;
    st.study_case = c;
    st.run_dir = (out / "runs" / c.dir_name).string();
    const std::string tag = fmt::format("[{}/{} {}]", i + 1, n, c.label);
    if (done[i]) {
      st.state = StudyRunStatus::State::skipped;
      st.wall_s = earlier_wall[i];
      say(fmt::format("{} finished earlier: skipped ({})", tag, st.run_dir));
      result.runs.push_back(st);
      continue;
    }
    const auto checkpoint = resumable_from(st.run_dir, c.scene_text);
    if (checkpoint) why[i] = fmt::format("unfinished: goes on from its checkpoint of step {}", *checkpoint);
    if (why[i] != "no run yet") {
      say(fmt::format("{} {}", tag, why[i]));
      st.why = why[i];
    }
    if (!checkpoint) remove_unfinished(st.run_dir);
    const std::string log = (out / "logs" / (c.dir_name + ".log")).string();
    say(fmt::format("{} {} = {}: running into {}", tag, swept_header(study), study.value_text(i), st.run_dir));
    const auto start = std::chrono::steady_clock::now();
    const int code = runner(c.scene_path, st.run_dir, log, [&](const std::string& line) { say(tag + " " + line); });
    st.wall_s = seconds_since(start);
    if (interrupted)
      throw StudyError(fmt::format("interrupted during run {}; rerun the same command to resume", c.dir_name));
    if (code == 0) {
      write_finished_marker(st.run_dir, c.scene_text, st.wall_s);
      st.state = StudyRunStatus::State::ran;
      ran_s += st.wall_s;
      ++ran;
      const std::size_t left = todo - ran - failed_now;
      say(fmt::format("{} done in {:.1f} s{}", tag, st.wall_s,
                      left > 0 ? fmt::format("; {} to go, about {:.0f} s more", left, left * ran_s / ran) : ""));
    } else {
      st.state = StudyRunStatus::State::failed;
      ++failed_now;
      const std::string line = failure_line(log);
      st.why = fmt::format("run failed (exit {}): {} (log: {})", code, line, log);
      say(fmt::format("{} FAILED (exit {}): {}; log in {}", tag, code, line, log));
    }
    result.runs.push_back(st);
  }

  // Observables of every finished run, then the figures and the report.
  std::vector<Row> rows;
  std::vector<std::string> plotted, labels;
  for (const auto& st : result.runs) {
    Row r;
    r.run = &st;
    if (st.state != StudyRunStatus::State::failed && !opt.no_analysis) {
      try {
        r.a = analyze_run_dir(st.run_dir);
        r.analysed = true;
        plotted.push_back(st.run_dir);
        labels.push_back(st.study_case.label);
      } catch (const std::exception& e) {
        r.error = std::string("analysis failed: ") + e.what();
        say(fmt::format("[{}] {}", st.study_case.label, r.error));
      }
    }
    rows.push_back(std::move(r));
  }
  std::vector<std::string> figures;
  std::string figure_error;
  if (opt.no_plot) {
    figure_error = "--no-plot";
  } else if (plotted.empty()) {
    figure_error = "no finished run";
  } else {
    try {
      PlotOptions p;
      p.run_dirs = plotted;
      p.out = (out / "figures").string();
      if (study.keys.size() == 1) p.key = study.keys.front();
      p.xlabel = swept_header(study);
      p.labels = labels;
      figures = plot_runs(p);
      // The comparisons first, then run by run.
      std::stable_partition(figures.begin(), figures.end(), [&](const std::string& f) {
        const auto name = fs::path(f).filename().string();
        return name == "sweep.png" || name.rfind("compare_", 0) == 0;
      });
    } catch (const std::exception& e) {
      figure_error = e.what();
      say(fmt::format("figures not drawn: {}", figure_error));
    }
  }
  std::ofstream(out / "summary.csv") << summary_csv(study, rows);
  result.report_path = (out / "report.md").string();
  std::ofstream(result.report_path) << report_md(study, opt, reduction, result.out, rows, figures, figure_error);
  say(fmt::format(
      "study {}: {} of {} runs finished{}; report {}", study.name, n - result.failed(), n,
      result.failed() ? fmt::format(" ({} failed: rerun the same command to retry them)", result.failed()) : "",
      result.report_path));
  return result;
}

ScratchFolder::ScratchFolder(const std::string& prefix)
    : path_((fs::temp_directory_path() / fmt::format("{}-{}", prefix, ::getpid())).string()) {}

ScratchFolder::~ScratchFolder() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::vector<std::string> check_study(const StudyOptions& opt) {
  const Study study = load_study(resolve_study(opt.study));
  const Reduction reduction_spec;
  const ScratchFolder tmp("hemocosim-study-check");
  const auto cases = expand_study(study, tmp.path(), opt.reduced ? &reduction_spec : nullptr,
                                  opt.check_placement ? SceneCheck::placement : SceneCheck::values);
  std::vector<std::string> lines;
  lines.push_back(fmt::format("{}: ok, {} runs of {} (base {}){}", study.path, cases.size(), swept_header(study),
                              study.base, opt.reduced ? ", reduced" : ""));
  for (const auto& c : cases) {
    const Scene s = load_scene(c.scene_path);
    const double volume = 3.14159265358979323846 * s.vessel.radius() * s.vessel.radius() * s.vessel.length;
    const long rbcs = s.rbc.present ? std::lround(s.rbc.hematocrit * volume / s.rbc.volume) : 0;
    const long platelets = s.platelet.present ? std::lround(s.platelet.number_density * volume) : 0;
    lines.push_back(fmt::format("  {:<14} {:<36} d = {:g} um, l = {:g} um, {} RBCs, {} platelets, {:g} s", c.dir_name,
                                study.value_text(c.index), s.vessel.diameter * 1e6, s.vessel.length * 1e6, rbcs,
                                platelets, s.time.coupling_steps * s.time.coupling_interval));
  }
  return lines;
}

int study_command(const StudyOptions& opt) {
  if (opt.check_only) {
    for (const auto& l : check_study(opt)) fmt::print("{}\n", l);
    return 0;
  }
  interrupted = 0;
  auto old_int = std::signal(SIGINT, on_signal);
  auto old_term = std::signal(SIGTERM, on_signal);
  struct Restore {
    decltype(old_int) i, t;
    ~Restore() {
      std::signal(SIGINT, i);
      std::signal(SIGTERM, t);
    }
  } restore{old_int, old_term};
  const auto r = run_study(opt);
  return r.failed() ? 1 : 0;
}

}  // namespace hemo
