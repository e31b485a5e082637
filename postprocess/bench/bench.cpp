// SPDX-License-Identifier: GPL-3.0-or-later
#include "bench.h"

#include "child_process.h"
#include "plot.h"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#ifndef HEMO_BENCH_SOURCE
#define HEMO_BENCH_SOURCE ""
#endif
#ifndef HEMO_BENCH_PLOT_SCRIPT
#define HEMO_BENCH_PLOT_SCRIPT ""
#endif

namespace fs = std::filesystem;

namespace hemo {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw StudyError(path + ": " + what); }

bool same_value(const toml::node& a, const toml::node& b) {
  if (a.is_number() && b.is_number()) return a.value<double>().value() == b.value<double>().value();
  if (a.is_string() && b.is_string()) return a.value<std::string>().value() == b.value<std::string>().value();
  if (a.is_boolean() && b.is_boolean()) return a.value<bool>().value() == b.value<bool>().value();
  if (a.is_array() && b.is_array()) {
    const auto &x = *a.as_array(), &y = *b.as_array();
    if (x.size() != y.size()) return false;
    for (std::size_t i = 0; i < x.size(); ++i)
      if (!same_value(*x.get(i), *y.get(i))) return false;
    return true;
  }
  return false;
}

double number_at(const toml::table& t, const char* key, double fallback) {
  const auto n = t.at_path(key);
  return n.is_number() ? n.value<double>().value_or(fallback) : fallback;
}

std::vector<fs::path> bench_dirs() {
  std::vector<fs::path> dirs = {fs::path("scenes/bench")};
  if (std::string(HEMO_BENCH_SOURCE) != "") dirs.emplace_back(HEMO_BENCH_SOURCE);
  dirs.push_back(fs::path(executable_dir()) / ".." / "share" / "hemocosim" / "scenes" / "bench");
  return dirs;
}

bool is_suite_file(const fs::path& p, bool* stress) {
  try {
    const toml::table t = toml::parse_file(p.string());
    if (!t.contains("sweep")) return false;
    if (stress) *stress = t["stress"].value_or(false);
    return true;
  } catch (const toml::parse_error&) {
    return false;
  }
}

// The last line of a file that says what went wrong (error, fatal, nan, exception), else "".
std::string error_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line, found;
  while (std::getline(in, line)) {
    std::string low = line;
    std::transform(low.begin(), low.end(), low.begin(), [](unsigned char c) { return std::tolower(c); });
    if (low.find("error") != std::string::npos || low.find("fatal") != std::string::npos ||
        low.find(" nan") != std::string::npos || low.find("exception") != std::string::npos ||
        low.find("stop") != std::string::npos)
      found = line;
  }
  while (!found.empty() && (found.back() == '\r' || found.back() == ' ')) found.pop_back();
  return found;
}

volatile int stress_failed = 0;

// Runs `argv` as a child, its command line, output and end appended to `log_path`; lines that
// say "error" go to `progress` too.
ChildResult run_logged(const std::vector<std::string>& argv, const std::string& log_path,
                       const std::function<void(const std::string&)>& progress) {
  std::ofstream log(log_path, std::ios::app);
  std::string command;
  for (const auto& a : argv) command += (command.empty() ? "" : " ") + a;
  log << "$ " << command << "\n";
  log.flush();
  ChildOptions opt;
  opt.merge_stderr = true;
  opt.on_line = [&](const std::string& line) {
    log << line << "\n";
    log.flush();
    if (progress && line.find("error") != std::string::npos) progress(line);
  };
  const auto r = run_child(argv, opt);
  log << "# " << fs::path(argv.front()).filename().string() << " " << r.describe() << "\n";
  return r;
}

