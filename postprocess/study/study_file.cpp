// SPDX-License-Identifier: GPL-3.0-or-later
#include "study_file.h"

#include "child_process.h"
#include "geometry.h"
#include "scene.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#ifndef HEMO_STUDIES_SOURCE
#define HEMO_STUDIES_SOURCE ""
#endif

namespace fs = std::filesystem;

namespace hemo {

namespace {

// A value as TOML text; floats in their shortest exact form ("0.1", not toml++'s 17 digits).
std::string toml_text(const toml::node& n) {
  if (const auto* f = n.as_floating_point()) {
    std::string s = fmt::format("{}", f->get());
    if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
    return s;
  }
  std::ostringstream ss;
  n.visit([&ss](const auto& v) { ss << v; });
  return ss.str();
}

// True if every float in the table survives 6 significant digits (then the scene file is
// written with short floats, exactly).
bool short_floats(const toml::node& n) {
  if (const auto* t = n.as_table()) {
    for (const auto& [k, v] : *t)
      if (!short_floats(v)) return false;
  } else if (const auto* a = n.as_array()) {
    for (const auto& v : *a)
      if (!short_floats(v)) return false;
  } else if (const auto* f = n.as_floating_point()) {
    return std::strtod(fmt::format("{:.6g}", f->get()).c_str(), nullptr) == f->get();
  }
  return true;
}

std::string scene_file_text(const toml::table& scene) {
  std::ostringstream ss;
  if (short_floats(scene))
    ss << toml::toml_formatter{scene,
                               toml::toml_formatter::default_flags | toml::format_flags::relaxed_float_precision};
  else
    ss << scene;
  return ss.str();
}

// A value for a table cell: strings without their quotes.
std::string plain(const std::string& value_toml) {
  if (value_toml.size() >= 2 && (value_toml.front() == '"' || value_toml.front() == '\''))
    return value_toml.substr(1, value_toml.size() - 2);
  return value_toml;
}

std::string sanitize(const std::string& s) {
  std::string out;
  for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_') ? c : '_';
  return out;
}

template <class... Args>
[[noreturn]] void fail(const std::string& path, const std::string& f, Args&&... args) {
  throw StudyError(path + ": " + fmt::format(fmt::runtime(f), std::forward<Args>(args)...));
}

// Keys --reduced writes: sweeping one of them would be overwritten.
const std::set<std::string> kReducedKeys = {"vessel.length_um", "mesh.core_cells",     "mesh.ring_cells",
                                            "mesh.axial_cells", "time.coupling_steps", "output.every_steps",
                                            "vessel.feeder_develop_s"};

}  // namespace

// ---- Reduction -------------------------------------------------------------------------------

std::string Reduction::describe() const {
  return fmt::format(
      "vessel diameter x {} (swept diameters too), length {} um, mesh {}x{} core + ring {} ({} cells per section) x {} "
      "axial (a surface vessel, a bifurcation's, keeps its shape and mesh: a narrower one's snapped cells would be "
      "narrower than a red cell), physical time {} s at the scene's coupling interval (a developed feeder's, vessel.feeder_develop_s, "
      "at most as long), {} particle snapshots; every other key as in the scene. The reduced runs test the machinery and show early-time behaviour only: cell-free layer, margination "
      "and steady profiles take of order a second of physical time to form.",
      diameter_factor, length_um, core_cells, core_cells, ring_cells,
      core_cells * core_cells + 4 * core_cells * ring_cells, axial_cells, end_time_s, snapshots);
}

void Reduction::apply(toml::table& scene) const {
  auto number = [&scene](const char* key, double fallback) {
    const auto n = scene.at_path(key);
    return n.is_number() ? n.value<double>().value_or(fallback) : fallback;
  };
  // A surface vessel keeps its shape and mesh: its snapped cells are cut to about half a cube at
  // the wall, and a narrower vessel's finer cubes would be narrower than a red cell. It runs
  // shorter only.
  const auto shape = scene.at_path("vessel.shape").value<std::string>();
  bool surface = false;
  try {
    surface = shape && vessel_shape(*shape).surface();
  } catch (const std::invalid_argument&) {
    // an unknown shape: the scene's own check names it
  }
  if (!surface) {
    const double d = number("vessel.diameter_um", 0);
    if (d > 0) set_dotted(scene, "vessel.diameter_um", fmt::format("{:.9g}", d * diameter_factor));
    const double l = number("vessel.length_um", length_um);
    set_dotted(scene, "vessel.length_um", fmt::format("{:.9g}", std::min(l, length_um)));
    set_dotted(scene, "mesh.core_cells", std::to_string(core_cells));
    set_dotted(scene, "mesh.ring_cells", std::to_string(ring_cells));
    set_dotted(scene, "mesh.axial_cells", std::to_string(axial_cells));
  }
  const Timing defaults;
  const double dt = number("time.coupling_interval_s", defaults.coupling_interval);
  const long given = scene.at_path("time.coupling_steps").value<int64_t>().value_or(defaults.coupling_steps);
  const long steps = std::max(1L, std::min(given, static_cast<long>(std::ceil(end_time_s / dt - 1e-9))));
  set_dotted(scene, "time.coupling_steps", std::to_string(steps));
  set_dotted(scene, "output.every_steps", std::to_string(std::max(1L, steps / std::max(1, snapshots))));
  // A developed feeder (model/feeder_develop.h) is a run of its own: no longer than the run.
  const double develop = number("vessel.feeder_develop_s", 0);
  if (develop > end_time_s) set_dotted(scene, "vessel.feeder_develop_s", fmt::format("{:.9g}", end_time_s));
}

// ---- Study file ------------------------------------------------------------------------------

std::string Study::value_text(std::size_t i) const {
  std::string s;
  for (const auto& v : values.at(i)) s += (s.empty() ? "" : ", ") + plain(v);
  return s;
}

void set_dotted(toml::table& root, const std::string& dotted_key, const std::string& value_toml) {
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + value_toml);
  } catch (const toml::parse_error& e) {
    throw StudyError(fmt::format("{} = {}: not a TOML value ({})", dotted_key, value_toml, e.description()));
  }
  toml::table* t = &root;
  std::string part, seen;
  std::istringstream parts(dotted_key);
  std::vector<std::string> path;
  while (std::getline(parts, part, '.')) path.push_back(part);
  if (path.empty() || std::any_of(path.begin(), path.end(), [](const std::string& p) { return p.empty(); }))
    throw StudyError(fmt::format("'{}' is not a dotted scene key", dotted_key));
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    seen += (seen.empty() ? "" : ".") + path[i];
    toml::node* n = t->get(path[i]);
    if (!n) n = &t->insert_or_assign(path[i], toml::table{}).first->second;
    t = n->as_table();
    if (!t) throw StudyError(fmt::format("{}: '{}' is a value, not a table", dotted_key, seen));
  }
  t->insert_or_assign(path.back(), *parsed.get("v"));
}