SceneRunner bench_runner(const std::string& hemocosim, bool stress) {
  return [hemocosim, stress](const std::string& scene, const std::string& run_dir, const std::string& log_path,
                             const std::function<void(const std::string&)>& progress) {
    if (stress && stress_failed) {
      std::ofstream(log_path, std::ios::app) << "not run: an earlier value of this stress suite failed\n";
      return 3;
    }
    const auto r = run_logged({hemocosim, "run", scene, "--out", run_dir}, log_path, progress);
    if (stress && !r.ok()) stress_failed = 1;
    return r.exit_code;
  };
}

// A floor suite's runner: hemocosim-dem-bench (next to hemocosim) on the scene, its coupling
// steps on as many ranks as the scene gives the particle node, the figures into
// RUN_DIR/dem-bench.json.
SceneRunner floor_runner(const std::string& hemocosim) {
  return [hemocosim](const std::string& scene, const std::string& run_dir, const std::string& log_path,
                     const std::function<void(const std::string&)>& progress) {
    fs::create_directories(run_dir);
    fs::copy_file(scene, fs::path(run_dir) / "scene.toml", fs::copy_options::overwrite_existing);
    const Scene parsed = load_scene(scene);
    return run_logged({(fs::path(hemocosim).parent_path() / "hemocosim-dem-bench").string(), "--scene", scene,
                       "--steps", std::to_string(parsed.time.coupling_steps), "--floor", "--ranks",
                       std::to_string(parsed.run.particle_ranks), "--json",
                       (fs::path(run_dir) / "dem-bench.json").string()},
                      log_path, progress)
        .exit_code;
  };
}

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : ""; }
std::string pct(double v) { return std::isfinite(v) ? fmt::format("{:.3g} %", 100 * v) : "n/a"; }
std::string g3(double v) { return std::isfinite(v) ? fmt::format("{:.3g}", v) : "n/a"; }
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}
std::string md_cell(std::string s) {
  std::replace(s.begin(), s.end(), '|', '/');
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

std::string utc_now() {
  char buf[32];
  const std::time_t t = std::time(nullptr);
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

std::string find_bench_plot_script() {
  const std::vector<fs::path> tried = {fs::path(executable_dir()) / ".." / "share" / "hemocosim" / "bench_plot.py",
                                       fs::path(HEMO_BENCH_PLOT_SCRIPT)};
  for (const auto& p : tried)
    if (!p.empty() && fs::is_regular_file(p)) return p.string();
  throw std::runtime_error("bench_plot.py not found next to the binary nor in the source tree");
}

}  // namespace

BenchSuite load_bench_suite(const std::string& path, const std::string& out_dir) {
  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    if (!fs::exists(path)) fail(path, "no such bench suite");
    fail(path, fmt::format("line {}: {}", e.source().begin.line, e.description()));
  }
  BenchSuite s;
  s.path = path;
  s.name = root["name"].value_or(fs::path(path).stem().string());
  s.stress = root["stress"].value_or(false);
  s.floor = root["floor"].value_or(false);
  if (s.floor && s.stress) fail(path, "floor and stress: a suite is one or the other");
  const bool keep_time = root["keep_physical_time"].value_or(false);
  const toml::node* reference = root.get("reference");
  if (!s.stress && !s.floor && !reference)
    fail(path, "reference: missing (the converged value of the swept key, one of sweep.values)");
  if (s.stress && reference) fail(path, "reference: a stress suite has none");
  if (s.floor && reference) fail(path, "reference: a floor suite has none (bare LIGGGHTS is its reference)");
  auto* sweep = root["sweep"].as_table();
  if (!sweep) fail(path, "[sweep]: missing (key and values)");
  const auto* values = (*sweep)["values"].as_array();
  if (!values || values->empty()) fail(path, "sweep.values: missing or empty");
  if (reference) {
    for (std::size_t i = 0; i < values->size(); ++i)
      if (same_value(*values->get(i), *reference)) s.reference = static_cast<int>(i);
    if (s.reference < 0) fail(path, "reference: not one of sweep.values");
  }
  // The base, absolute: the study file is written elsewhere.
  const auto base = root["base"].value<std::string>();
  if (!base) fail(path, "base: missing (the base scene, relative to the suite file)");
  const std::string base_path = fs::absolute(fs::path(path).parent_path() / *base).lexically_normal().string();
  if (keep_time) {
    if ((*sweep)["key"].value_or(std::string()) != "time.coupling_interval_s")
      fail(path, "keep_physical_time: only with sweep.key = \"time.coupling_interval_s\"");
    toml::table scene;
    try {
      scene = toml::parse_file(base_path);
    } catch (const toml::parse_error& e) {
      fail(path, fmt::format("base scene {}: {}", base_path, e.description()));
    }
    if (const auto* set = root["set"].as_table())
      for (const char* k : {"coupling_interval_s", "coupling_steps"})
        if (const auto* t = (*set)["time"].as_table(); t && t->contains(k))
          set_dotted(scene, std::string("time.") + k, fmt::format("{}", (*t)[k].value<double>().value()));
    const double dt0 = number_at(scene, "time.coupling_interval_s", 2e-5);
    const double steps0 = number_at(scene, "time.coupling_steps", 1);
    const double every0 = number_at(scene, "output.every_steps", steps0);
    toml::array derived;
    for (const auto& v : *values) {
      const double dt = v.value<double>().value_or(0);
      if (!(dt > 0)) fail(path, "sweep.values: coupling intervals must be positive numbers");
      const auto steps = static_cast<int64_t>(std::llround(steps0 * dt0 / dt));
      const auto every = std::max<int64_t>(1, std::llround(every0 * dt0 / dt));
      derived.push_back(toml::array{dt, steps, every});
    }
    if (!sweep->contains("labels")) {
      toml::array labels;
      for (const auto& v : *values) labels.push_back(fmt::format("{}", v.value<double>().value()));
      sweep->insert_or_assign("labels", labels);
    }
    sweep->erase("key");
    sweep->insert_or_assign("keys",
                            toml::array{"time.coupling_interval_s", "time.coupling_steps", "output.every_steps"});
    sweep->insert_or_assign("values", derived);
  }
  for (const char* k : {"reference", "keep_physical_time", "stress", "floor"}) root.erase(k);
  root.insert_or_assign("base", base_path);
  root.insert_or_assign("name", s.name);
  const fs::path dir = fs::path(out_dir) / s.name;
  fs::create_directories(dir);
  s.study_path = (dir / "bench-study.toml").string();
  {
    std::ofstream out(s.study_path);
    out << "# Written by `hemocosim bench` from " << fs::absolute(path).string() << "\n" << root << "\n";
  }
  s.study = load_study(s.study_path);
  return s;
}

std::vector<std::string> resolve_bench_suites(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  std::error_code ec;
  if (names.empty()) {
    for (const auto& dir : bench_dirs()) {
      if (!fs::is_directory(dir, ec)) continue;
      std::vector<std::string> found;
      for (const auto& e : fs::directory_iterator(dir)) {
        bool stress = false;
        if (e.path().extension() == ".toml" && is_suite_file(e.path(), &stress) && !stress)
          found.push_back(e.path().string());
      }
      std::sort(found.begin(), found.end());
      if (!found.empty()) return found;
    }
    throw StudyError("no bench suites found (scenes/bench/*.toml)");
  }
  for (const auto& name : names) {
    if (fs::is_regular_file(name, ec)) {
      out.push_back(name);
      continue;
    }
    bool hit = false;
    for (const auto& dir : bench_dirs()) {
      if (!fs::is_directory(dir, ec)) continue;
      const fs::path file = dir / (name + ".toml");
      if (fs::is_regular_file(file, ec)) {
        out.push_back(file.lexically_normal().string());
        hit = true;
        break;
      }
      std::vector<std::string> group;
      for (const auto& e : fs::directory_iterator(dir)) {
        const std::string stem = e.path().stem().string();
        if (e.path().extension() == ".toml" && stem.rfind(name + "-", 0) == 0 && is_suite_file(e.path(), nullptr))
          group.push_back(e.path().lexically_normal().string());
      }
      if (!group.empty()) {
        std::sort(group.begin(), group.end());
        out.insert(out.end(), group.begin(), group.end());
        hit = true;
        break;
      }
    }
    if (!hit)
      throw StudyError(fmt::format("no bench suite '{}' (scenes/bench/{}.toml or {}-*.toml)", name, name, name));
  }
  return out;
}