Study load_study(const std::string& path) {
  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    if (!fs::exists(path)) fail(path, "no such study file");
    fail(path, "line {}: {}", e.source().begin.line, e.description());
  }
  Study s;
  s.path = path;
  const std::set<std::string> known_top = {"name", "title", "expectation", "base", "sweep", "set"};
  for (const auto& [k, v] : root)
    if (!known_top.count(std::string(k.str())))
      fail(path, "line {}: unknown key '{}' (known: name, title, expectation, base, [sweep], [set])",
           v.source().begin.line, k.str());
  s.name = root["name"].value_or(fs::path(path).stem().string());
  s.title = root["title"].value_or(std::string());
  s.expectation = root["expectation"].value_or(std::string());
  const auto base = root["base"].value<std::string>();
  if (!base) fail(path, "base: missing (the base scene, relative to the study file)");
  s.base = (fs::path(path).parent_path() / *base).lexically_normal().string();
  if (!fs::is_regular_file(s.base)) fail(path, "base: {} does not exist", s.base);

  const auto* sweep = root["sweep"].as_table();
  if (!sweep) fail(path, "[sweep]: missing (key and values)");
  for (const auto& [k, v] : *sweep) {
    const std::string key(k.str());
    if (key != "key" && key != "keys" && key != "values" && key != "labels")
      fail(path, "line {}: sweep.{}: unknown key (known: key, keys, values, labels)", v.source().begin.line, key);
  }
  const bool one = sweep->contains("key"), many = sweep->contains("keys");
  if (one == many) fail(path, "sweep: give exactly one of key (one swept key) and keys (several that change together)");
  if (one) {
    const auto k = (*sweep)["key"].value<std::string>();
    if (!k) fail(path, "sweep.key: expected a string (a dotted scene key)");
    s.keys.push_back(*k);
  } else {
    const auto* arr = (*sweep)["keys"].as_array();
    if (!arr || arr->empty()) fail(path, "sweep.keys: expected a non-empty array of dotted scene keys");
    for (const auto& k : *arr) {
      const auto str = k.value<std::string>();
      if (!str) fail(path, "sweep.keys: expected strings");
      s.keys.push_back(*str);
    }
  }
  for (const auto& k : s.keys)
    if (k.rfind("run.", 0) == 0 && k != "run.seed")
      fail(path, "sweep: '{}': run settings other than run.seed cannot be swept", k);

  const auto* values = (*sweep)["values"].as_array();
  if (!values || values->empty()) fail(path, "sweep.values: missing or empty (one value per run)");
  for (std::size_t i = 0; i < values->size(); ++i) {
    const toml::node& v = *values->get(i);
    std::vector<std::string> per_key;
    if (one) {
      if (v.is_table()) fail(path, "sweep.values[{}]: a table is no scene value", i);
      per_key.push_back(toml_text(v));
    } else {
      const auto* tuple = v.as_array();
      if (!tuple || tuple->size() != s.keys.size())
        fail(path, "sweep.values[{}]: expected an array of {} values, one per key of sweep.keys", i, s.keys.size());
      for (const auto& x : *tuple) per_key.push_back(toml_text(x));
    }
    s.values.push_back(per_key);
  }
  if (const auto* labels = (*sweep)["labels"].as_array()) {
    if (labels->size() != s.values.size())
      fail(path, "sweep.labels: {} labels for {} values", labels->size(), s.values.size());
    for (const auto& l : *labels) {
      const auto str = l.value<std::string>();
      if (!str || str->empty()) fail(path, "sweep.labels: expected non-empty strings");
      s.labels.push_back(sanitize(*str));
    }
  } else {
    for (std::size_t i = 0; i < s.values.size(); ++i) {
      std::string label;
      for (const auto& v : s.values[i]) label += (label.empty() ? "" : "-") + sanitize(plain(v));
      s.labels.push_back(label);
    }
  }
  std::set<std::string> unique(s.labels.begin(), s.labels.end());
  if (unique.size() != s.labels.size()) fail(path, "sweep: two runs would have the same label; give sweep.labels");
  if (const auto* set = root["set"].as_table()) {
    std::ostringstream ss;
    ss << *set;
    s.set_toml = ss.str();
  } else if (root.contains("set")) {
    fail(path, "set: expected a table of scene keys");
  }
  return s;
}