std::string bench_csv(const std::vector<BenchRow>& rows) {
  std::string c =
      "suite,key,value,label,reference,status,wall_s,speedup,fluid_compute_s,particle_compute_s,coupling_overhead_s,"
      "fluid_peak_MiB,particle_peak_MiB,U_m_s,r_platelet_m,r_rbc_m,D_m2_s,platelets,rbcs,err_U,err_r_platelet,err_r_"
      "rbc,"
      "err_D,D_noise,L1_platelet,L1_rbc,message,run_dir,dem_ns_per_particle_step,callback_ns,one_run_ns,bare_liggghts_ns,"
      "dem_over_bare\n";
  for (const auto& r : rows) {
    const auto& m = r.measures;
    const auto& e = r.errors;
    const bool me = r.measured, er = r.has_errors;
    const bool fl = r.has_floor;
    const auto& f = r.floor;
    c += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                     csv_field(r.suite), csv_field(r.keys), csv_field(r.value), csv_field(r.label), r.reference ? 1 : 0,
                     r.status, num(r.wall_s), num(r.speedup), num(r.cost.fluid_compute_s),
                     num(r.cost.particle_compute_s), num(r.cost.coupling_overhead_s), num(r.cost.fluid_peak_mib),
                     num(r.cost.particle_peak_mib), me ? num(m.mean_velocity) : "", me ? num(m.mean_r_platelet) : "",
                     me ? num(m.mean_r_rbc) : "", me ? num(m.diffusivity) : "", me ? std::to_string(m.platelets) : "",
                     me ? std::to_string(m.rbcs) : "", er ? num(e.u) : "", er ? num(e.r_platelet) : "",
                     er ? num(e.r_rbc) : "", er ? num(e.d) : "", er ? num(e.d_noise) : "", er ? num(e.l1_platelet) : "",
                     er ? num(e.l1_rbc) : "", csv_field(r.message), csv_field(r.run_dir), fl ? num(f.dem_ns) : "",
                     fl ? num(f.callback_ns) : "", fl ? num(f.one_run_ns) : "", fl ? num(f.bare_ns) : "",
                     fl ? num(f.over_bare()) : "");
  }
  return c;
}

namespace {

std::string bench_md(const BenchOptions& opt, const std::vector<BenchSuite>& suites, const std::vector<BenchRow>& rows,
                     const std::vector<std::string>& figures, const std::string& figure_error) {
  std::string m = "# hemocosim bench\n\n";
  std::string args;
  for (const auto& s : opt.suites) args += " " + s;
  m += fmt::format(
      "Generated {} by `hemocosim bench{} --out {}`. Errors against each suite's reference run "
      "(definitions: `postprocess/bench/bench_metrics.h`, docs/performance.md): e_U, e_rPLT, e_rRBC, e_D "
      "relative; L1 between the last snapshot's radial distributions (10 bins of r/R; 0 equal, 2 disjoint); "
      "D noise ≈ √(2/N_PLT). Wall: the whole `hemocosim run`; compute: the nodes' own (profile.csv).\n",
      utc_now(), args, opt.out);
  for (const auto& s : suites) {
    std::string keys;
    for (const auto& k : s.study.keys) keys += (keys.empty() ? "`" : ", `") + k + "`";
    m += fmt::format("\n## {} — {}\n\n", s.name, keys);
    if (!s.study.title.empty()) m += s.study.title + "\n\n";
    if (s.floor) {
      m += "Each scene's particles in a synthetic Poiseuille flow without a fluid node (`hemocosim-dem-bench "
           "--floor`), wall time per particle-step: our DEM as the node runs it (one LIGGGHTS run per coupling "
           "interval; the callback is our fluid force), the same steps in one run, and bare LIGGGHTS on the same "
           "particles (none of our fixes, no fluid force).\n\n";
      m += "Neighbour-list builds per 1000 DEM steps in brackets: ours with its `dem.neighbour_rebuild`, bare "
           "LIGGGHTS with its own policy and, where ours rebuilds in the streaming frame, with that criterion.\n\n";
      m += "| value | particles | ranks | lists | DEM ns (callback) [builds] | one run ns | bare LIGGGHTS ns [builds] | "
           "DEM / bare | bare, streaming ns [builds] | peak MiB per rank | wall (s) | status |\n"
           "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
      for (const auto& r : rows) {
        if (r.suite != s.name) continue;
        const auto& f = r.floor;
        const bool fl = r.has_floor;
        m += fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1f} | {} |\n", r.value,
                         fl ? std::to_string(f.particles) : "", fl ? std::to_string(f.ranks) : "",
                         fl ? f.neighbour_rebuild : "",
                         fl ? fmt::format("{} ({}) [{}]", g3(f.dem_ns), g3(f.callback_ns), g3(f.builds_per_1000)) : "",
                         fl ? g3(f.one_run_ns) : "",
                         fl ? fmt::format("{} [{}]", g3(f.bare_ns), g3(f.bare_builds_per_1000)) : "",
                         fl ? g3(f.over_bare()) : "",
                         fl && f.has_bare_streaming
                             ? fmt::format("{} [{}]", g3(f.bare_streaming_ns), g3(f.bare_streaming_builds_per_1000))
                             : "",
                         fl ? g3(f.peak_mib) : "", r.wall_s, r.status + (r.message.empty() ? "" : ": " + md_cell(r.message)));
      }
      continue;
    }
    if (s.stress) {
      m += "| value | status | wall (s) | particles compute (s) | message |\n|---|---|---|---|---|\n";
      for (const auto& r : rows)
        if (r.suite == s.name)
          m += fmt::format("| {} | {} | {:.1f} | {} | {} |\n", r.value, r.status, r.wall_s,
                           g3(r.cost.particle_compute_s), md_cell(r.message));
      continue;
    }
    m += "| value | wall (s) | speed-up | fluid / particles compute (s) | e_U | e_rPLT | e_rRBC | e_D (noise) | L1 PLT "
         "| L1 RBC "
         "| peak MiB fluid / particles | status |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& r : rows) {
      if (r.suite != s.name) continue;
      const auto& e = r.errors;
      const bool er = r.has_errors;
      m += fmt::format("| {}{} | {:.1f} | {} | {} / {} | {} | {} | {} | {} ({}) | {} | {} | {} / {} | {} |\n", r.value,
                       r.reference ? " (ref)" : "", r.wall_s, g3(r.speedup), g3(r.cost.fluid_compute_s),
                       g3(r.cost.particle_compute_s), er ? pct(e.u) : "", er ? pct(e.r_platelet) : "",
                       er ? pct(e.r_rbc) : "", er ? pct(e.d) : "", er ? pct(e.d_noise) : "",
                       er ? g3(e.l1_platelet) : "", er ? g3(e.l1_rbc) : "", g3(r.cost.fluid_peak_mib),
                       g3(r.cost.particle_peak_mib), r.status + (r.message.empty() ? "" : ": " + md_cell(r.message)));
    }
  }
  if (!figure_error.empty()) m += fmt::format("\nFigures not drawn: {}\n", figure_error);
  if (!figures.empty()) m += "\n## Figures\n\n";
  for (const auto& f : figures)
    m += fmt::format("![{}]({})\n\n", fs::path(f).stem().string(), fs::path(f).lexically_relative(opt.out).string());
  return m;
}

}  // namespace