std::string resolve_study(const std::string& name_or_file) {
  std::error_code ec;
  if (fs::is_regular_file(name_or_file, ec)) return name_or_file;
  const std::string file = name_or_file + ".toml";
  std::vector<std::string> tried = {name_or_file};
  for (const fs::path& dir : {fs::path("scenes/studies"), fs::path(HEMO_STUDIES_SOURCE),
                              fs::path(executable_dir()) / ".." / "share" / "hemocosim" / "scenes" / "studies"}) {
    if (dir.empty()) continue;
    const auto p = (dir / file).lexically_normal();
    tried.push_back(p.string());
    if (fs::is_regular_file(p, ec)) return p.string();
  }
  std::string list;
  for (const auto& t : tried) list += (list.empty() ? "" : ", ") + t;
  throw StudyError(fmt::format("no study '{}' (tried {})", name_or_file, list));
}

// ---- Expansion -------------------------------------------------------------------------------

std::vector<StudyCase> expand_study(const Study& study, const std::string& scenes_dir, const Reduction* reduction,
                                    SceneCheck check) {
  toml::table base;
  try {
    base = toml::parse_file(study.base);
  } catch (const toml::parse_error& e) {
    fail(study.path, "base scene {}: line {}: {}", study.base, e.source().begin.line, e.description());
  }
  if (reduction)
    for (const auto& k : study.keys)
      if (kReducedKeys.count(k))
        fail(study.path, "sweep key {} is one that --reduced sets; run this study without --reduced", k);
  if (!study.set_toml.empty()) {
    // Merge [set] into the base, key by key.
    const toml::table set = toml::parse(study.set_toml);
    std::function<void(const toml::table&, const std::string&)> merge = [&](const toml::table& t,
                                                                            const std::string& prefix) {
      for (const auto& [k, v] : t) {
        const std::string key = prefix + std::string(k.str());
        if (const auto* sub = v.as_table())
          merge(*sub, key + ".");
        else
          set_dotted(base, key, toml_text(v));
      }
    };
    merge(set, "");
  }

  fs::create_directories(scenes_dir);
  std::vector<StudyCase> cases;
  const int width = study.size() >= 100 ? 3 : 2;
  for (std::size_t i = 0; i < study.size(); ++i) {
    StudyCase c;
    c.index = i;
    c.label = study.labels[i];
    c.dir_name = fmt::format("{:0{}d}-{}", i + 1, width, c.label);
    c.scene_path = (fs::path(scenes_dir) / (c.dir_name + ".toml")).string();
    toml::table scene = base;
    for (std::size_t k = 0; k < study.keys.size(); ++k) {
      try {
        set_dotted(scene, study.keys[k], study.values[i][k]);
      } catch (const StudyError& e) {
        fail(study.path, "sweep: {}", e.what());
      }
    }
    if (reduction) reduction->apply(scene);
    const std::string run_name = sanitize(study.name + "-" + c.label);
    set_dotted(scene, "run.name", "\"" + run_name + "\"");
    std::ostringstream text;
    text << "# Generated by `hemocosim study` from " << study.path << " (base " << study.base << "):\n";
    for (std::size_t k = 0; k < study.keys.size(); ++k)
      text << "#   " << study.keys[k] << " = " << study.values[i][k] << "\n";
    if (reduction) text << "#   reduced (--reduced): " << reduction->describe() << "\n";
    text << "\n" << scene_file_text(scene) << "\n";
    c.scene_text = text.str();
    std::ofstream(c.scene_path) << c.scene_text;

    // The scene loader is the judge: an unknown swept key or a value of the wrong kind is refused.
    try {
      load_scene(c.scene_path, check);
    } catch (const SceneError& e) {
      std::string why;
      for (const auto& p : e.problems()) {
        const bool swept = std::find(study.keys.begin(), study.keys.end(), p.key) != study.keys.end();
        if (swept && p.message == "unknown key")
          fail(study.path, "sweep: '{}' is not a scene key (see docs/scenes.md and model/scene.cpp)", p.key);
        why += (why.empty() ? "" : "; ") + fmt::format("{}: {}", p.key, p.message) + (swept ? " (the swept key)" : "");
      }
      fail(study.path, "run {} ({}): the scene is invalid: {}", c.dir_name, study.value_text(i), why);
    }
    cases.push_back(std::move(c));
  }
  return cases;
}

}  // namespace hemo