BenchResult run_bench(const BenchOptions& opt) {
  const auto files = resolve_bench_suites(opt.suites);
  fs::create_directories(opt.out);
  std::vector<BenchSuite> suites;
  for (const auto& f : files) suites.push_back(load_bench_suite(f, opt.out));  // all validated before anything runs
  const std::string hemocosim =
      !opt.hemocosim.empty() ? opt.hemocosim : (fs::path(executable_dir()) / "hemocosim").string();
  BenchResult result;
  for (const auto& s : suites) {
    stress_failed = 0;
    StudyOptions so;
    so.study = s.study_path;
    so.out = (fs::path(opt.out) / s.name).string();
    so.no_plot = true;
    so.quiet = opt.quiet;
    so.hemocosim = hemocosim;
    so.runner = s.floor ? floor_runner(hemocosim) : bench_runner(hemocosim, s.stress);
    so.no_analysis = s.floor;
    so.check_placement = !s.stress;
    if (!opt.quiet) fmt::print(stderr, "bench {}: {}\n", s.name, s.path);
    const StudyResult sr = run_study(so);
    std::vector<BenchRow> rows;
    for (const auto& st : sr.runs) {
      BenchRow r;
      r.suite = s.name;
      r.keys = s.study.keys.front();
      r.value = s.study.value_text(st.study_case.index);
      if (s.study.keys.size() > 1 && s.study.keys.front() == "time.coupling_interval_s")
        r.value = s.study.labels[st.study_case.index];
      r.label = st.study_case.label;
      r.run_dir = st.run_dir;
      r.reference = static_cast<int>(st.study_case.index) == s.reference;
      r.wall_s = st.wall_s;
      r.cost = bench::read_profile(st.run_dir);
      const bool failed = st.state == StudyRunStatus::State::failed;
      r.status = failed ? "failed" : "ok";
      if (failed) {
        // What the run and each node said last about the failure.
        std::string msg;
        const fs::path log = fs::path(so.out) / "logs" / (st.study_case.dir_name + ".log");
        // The log collects every attempt: only its last line says whether this one was skipped.
        std::string last;
        {
          std::ifstream in(log);
          for (std::string l; std::getline(in, l);)
            if (!l.empty()) last = l;
        }
        if (last.rfind("not run:", 0) == 0) {
          r.status = "not run";
          r.message = last.substr(9);
          rows.push_back(r);
          continue;
        }
        const std::string coordinator_line = error_line(log);
        msg = "coordinator: " + coordinator_line;
        for (const char* node : {"particles.log", "fluid.log"}) {
          std::string line = error_line(fs::path(st.run_dir) / node);
          // Without the logger's "[time] [level] " prefix, to see whether the coordinator said it already.
          for (int i = 0; i < 2 && !line.empty() && line.front() == '['; ++i) {
            const auto close = line.find("] ");
            if (close == std::string::npos) break;
            line = line.substr(close + 2);
          }
          if (!line.empty() && coordinator_line.find(line) == std::string::npos)
            msg += fmt::format("; {}: {}", node, line);
        }
        r.message = msg;
      } else if (s.floor) {
        try {
          r.floor = bench::read_dem_floor(st.run_dir);
          r.has_floor = true;
          r.cost.particle_peak_mib = r.floor.peak_mib;
          if (r.floor.bare_particles != r.floor.particles) {
            r.status = "not measured";
            r.message = fmt::format("bare LIGGGHTS read {} of the {} particles", r.floor.bare_particles,
                                    r.floor.particles);
          }
        } catch (const std::exception& e) {
          r.status = "not measured";
          r.message = e.what();
        }
      } else {
        try {
          r.measures = bench::measure_run(st.run_dir);
          r.measured = true;
        } catch (const std::exception& e) {
          r.status = "not measured";
          r.message = e.what();
        }
      }
      rows.push_back(r);
    }
    if (!s.stress)  // a stress suite is there to fail
      for (const auto& r : rows) result.failed += r.status == "failed";
    if (!s.stress && !s.floor) {
      const BenchRow* ref = nullptr;
      for (const auto& r : rows)
        if (r.reference && r.measured) ref = &r;
      for (auto& r : rows) {
        if (!ref || !r.measured) continue;
        r.errors = bench::errors_against(r.measures, ref->measures);
        r.has_errors = true;
        r.speedup = r.wall_s > 0 ? ref->wall_s / r.wall_s : NAN;
      }
      if (!ref)
        for (auto& r : rows) r.message += r.message.empty() ? "no reference run: no errors" : "; no reference run";
    }
    result.rows.insert(result.rows.end(), rows.begin(), rows.end());
    // Written after every suite, so an interrupted bench keeps what it measured.
    std::ofstream(fs::path(opt.out) / "bench.csv") << bench_csv(result.rows);
  }
  std::string figure_error;
  if (opt.no_plot) {
    figure_error = "--no-plot";
  } else {
    try {
      const std::string script = find_bench_plot_script();
      const std::string python = find_python();
      ChildOptions co;
      std::string said;
      co.merge_stderr = true;
      co.on_line = [&](const std::string& line) {
        if (line.rfind("wrote ", 0) == 0)
          result.figures.push_back(line.substr(6));
        else
          said += line + "\n";
      };
      const auto r = run_child(
          {python, script, (fs::path(opt.out) / "bench.csv").string(), (fs::path(opt.out) / "figures").string()}, co);
      if (!r.ok()) throw std::runtime_error(fmt::format("{} {}: {}", script, r.describe(), said));
    } catch (const std::exception& e) {
      figure_error = e.what();
      if (!opt.quiet) fmt::print(stderr, "figures not drawn: {}\n", figure_error);
    }
  }
  std::ofstream(fs::path(opt.out) / "bench.md") << bench_md(opt, suites, result.rows, result.figures, figure_error);
  if (!opt.quiet)
    fmt::print(stderr, "bench: {} runs, {} failed; {}/bench.md, {}/bench.csv\n", result.rows.size(), result.failed,
               opt.out, opt.out);
  return result;
}

std::vector<std::string> check_bench(const BenchOptions& opt) {
  const ScratchFolder tmp("hemocosim-bench-check");
  std::vector<std::string> files = opt.suites.empty() ? resolve_bench_suites({}) : resolve_bench_suites(opt.suites);
  if (opt.suites.empty())
    for (const auto& f : resolve_bench_suites({"stress"})) files.push_back(f);
  std::vector<std::string> lines;
  for (const auto& f : files) {
    const BenchSuite suite = load_bench_suite(f, tmp.path());
    StudyOptions so;
    so.study = suite.study_path;
    so.check_placement = !suite.stress;
    try {
      auto plan = check_study(so);
      // The plan names the study file written from the suite, a temporary: name the suite instead.
      if (!plan.empty() && plan.front().rfind(suite.study_path, 0) == 0)
        plan.front().replace(0, suite.study_path.size(), fmt::format("{} ({}suite)", f, suite.stress ? "stress " : ""));
      for (auto& line : plan) lines.push_back(std::move(line));
    } catch (const StudyError& e) {
      throw StudyError(fmt::format("bench suite {}: {}", f, e.what()));  // the study file is a temporary
    }
  }
  return lines;
}

int bench_command(const BenchOptions& opt) {
  if (opt.check_only) {
    for (const auto& l : check_bench(opt)) fmt::print("{}\n", l);
    return 0;
  }
  return run_bench(opt).failed ? 1 : 0;
}

}  // namespace hemo
