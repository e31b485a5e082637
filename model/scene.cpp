// SPDX-License-Identifier: GPL-3.0-or-later
#include "scene.h"

#include "bifurcation.h"
#include "solid_fraction_names.h"

#include "momentum_forms.h"
#include "suspension_viscosity.h"

#include "dem_step.h"
#include "driving.h"
#include "geometry.h"
#include "hosts.h"
#include "placement.h"
#include "units.h"
#include "vessel_ends.h"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <tuple>

namespace hemo {

std::string SceneProblem::str(const std::string& file) const {
  const std::string what = value.empty() ? key : key + " = " + value;
  if (line > 0) return fmt::format("{}:{}: {}: {}", file, line, what, message);
  return fmt::format("{}: {}: {}", file, what, message);
}

static std::string join_problems(const std::string& file, const std::vector<SceneProblem>& ps) {
  std::string s;
  for (const auto& p : ps) s += (s.empty() ? "" : "\n") + p.str(file);
  return s;
}

SceneError::SceneError(std::string file, std::vector<SceneProblem> problems)
    : std::runtime_error(join_problems(file, problems)), problems_(std::move(problems)) {}

namespace {

// Reads typed values by dotted key, remembering which keys the schema knows so that
// anything else in the file is reported as unknown.
class Reader {
 public:
  explicit Reader(const toml::table& root) : root_(root) {}

  template <class T>
  bool read(const std::string& key, T& out, double scale = 1.0) {
    known_.insert(key);
    catalogue_.push_back({key, default_text(out, scale), {}, {}});
    if (const auto it = bounds().find(key); it != bounds().end())
      catalogue_.back().rules.push_back(bound_rule(it->second.first, it->second.second));
    auto node = root_.at_path(key);
    if (!node) return false;
    const int line = static_cast<int>(node.node()->source().begin.line);
    const std::string value = value_text(node);
    if constexpr (std::is_same_v<T, std::string>) {
      if (auto v = node.value_exact<std::string>()) {
        out = *v;
        return true;
      }
      problem(key, line, "expected a string", value);
    } else if constexpr (std::is_same_v<T, bool>) {
      // value<bool>() would take the integer 1 for true: only a TOML boolean is one.
      if (auto v = node.value_exact<bool>()) {
        out = *v;
        return true;
      }
      problem(key, line, "expected true or false", value);
    } else if constexpr (std::is_integral_v<T>) {
      if (auto v = node.value_exact<int64_t>()) {
        // Read wide, refuse what the field cannot hold: no silent narrowing.
        using L = std::numeric_limits<T>;
        if (*v < static_cast<int64_t>(L::min()) ||
            (static_cast<uint64_t>(L::max()) < static_cast<uint64_t>(INT64_MAX) &&
             *v > static_cast<int64_t>(L::max()))) {
          problem(key, line, fmt::format("out of range: must be an integer from {} to {}", L::min(), L::max()), value);
          return false;
        }
        if (!within_bounds(key, line, static_cast<double>(*v), value)) return false;
        out = static_cast<T>(*v);
        return true;
      }
      problem(key, line, "expected an integer", value);
    } else {
      if (node.is_number()) {
        const double v = *node.value<double>();
        if (!std::isfinite(v)) {
          problem(key, line, "must be a finite number", value);
          return false;
        }
        if (!within_bounds(key, line, v, value)) return false;
        out = v * scale;
        return true;
      }
      problem(key, line, "expected a number", value);
    }
    return false;
  }

  // A key scenes no longer take: known (not reported as unknown) but not in the catalogue; a file
  // that gives it gets one problem naming what replaced it.
  void retired(const std::string& key, const std::string& replaced_by) {
    known_.insert(key);
    if (auto node = root_.at_path(key))
      problem(key, static_cast<int>(node.node()->source().begin.line), replaced_by, value_text(node));
  }
  // The value of a key as the file has it, for messages ("" when absent).
  std::string value_text(const std::string& key) const { return value_text(root_.at_path(key)); }

  int line_of(const std::string& key) const {
    auto node = root_.at_path(key);
    return node ? static_cast<int>(node.node()->source().begin.line) : 0;
  }

  void problem(const std::string& key, int line, std::string message, std::string value = {}) {
    problems_.push_back({key, line, std::move(message), std::move(value)});
  }
  // One problem per key: the first cause found (a value refused as read is not also "must be
  // positive" with the default it kept). The message is also the key's rule in the catalogue:
  // whether the check passes or not, so that an empty scene lists every rule.
  void check(bool ok, const std::string& key, const std::string& message) {
    add_rule(key, message);
    refuse_once(ok, key, message);
  }
  // The same without a rule: a refusal that depends on the file, not on the value's range.
  void refuse_once(bool ok, const std::string& key, const std::string& message) {
    if (!ok && !has_problem(key)) problem(key, line_of(key), message, value_text(key));
  }
  void add_names(const std::string& key, const std::vector<std::string>& names) {
    if (SceneKey* k = entry(key)) k->names = names;
  }
  bool has_problem(const std::string& key) const {
    for (const auto& p : problems_)
      if (p.key == key) return true;
    return false;
  }

  void report_unknown() { walk(root_, ""); }
  std::vector<SceneKey>& catalogue() { return catalogue_; }
  std::vector<SceneProblem>& problems() { return problems_; }

 private:
  void walk(const toml::table& t, const std::string& prefix) {
    for (const auto& [k, v] : t) {
      const std::string key = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
      if (const auto* sub = v.as_table()) {
        bool any_known = false;
        for (const auto& kk : known_) any_known |= kk.rfind(key + ".", 0) == 0;
        if (any_known) {
          walk(*sub, key);
          continue;
        }
      }
      if (!known_.count(key)) problem(key, static_cast<int>(v.source().begin.line), "unknown key");
    }
  }

  static std::string value_text(toml::node_view<const toml::node> node) {
    if (!node) return {};
    if (auto v = node.value_exact<std::string>()) {
      std::string t = *v;
      if (t.size() > 60) t = t.substr(0, 60) + "...";
      return "\"" + t + "\"";
    }
    if (auto v = node.value_exact<bool>()) return *v ? "true" : "false";
    if (auto v = node.value_exact<int64_t>()) return std::to_string(*v);
    if (auto v = node.value_exact<double>()) return fmt::format("{}", *v);
    if (node.is_table()) return "(a table)";
    if (node.is_array()) return "(an array)";
    return "(a date or time)";
  }

  // The physical range a number may have, in the file's units: what is outside is a mistake
  // (or an attempt to overflow what is derived from it), named with the range.
  bool within_bounds(const std::string& key, int line, double v, const std::string& value) {
    const auto it = bounds().find(key);
    if (it == bounds().end()) return true;
    const auto [lo, hi] = it->second;
    if (v >= lo && v <= hi) return true;
    problem(key, line, bound_rule(lo, hi), value);
    return false;
  }
  static std::string bound_rule(double lo, double hi) {
    if (lo == -std::numeric_limits<double>::infinity()) return fmt::format("must be at most {:g}", hi);
    return fmt::format("must be in [{:g}, {:g}]", lo, hi);
  }
  SceneKey* entry(const std::string& key) {
    for (auto it = catalogue_.rbegin(); it != catalogue_.rend(); ++it)
      if (it->key == key) return &*it;
    return nullptr;
  }
  void add_rule(const std::string& key, const std::string& rule) {
    SceneKey* k = entry(key);
    if (k != nullptr && std::find(k->rules.begin(), k->rules.end(), rule) == k->rules.end()) k->rules.push_back(rule);
  }
  static const std::map<std::string, std::pair<double, double>>& bounds() {
    constexpr double ninf = -std::numeric_limits<double>::infinity();
    static const std::map<std::string, std::pair<double, double>> b = {
        {"run.node_timeout_s", {ninf, 86400}},
        {"run.startup_timeout_s", {ninf, 1e6}},
        {"run.step_timeout_s", {ninf, 1e6}},
        {"run.max_restarts", {ninf, 1000}},
        {"run.fluid_ranks", {ninf, 4096}},
        {"run.particle_ranks", {ninf, 4096}},
        {"run.bus_check_s", {ninf, 3600}},
        {"run.max_courant", {ninf, 1000}},
        {"coupling.kernel_width_diameters", {ninf, 100}},  // a kernel wider averages the flow away
        {"vessel.diameter_um", {5, 1e4}},  // a capillary to a 10-mm artery
        {"vessel.length_um", {ninf, 1e5}},
        {"vessel.daughter_1_diameter_um", {ninf, 1e4}},  // as the vessel's diameter (0: Murray's law)
        {"vessel.daughter_2_diameter_um", {ninf, 1e4}},
        {"vessel.daughter_length_um", {ninf, 1e5}},  // as the vessel's length
        {"vessel.feeder_develop_s", {0, 1e3}},
        {"mesh.surface_cell_size_um", {ninf, 1e4}},
        {"mesh.core_cells", {ninf, 200}},
        {"mesh.ring_cells", {ninf, 200}},
        {"mesh.axial_cells", {ninf, 10000}},
        {"plasma.density_kg_m3", {ninf, 1e5}},
        {"plasma.viscosity_Pa_s", {ninf, 1e3}},
        {"driving.pressure_drop_Pa", {ninf, 1e9}},
        {"driving.wall_shear_rate_per_s", {ninf, 1e7}},
        {"rbc.diameter_um", {ninf, 100}},
        {"rbc.volume_um3", {ninf, 1e6}},
        {"rbc.density_kg_m3", {ninf, 1e5}},
        {"rbc.mass_scaling", {ninf, 1e9}},
        {"platelet.diameter_um", {ninf, 100}},
        {"platelet.mass_pg", {ninf, 1e6}},
        {"platelet.volume_um3", {ninf, 1e6}},
        {"platelet.number_density_per_ul", {ninf, 1e8}},
        {"platelet.semi_axis_a_um", {ninf, 100}},
        {"platelet.semi_axis_c_um", {ninf, 100}},
        {"platelet.mass_scaling", {ninf, 1e9}},
        {"contact.cell_youngs_modulus_Pa", {ninf, 1e13}},
        {"contact.wall_youngs_modulus_Pa", {ninf, 1e13}},
        {"contact.friction", {ninf, 100}},
        {"time.coupling_interval_s", {ninf, 1}},
        {"time.coupling_steps", {ninf, 1e9}},
        {"time.dem_substeps", {ninf, 1e7}},
        {"time.dem_steps_per_contact", {ninf, 1e4}},
        {"time.dem_step_max_relaxation_times", {ninf, 1e6}},
        {"time.closure_every_dem_steps", {ninf, 1e6}},
        {"time.mass_scaling", {ninf, 1e9}},
        {"time.coupling_relaxation_times", {ninf, 1e6}},
        {"dem.load_balance_every_steps", {ninf, 1e9}},
        {"dem.load_balance_threshold", {ninf, 1e6}},  // the largest over the mean is at most the rank count
        {"output.every_steps", {ninf, 1e9}},
        {"output.checkpoint_every_steps", {ninf, 1e9}},
        {"gravity.x_m_s2", {-1e8, 1e8}},  // stress bench: 1e7
        {"gravity.y_m_s2", {-1e8, 1e8}},  // stress bench: 1e7
        {"gravity.z_m_s2", {-1e8, 1e8}},  // stress bench: 1e7
        {"fluid.pressure_tolerance", {ninf, 1}},
        {"fluid.velocity_tolerance", {ninf, 1}},
        {"fluid.min_correctors", {ninf, 1000}},
        {"fluid.max_correctors", {ninf, 1000}},
        {"fluid.corrector_tolerance", {ninf, 1}},
        {"fluid.non_orthogonal_correctors", {ninf, 100}},
        {"fluid.steady_tolerance", {ninf, 1}},
        {"fluid.solve_every", {ninf, 1e4}},
    };
    return b;
  }

  // The value a key has before the file is read, in the file's units.
  template <class T>
  static std::string default_text(const T& v, double scale) {
    if constexpr (std::is_same_v<T, std::string>)
      return "\"" + v + "\"";
    else if constexpr (std::is_same_v<T, bool>)
      return v ? "true" : "false";
    else if constexpr (std::is_integral_v<T>)
      return std::to_string(v);
    else
      return fmt::format("{:g}", v / scale);
  }

  const toml::table& root_;
  std::vector<SceneKey> catalogue_;
  std::set<std::string> known_;
  std::vector<SceneProblem> problems_;
};

void read_name(Reader& r, const std::string& key, std::string& out, const std::vector<std::string>& known) {
  r.read(key, out);
  r.add_names(key, known);
  bool ok = false;
  std::string list;
  for (const auto& k : known) {
    ok |= k == out;
    list += (list.empty() ? "" : ", ") + k;
  }
  r.refuse_once(ok, key, "unknown name '" + out + "' (known: " + list + ")");
}

// A scene option with a few named values (model/scene_choices.h): the name in the file, refused
// with the known ones when unknown, the enum in the scene.
template <class E>
void read_choice(Reader& r, const std::string& key, E& out) {
  std::string name = name_of(out);
  read_name(r, key, name, choice_names<E>());
  choice_named(name, out);
}

void read_species(Reader& r, Species& s, bool rbc) {
  const std::string p = s.name + ".";
  s.present = false;
  if (rbc) {
    s.diameter = 5.56 * units::um;
    s.volume = 90 * units::um3;
    double density = 1100;
    r.read(p + "diameter_um", s.diameter, units::um);
    r.read(p + "volume_um3", s.volume, units::um3);
    r.read(p + "density_kg_m3", density);
    s.mass = density * s.volume;
    s.present = r.read(p + "hematocrit", s.hematocrit);
    r.check(s.hematocrit >= 0 && s.hematocrit < 0.6, p + "hematocrit", "must be in [0, 0.6)");
  } else {
    s.diameter = 2.66 * units::um;
    s.mass = 8.79 * units::pg;
    const double a = 2.06 * units::um, c = 0.52 * units::um;
    s.volume = 4.0 / 3.0 * units::pi * a * a * c;
    r.read(p + "diameter_um", s.diameter, units::um);
    r.read(p + "mass_pg", s.mass, units::pg);
    r.read(p + "volume_um3", s.volume, units::um3);
    s.present = r.read(p + "number_density_per_ul", s.number_density, units::per_ul);
    r.check(s.number_density >= 0, p + "number_density_per_ul", "must not be negative");
  }
  s.drag = rbc ? "rbc_fit" : "oblate";
  s.lift = rbc ? "rbc_lift" : "oblate";
  s.torque = rbc ? "none" : "oblate";
  read_name(r, p + "drag", s.drag, known_drag_closures());
  read_name(r, p + "lift", s.lift, known_lift_closures());
  read_name(r, p + "torque", s.torque, known_torque_closures());
  if (rbc) {
    for (const auto& [key, name] : {std::pair{"drag", s.drag}, {"lift", s.lift}, {"torque", s.torque}})
      r.check(name != "oblate", p + key, "the oblate closures are for platelets (RBCs are spheres)");
  } else {
    s.semi_axis_a = 2.06 * units::um;
    s.semi_axis_c = 0.52 * units::um;
    r.read(p + "semi_axis_a_um", s.semi_axis_a, units::um);
    r.read(p + "semi_axis_c_um", s.semi_axis_c, units::um);
    r.check(s.semi_axis_a > 0, p + "semi_axis_a_um", "must be positive");
    r.check(s.semi_axis_c > 0 && s.semi_axis_c < s.semi_axis_a, p + "semi_axis_c_um",
            "must be positive and below semi_axis_a_um (an oblate spheroid)");
    read_choice(r, p + "orientation_integrator", s.orientation_integrator);
  }
  r.read(p + "mass_scaling", s.mass_scaling);
  r.check(s.mass_scaling == 0 || (s.mass_scaling >= 1 && std::isfinite(s.mass_scaling)), p + "mass_scaling",
          "must be 0 (time.mass_scaling's) or at least 1 (1: the physical mass)");
  r.check(s.diameter > 0, p + "diameter_um", "must be positive");
  r.check(s.volume > 0, p + "volume_um3", "must be positive");
  r.check(s.mass > 0, p + (rbc ? "density_kg_m3" : "mass_pg"), "must be positive");
}

}  // namespace

// vessel.ends and vessel.inlet (model/vessel_ends.h); periodic ends ignore the inlet, as a shape
// ignores the parameters it does not take.
static void read_vessel_ends(Reader& r, Vessel& v) {
  read_name(r, "vessel.ends", v.ends, vessel_end_names());
  read_name(r, "vessel.inlet", v.inlet, vessel_inlet_names());
  r.read("vessel.feeder_develop_s", v.feeder_develop);
}

// Whether vessel.ends and vessel.inlet are names the scene knows (unknown ones are refused as read).
static bool known_ends(const Vessel& v) {
  const auto ends = vessel_end_names(), inlets = vessel_inlet_names();
  return std::find(ends.begin(), ends.end(), v.ends) != ends.end() &&
         std::find(inlets.begin(), inlets.end(), v.inlet) != inlets.end();
}

// Cells enter an open vessel as copies of the cells crossing its feeder's end (docs/design.md,
// "Open ends"): an inlet with a fixed profile has none to hand over, so it carries plasma alone.
static void refuse_cells_without_feeder(Reader& r, const Scene& s) {
  if (!known_ends(s.vessel)) return;  // refused as read
  const auto shapes = vessel_shape_names();
  if (std::find(shapes.begin(), shapes.end(), s.vessel.shape) != shapes.end() &&
      !vessel_shape(s.vessel.shape).carries_cells())
    return;  // no cells at all, which check_surface_vessel says
  const bool cells = (s.rbc.present && s.rbc.hematocrit > 0) || (s.platelet.present && s.platelet.number_density > 0);
  r.refuse_once(!cells || !open_ends(s.vessel) || fed_by_feeder(s.vessel), "vessel.inlet",
                "cells enter an open vessel only from a feeder (vessel.inlet = \"feeder\"); a fixed profile "
                "carries plasma alone: remove rbc.hematocrit and platelet.number_density_per_ul, or use the feeder");
}

static Scene read_scene(const toml::table& root, const std::string& path, std::vector<SceneKey>& catalogue,
                        SceneCheck check = SceneCheck::values);

// A vessel given as a closed surface (vessel.shape "bifurcation", "imported"; docs/design.md,
// "Surface vessels"): its surface must be one (built here, as the fluid node will build it), its
// ends open, its fluid on one rank, and cells only in a shape with a wall for the particle side;
// a feeder needs its inlet to face -z (feeder_layout says why not in one line). Returns the width of
// its narrowest end (the diameter of a disc of its area; 0 when it was not built).
static double check_surface_vessel(Reader& r, const Scene& s) {
  const auto names = vessel_shape_names();
  if (std::find(names.begin(), names.end(), s.vessel.shape) == names.end()) return 0;  // refused as read
  const VesselShape& shape = vessel_shape(s.vessel.shape);
  if (!shape.surface()) return 0;
  const bool cells = (s.rbc.present && s.rbc.hematocrit > 0) || (s.platelet.present && s.platelet.number_density > 0);
  r.refuse_once(!cells || shape.carries_cells(), "vessel.shape",
                "vessel.shape \"" + shape.name +
                    "\" carries plasma alone for now: the particle node does not know its branches "
                    "(model/vessel_wall.h); remove rbc.hematocrit and platelet.number_density_per_ul");
  if (known_ends(s.vessel)) {
    r.refuse_once(open_ends(s.vessel), "vessel.ends",
                  "a surface vessel has open ends (an inlet and outlets): set vessel.ends = \"open\"");
  }
  r.refuse_once(s.run.fluid_ranks == 1, "run.fluid_ranks",
                "a surface vessel's fluid runs on one rank for now (the decomposition splits the O-grid's layers)");
  if (!r.problems().empty()) return 0;
  const bool from_file = shape.takes("vessel.surface");  // a problem of the surface is blamed on its file
  const std::string key = from_file ? "vessel.surface" : "vessel.shape";
  if (from_file && s.vessel.surface_file.empty()) {
    r.refuse_once(false, key, "missing: the ASCII STL of the vessel.shape \"" + shape.name + "\"");
    return 0;
  }
  Surface surface;
  try {
    surface = make_vessel_surface(s.vessel);
  } catch (const std::exception& e) {
    r.refuse_once(false, key, e.what());
    return 0;
  }
  // Every end wide enough for a red cell (as a bifurcation's daughters are, check_bifurcation):
  // the vessel is for blood. An end's width is the diameter of a disc of its area.
  const std::vector<std::string> outlets = from_file ? surface_outlet_names(s.vessel) : std::vector<std::string>{};
  double narrowest = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < surface.region_names.size(); ++k) {
    const std::string& region = surface.region_names[k];
    if (region == surface_region::wall) continue;
    const double width = 2 * std::sqrt(surface.area(static_cast<int>(k)) / units::pi);
    narrowest = std::min(narrowest, width);
    if (width >= kMinDaughterDiameter) continue;
    std::string named = region;  // an imported surface's ends by the file's names
    if (from_file && region == surface_region::inlet) named = "'" + s.vessel.surface_inlet + "' (the inlet)";
    for (std::size_t o = 0; from_file && o < outlets.size(); ++o)
      if (region == surface_region::outlet(static_cast<int>(o) + 1)) named = "'" + outlets[o] + "' (" + region + ")";
    r.refuse_once(false, key,
                  fmt::format("the surface's end {} is {:.1f} um across (a disc of its area), narrower than a red "
                              "cell ({:g} um)",
                              named, width / units::um, kMinDaughterDiameter / units::um));
    return 0;
  }
  if (fed_by_feeder(s.vessel)) {
    try {
      (void)feeder_layout(s);
    } catch (const std::exception& e) {
      r.refuse_once(false, "vessel.inlet", e.what());
    }
  }
  return std::isfinite(narrowest) ? narrowest : 0;
}

double surface_cell_size(const Scene& s) {
  return s.mesh.surface_cell_size > 0 ? s.mesh.surface_cell_size : s.vessel.diameter / 12;
}

WorkEstimate estimate_work(const Scene& s) {
  WorkEstimate w;
  double volume = vessel_volume(s.vessel);
  if (known_ends(s.vessel) && fed_by_feeder(s.vessel)) {  // the feeder carries the scene's blood too
    const FeederLayout feeder = feeder_layout(s);
    volume += units::pi * feeder.radius * feeder.radius * feeder.period;
  }
  w.particles = (s.rbc.present ? s.rbc.hematocrit * volume / s.rbc.volume : 0) +
                (s.platelet.present ? s.platelet.number_density * volume : 0);
  // The particle node's contact time (particle-node/dem_timing.cpp calls the same function).
  w.contact_time = particles::shortest_contact_time(particles::dem_scene(s), s.driving.wall_shear_rate).time;
  if (s.time.dem_substeps > 0)
    w.substeps = s.time.dem_substeps;
  else if (std::isfinite(w.contact_time))
    w.substeps = particles::dem_substeps(s.time.coupling_interval, w.contact_time / s.time.steps_per_contact);
  else
    w.substeps = 0;  // no particles: no DEM
  w.particle_steps = w.substeps * static_cast<double>(s.time.coupling_steps) * std::ceil(w.particles);
  return w;
}

namespace {

// Cross-checks of a scene whose every value is valid on its own: the particles fit the vessel
// and are smaller than its fluid cells (unresolved CFD-DEM), and the run is a sane amount of work.
constexpr double kMinMeshWallSpan = 100 * units::um;

// narrowest_end: a surface vessel's narrowest end (m, 0: not known).
void check_geometry_and_work(Reader& r, const Scene& s, double narrowest_end) {
  // Blame the key the file gives (the species' diameter if it sets one, else the vessel's).
  auto blame = [&](const std::string& own, const std::string& other) {
    return r.line_of(own) > 0 || r.line_of(other) == 0 ? own : other;
  };
  auto fail = [&](const std::string& key, const std::string& value, const std::string& message) {
    r.problem(key, r.line_of(key), message, value);
  };
  const double d_vessel = s.vessel.diameter;
  // A surface vessel's cells are snapped cubes (fluid-node/surface_mesh.h): unresolved CFD-DEM
  // needs them wider than the cells it carries, unless a kernel wider than the particle shares them
  // (model/solid_fraction_names.h), at least a cube wide at half maximum and at most the narrowest
  // end's radius.
  if (surface_vessel(s.vessel)) {
    const double cube = s.mesh.surface_cell_size > 0 ? s.mesh.surface_cell_size : d_vessel / 12;
    if (shares_over_kernel(s.solid_fraction)) {
      for (const Species* sp : {&s.rbc, &s.platelet}) {
        if (!sp->present) continue;
        const double fwhm = s.kernel_width_diameters * sp->diameter;
        if (fwhm < cube)
          fail("coupling.kernel_width_diameters", fmt::format("{:g}", s.kernel_width_diameters),
               fmt::format("a {}'s kernel ({:g} um at half maximum) is narrower than the snapped cubes ({:g} um): "
                           "the cells' centres would not sample it; widen it or use smaller cubes",
                           sp->name, fwhm / units::um, cube / units::um));
        else if (narrowest_end > 0 && fwhm > narrowest_end / 2)
          fail("coupling.kernel_width_diameters", fmt::format("{:g}", s.kernel_width_diameters),
               fmt::format("a {}'s kernel ({:.3g} um at half maximum) is wider than the radius of the vessel's "
                           "narrowest end ({:.3g} um): it would average the flow across the vessel; narrow it",
                           sp->name, fwhm / units::um, narrowest_end / 2 / units::um));
      }
      return;
    }
    for (const Species* sp : {&s.rbc, &s.platelet})
      if (sp->present && sp->diameter >= cube)
        fail("mesh.surface_cell_size_um", fmt::format("{:g}", cube / units::um),
             fmt::format("the snapped cubes ({:g} um) must be wider than a {} ({:g} um): the particles are unresolved "
                         "in the fluid's cells (CFD-DEM); widen mesh.surface_cell_size_um, or share them over "
                         "a kernel (coupling.solid_fraction = \"gaussian_kernel\")",
                         cube / units::um, sp->name, sp->diameter / units::um));
    return;
  }
  // The mesh's cell size: the edge of a cube of the mean cell volume (the O-grid's cells differ
  // little in volume; postprocess/study/study_file.h uses the same measure).
  const double cells =
      std::max(1.0, (1.0 * s.mesh.core_cells * s.mesh.core_cells + 4.0 * s.mesh.core_cells * s.mesh.ring_cells) *
                        s.mesh.axial_cells);
  const double cell = std::cbrt(vessel_volume(s.vessel) / cells);
  for (const Species* sp : {&s.rbc, &s.platelet}) {
    if (!sp->present) continue;
    const std::string dkey = sp->name + ".diameter_um";
    const double d = sp->diameter;
    const std::string dtext = fmt::format("{:g}", d / units::um);
    if (!(d < d_vessel / 2)) {
      const auto key = blame(dkey, "vessel.diameter_um");
      fail(key, key == dkey ? dtext : fmt::format("{:g}", d_vessel / units::um),
           fmt::format("a {} of {:g} um does not fit a vessel of {:g} um: its diameter must be below half the "
                       "vessel's (vessel.diameter_um above {:g})",
                       sp->name, d / units::um, d_vessel / units::um, 2 * d / units::um));
      continue;
    }
    if (!(2 * d <= s.vessel.length)) {
      const auto key = blame(dkey, "vessel.length_um");
      fail(key, key == dkey ? dtext : fmt::format("{:g}", s.vessel.length / units::um),
           fmt::format("the periodic vessel of {:g} um is shorter than two {} diameters ({:g} um)",
                       s.vessel.length / units::um, sp->name, 2 * d / units::um));
      continue;
    }
    // A kernel at least a cell wide at half maximum and at most the vessel's radius shares a particle
    // over cells narrower than it, as in a surface vessel (above): the feeder of such a vessel is
    // this O-grid, developed on its own (model/feeder_develop.h).
    const double fwhm = s.kernel_width_diameters * d;
    const bool kernel_spans_cells = shares_over_kernel(s.solid_fraction) && fwhm >= cell && fwhm <= d_vessel / 2;
    if (!(d / cell < 1) && !kernel_spans_cells) {
      const std::string key = blame(dkey, "mesh.axial_cells");
      fail(key, key == dkey ? dtext : r.value_text(key),
           fmt::format("a {} of {:g} um is larger than the fluid cells ({:.3g} um, the cube root of the mean cell "
                       "volume): unresolved CFD-DEM needs particle diameter / cell size < 1 (here {:.2f}); use fewer "
                       "cells (mesh.*) or smaller particles, or share them over a kernel at least a cell wide "
                       "(coupling.solid_fraction = \"gaussian_kernel\")",
                       sp->name, d / units::um, cell / units::um, d / cell));
    }
  }
  if (const auto& shape = vessel_shape(s.vessel.shape); !shape.narrowing_key.empty()) {
    const double throat = 2 * make_vessel_geometry(s.vessel)->throat_radius();
    if (!(throat > s.rbc.diameter))
      fail(shape.narrowing_key,
           r.value_text(shape.narrowing_key).empty() ? fmt::format("{:g}", s.vessel.stenosis_area_reduction)
                                                     : r.value_text(shape.narrowing_key),
           fmt::format("the throat is {:.3g} um across, narrower than a red cell (rbc.diameter_um {:g}): lower it "
                       "or widen the vessel",
                       throat / units::um, s.rbc.diameter / units::um));
    // LIGGGHTS refuses a mesh whose coordinates span less than 1e-4 (its round-off guard).
    const double R = s.vessel.radius(), span = std::max(s.vessel.length, R) + R;
    if (!(span >= kMinMeshWallSpan))
      fail("vessel.length_um", r.value_text("vessel.length_um"),
           fmt::format("a vessel.shape that narrows has a LIGGGHTS mesh wall, which needs the vessel to span at "
                       "least {:g} um (max(l, d/2) + d/2 is {:.3g} um): lengthen the vessel",
                       kMinMeshWallSpan / units::um, span / units::um));
  }
  if (std::max<long long>(1,
                          1LL * s.mesh.core_cells * s.mesh.core_cells + 4LL * s.mesh.core_cells * s.mesh.ring_cells) *
          s.mesh.axial_cells >
      20'000'000)
    fail("mesh.axial_cells", r.value_text("mesh.axial_cells"), "the mesh would have more than 20,000,000 cells");
  if (!r.problems().empty()) return;

  const auto w = estimate_work(s);
  if (w.substeps > kMaxDemSubsteps) {
    const std::string key = r.line_of("time.dem_substeps") > 0 ? "time.dem_substeps" : "time.coupling_interval_s";
    fail(key, r.value_text(key).empty() ? fmt::format("{:g}", s.time.coupling_interval) : r.value_text(key),
         fmt::format("plans {:.3g} DEM substeps per coupling interval (shortest contact {:.3g} s / "
                     "time.dem_steps_per_contact {:g}): at most {:g}; shorten the coupling interval",
                     w.substeps, w.contact_time, s.time.steps_per_contact, kMaxDemSubsteps));
  } else if (w.particle_steps > kMaxParticleSteps) {
    fail("time.coupling_steps", std::to_string(s.time.coupling_steps),
         fmt::format("plans {:.3g} particle-steps ({:.0f} particles x {:.3g} DEM substeps x {} coupling steps): "
                     "at most {:g}",
                     w.particle_steps, std::ceil(w.particles), w.substeps, s.time.coupling_steps, kMaxParticleSteps));
  }
}

// Whether the particles can be placed, found by placing them: the particle node's own placement
// (model/placement.h, the same function and order), with the scene's seed, in the vessel the
// node places in. That vessel is the built-in fluid node's mesh, whose diameter and length are
// the scene's (fluid-node/vessel_mesh.cpp, fill_mesh_message; the particle node refuses a mesh
// that differs) and whose lowest point, the node's z0, is z = 0 (make_vessel_mesh extrudes from
// z = 0): the check's placement is the node's, bit for bit (tests/particles,
// PlacementInTheMesh.*). Why not a bound on the volume fraction: what fits depends on the
// vessel's size (the wall gap, how the lattice meets the wall), on the species' mix and on the
// seed; a safe bound would refuse scenes that run, a loose one pass scenes that stop at step 0.
void check_placement(Reader& r, const Scene& s) {
  namespace pl = particles;
  if (!placement_checked(s)) return;  // too many to place here: the particle node will tell
  // A surface vessel places cells only from its feeder and in a shape whose branches are known;
  // anything else is refused already (check_surface_vessel, refuse_cells_without_feeder).
  if (surface_vessel(s.vessel) && !(vessel_shape(s.vessel.shape).carries_cells() && fed_by_feeder(s.vessel))) return;
  try {
    pl::place_scene_particles(s, *make_vessel_wall(s.vessel), 0.0);
  } catch (const pl::PlacementError& e) {
    const Species* sp = e.species == pl::kRbc ? &s.rbc : e.species == pl::kPlatelet ? &s.platelet : nullptr;
    if (sp == nullptr) {  // not a species' (validation rules out such vessels and requests)
      r.problem("vessel.diameter_um", r.line_of("vessel.diameter_um"), std::string("cannot be placed: ") + e.what(),
                r.value_text("vessel.diameter_um"));
      return;
    }
    // The key that made the species present, and so is in the file.
    const std::string key = sp->name + (sp == &s.rbc ? ".hematocrit" : ".number_density_per_ul");
    const double vessel = vessel_volume(s.vessel);
    const double asked = static_cast<double>(e.requested) * units::pi / 6 * std::pow(sp->diameter, 3) / vessel;
    r.problem(key, r.line_of(key),
              fmt::format("cannot be placed: {} {}s of {:g} um, a sphere volume fraction of {:.3g}, in a vessel of "
                          "{:g} x {:g} um; the particle node's placement (run.seed {}) would stop at step 0: {}",
                          e.requested, sp == &s.rbc ? "RBC" : "platelet", sp->diameter / units::um, asked,
                          s.vessel.diameter / units::um, s.vessel.length / units::um, s.run.seed, e.what()),
              r.value_text(key));
  }
}

}  // namespace

bool placement_checked(const Scene& s) {
  return particles::rbc_count(s) + particles::platelet_count(s) <= kMaxCheckedPlacement;
}

// The deepest nesting a TOML text can make: the dots of the current [table] header, plus open
// brackets and braces and the dots of the keys on a line (a.b.c = 1 is three levels), outside
// strings and comments. An overestimate (a number's decimal point counts too) is fine: the
// limit is far above any scene's.
static int nesting_depth(const std::string& text) {
  int deepest = 0, brackets = 0, dots = 0, header = 0;
  bool line_start = true, header_line = false;
  enum { code, basic, literal, ml_basic, ml_literal, comment } state = code;
  auto end_line = [&] {
    if (header_line) header = dots + 1;
    dots = 0, line_start = true, header_line = false;
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
    const bool triple_quote = text.compare(i, 3, "\"\"\"") == 0, triple_apos = text.compare(i, 3, "'''") == 0;
    switch (state) {
      case code:
        if (line_start && ch != ' ' && ch != '\t' && ch != '\n' && ch != '\r') {
          line_start = false;
          header_line = ch == '[' && brackets == 0;
        }
        if (ch == '#')
          state = comment;
        else if (triple_quote)
          state = ml_basic, i += 2;
        else if (triple_apos)
          state = ml_literal, i += 2;
        else if (ch == '"')
          state = basic;
        else if (ch == '\'')
          state = literal;
        else if (ch == '[' || ch == '{')
          ++brackets;
        else if (ch == ']' || ch == '}')
          brackets = std::max(0, brackets - 1);
        else if (ch == '.')
          ++dots;
        else if (ch == '\n')
          end_line();
        break;
      case basic:
        if (ch == '\\')
          ++i;
        else if (ch == '"')
          state = code;
        else if (ch == '\n')
          state = code, end_line();
        break;
      case literal:
        if (ch == '\'')
          state = code;
        else if (ch == '\n')
          state = code, end_line();
        break;
      case ml_basic:
        if (ch == '\\')
          ++i;
        else if (triple_quote)
          state = code, i += 2;
        break;
      case ml_literal:
        if (triple_apos) state = code, i += 2;
        break;
      case comment:
        if (ch == '\n') state = code, end_line();
        break;
    }
    deepest = std::max(deepest, (header_line ? 0 : header) + brackets + dots + 1);
  }
  return deepest;
}

// Reads the file, refusing before any parsing what toml++ should not see: anything but a
// regular file (a FIFO would hang the reader, a directory or device is no scene), a file over
// kMaxSceneBytes, nesting deeper than kMaxSceneNesting (toml++ recurses per level).
static std::string read_scene_text(const std::string& path) {
  auto refuse = [&](const std::string& why) { return SceneError(path, {{"(file)", 0, why}}); };
  // O_NONBLOCK: opening a FIFO does not wait for a writer; fstat on what was opened (no race
  // between looking and opening).
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw refuse(fmt::format("cannot open: {}", std::strerror(errno)));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw refuse(fmt::format("cannot stat: {}", std::strerror(errno)));
  if (!S_ISREG(st.st_mode)) {
    const char* what = S_ISDIR(st.st_mode)    ? "a directory"
                       : S_ISFIFO(st.st_mode) ? "a FIFO"
                       : S_ISCHR(st.st_mode)  ? "a character device"
                       : S_ISBLK(st.st_mode)  ? "a block device"
                       : S_ISSOCK(st.st_mode) ? "a socket"
                                              : "not a regular file";
    throw refuse(fmt::format("is {}, not a regular file", what));
  }
  if (st.st_size > kMaxSceneBytes)
    throw refuse(fmt::format("{} bytes: larger than a scene may be ({} bytes)", st.st_size, kMaxSceneBytes));
  std::string text;
  text.resize(static_cast<std::size_t>(kMaxSceneBytes) + 1);
  std::size_t got = 0;
  for (;;) {
    const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw refuse(fmt::format("cannot read: {}", std::strerror(errno)));
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
    if (got == text.size()) throw refuse(fmt::format("larger than a scene may be ({} bytes)", kMaxSceneBytes));
  }
  text.resize(got);
  if (text.find('\0') != std::string::npos) throw refuse("holds NUL bytes: not a TOML text file");
  if (const int depth = nesting_depth(text); depth > kMaxSceneNesting)
    throw refuse(fmt::format("nested {} levels deep (tables, arrays, dotted keys): at most {} are allowed", depth,
                             kMaxSceneNesting));
  return text;
}

static toml::table parse_scene_file(const std::string& path) {
  const std::string text = read_scene_text(path);
  try {
    return toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    const int line = static_cast<int>(e.source().begin.line);
    if (e.source().path == nullptr && line == 0) throw SceneError(path, {{"(file)", 0, std::string(e.description())}});
    throw SceneError(path, {{"(syntax)", line, std::string(e.description())}});
  }
}

Scene load_scene(const std::string& path, SceneCheck check) {
  std::vector<SceneKey> unused;
  return read_scene(parse_scene_file(path), path, unused, check);
}

std::string SceneKey::allowed() const {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "one of \"" : ", \"") + n + "\"";
  for (const auto& r : rules) s += (s.empty() ? "" : "; ") + r;
  return s;
}

std::string SceneKey::table_row() const {
  return fmt::format("| `{}` | {} | {} |", key, default_value.empty() ? "—" : default_value,
                     allowed().empty() ? "any" : allowed());
}

std::vector<SceneKey> scene_keys() {
  std::vector<SceneKey> keys;
  toml::table empty;
  try {
    read_scene(empty, "(defaults)", keys);
  } catch (const SceneError& e) {
    // An empty scene lacks exactly the keys without a default: say so in the listing.
    for (const auto& p : e.problems())
      for (auto& k : keys)
        if (k.key == p.key || k.key.rfind(p.key + ".", 0) == 0)
          k.default_value = p.key == k.key ? "required" : "required: " + p.message;
  }
  return keys;
}

// [hosts]: each list parsed as `hemocosim run --*-hosts` parses it; a node's ranks become its
// hosts' sum, and a run.*_ranks that says otherwise is refused.
static void read_hosts(Reader& r, Scene& s) {
  auto& h = s.hosts;
  for (auto [key, list, ranks_key, ranks] :
       {std::tuple{"hosts.fluid", &h.fluid, "run.fluid_ranks", &s.run.fluid_ranks},
        std::tuple{"hosts.particles", &h.particles, "run.particle_ranks", &s.run.particle_ranks}}) {
    if (!r.read(key, *list)) continue;
    try {
      *ranks = ranks_for_hosts(parse_host_list(*list), *ranks, ranks_key);
    } catch (const std::invalid_argument& e) {
      r.check(false, key, e.what());
    }
  }
  read_choice(r, "hosts.launcher", h.launcher);
  read_choice(r, "hosts.transport", h.transport);
  r.read("hosts.relay_address", h.relay_address);
  in_addr ip{};
  r.check(h.relay_address == "auto" || ::inet_pton(AF_INET, h.relay_address.c_str(), &ip) == 1, "hosts.relay_address",
          "must be \"auto\" or an IPv4 address of this host (LCM's tcpq takes no names)");
  r.read("hosts.relay_port", h.relay_port);
  r.check(h.relay_port >= 0 && h.relay_port <= 65535, "hosts.relay_port", "must be 0 (any free port) to 65535");
  r.read("hosts.launch_command", h.launch_command);
  try {
    check_launch_command(h.launch_command);
  } catch (const std::invalid_argument& e) {
    r.check(false, "hosts.launch_command", e.what());
  }
}

// vessel.shape and its parameters (model/geometry.h); a shape ignores the parameters it does not
// take.
// Whether the vessel's radius is the same everywhere; a shape refused on its own counts as such.
static bool uniform_vessel(const Vessel& v) {
  try {
    return make_vessel_geometry(v)->uniform();
  } catch (const std::invalid_argument&) {
    return true;
  }
}

static void read_vessel_shape(Reader& r, Vessel& v, const std::string& scene_path) {
  read_name(r, "vessel.shape", v.shape, vessel_shape_names());
  // A bifurcation's daughters and an imported surface (model/bifurcation.h, surface.h); whether
  // the surface can be a vessel is checked with the rest of a surface vessel
  // (check_surface_vessel).
  for (int i = 0; i < 2; ++i) {
    const std::string key = fmt::format("vessel.daughter_{}_diameter_um", i + 1);
    r.read(key, v.daughter_diameter[i], units::um);
    r.check(v.daughter_diameter[i] >= 0, key, "must not be negative (0: Murray's law, the parent's / 2^(1/3))");
  }
  r.read("vessel.daughter_length_um", v.daughter_length, units::um);
  r.check(v.daughter_length >= 0, "vessel.daughter_length_um", "must not be negative (0: the parent's length)");
  r.read("vessel.bifurcation_angle_deg", v.bifurcation_angle, units::pi / 180);
  r.check(v.bifurcation_angle > 0 && v.bifurcation_angle < units::pi, "vessel.bifurcation_angle_deg",
          "must be in (0, 180)");
  r.read("vessel.surface", v.surface_file);
  // The run directory keeps a copy of the surface at the same path relative to its scene.toml
  // (coordinator/run_directory.cpp): a relative path stays below the scene's folder.
  const std::filesystem::path file(v.surface_file);
  bool climbs = false;
  for (const auto& part : file) climbs = climbs || part == "..";
  r.check(file.is_absolute() || !climbs, "vessel.surface",
          "must be absolute or a path below the scene file's folder (no ..): the run directory keeps a copy at "
          "that path");
  if (!v.surface_file.empty())
    v.surface_path = file.is_absolute() ? file.string()
                                        : (std::filesystem::path(scene_path).parent_path() / file).lexically_normal().string();
  r.read("vessel.surface_inlet", v.surface_inlet);
  r.read("vessel.surface_outlets", v.surface_outlets);
  r.read("vessel.stenosis_area_reduction", v.stenosis_area_reduction);
  r.check(v.stenosis_area_reduction >= 0 && v.stenosis_area_reduction < 1, "vessel.stenosis_area_reduction",
          "must be in [0, 1) (1 closes the vessel)");
  r.read("vessel.stenosis_length_um", v.stenosis_length, units::um);
  r.check(v.stenosis_length >= 0, "vessel.stenosis_length_um", "must not be negative");
  const VesselShape* shape = nullptr;
  for (const VesselShape& sh : vessel_shapes())
    if (sh.name == v.shape) shape = &sh;
  if (shape == nullptr) return;  // refused above
  r.check(!shape->takes("vessel.stenosis_length_um") || v.stenosis_length > 0, "vessel.stenosis_length_um",
          "must be positive for a vessel.shape that takes it");
  r.check(!(v.stenosis_length > v.length) || !(v.length > 0), "vessel.stenosis_length_um",
          "must not exceed vessel.length_um (the constriction fits in the periodic vessel)");
}

static Scene read_scene(const toml::table& root, const std::string& path, std::vector<SceneKey>& catalogue,
                        SceneCheck check) {
  Scene s;
  s.source_path = path;
  Reader r(root);

  r.read("run.name", s.run.name);
  r.read("run.seed", s.run.seed);
  r.read("run.node_timeout_s", s.run.node_timeout);
  r.read("run.startup_timeout_s", s.run.startup_timeout);
  r.read("run.step_timeout_s", s.run.step_timeout);
  r.read("run.drop_every", s.run.drop_every);
  r.read("run.max_restarts", s.run.max_restarts);
  r.check(s.run.max_restarts >= 0, "run.max_restarts", "must not be negative (0: a dead node stops the run)");
  r.read("run.fluid_ranks", s.run.fluid_ranks);
  r.read("run.particle_ranks", s.run.particle_ranks);
  r.check(s.run.fluid_ranks >= 1, "run.fluid_ranks", "must be at least 1");
  r.check(s.run.particle_ranks >= 1, "run.particle_ranks", "must be at least 1");
  r.check(s.run.drop_every >= 0, "run.drop_every", "must not be negative (0: no fault injection)");
  r.read("run.max_courant", s.run.max_courant);
  r.read("run.max_overlap", s.run.max_overlap);
  r.check(s.run.max_courant > 0, "run.max_courant", "must be positive");
  r.check(s.run.max_overlap > 0 && s.run.max_overlap <= 1, "run.max_overlap", "must be in (0, 1]");
  r.read("run.fluid_command", s.run.fluid_command);
  r.read("run.particle_command", s.run.particle_command);
  r.read("run.bus_ttl", s.run.bus_ttl);
  r.check(s.run.bus_ttl >= -1 && s.run.bus_ttl <= 255, "run.bus_ttl",
          "must be -1 (0 on one host, 1 across hosts) or a TTL from 0 to 255");
  r.read("run.bus_check_s", s.run.bus_check_s);
  r.check(s.run.bus_check_s > 0, "run.bus_check_s", "must be positive");
  read_hosts(r, s);
  r.read("bus.encrypt", s.bus.encrypt);
  r.check(s.run.node_timeout > 0, "run.node_timeout_s", "must be positive");
  r.check(s.run.startup_timeout > 0, "run.startup_timeout_s", "must be positive");
  r.check(s.run.step_timeout > 0, "run.step_timeout_s", "must be positive");

  // Required, without a default: missing is one problem, not also "must be positive".
  for (auto [key, value] :
       {std::pair{"vessel.diameter_um", &s.vessel.diameter}, {"vessel.length_um", &s.vessel.length}}) {
    if (!r.read(key, *value, units::um))
      r.refuse_once(r.line_of(key) > 0, key, "missing");  // given but refused: that problem, not also "missing"
    r.check(*value > 0, key, "must be positive");
  }
  read_vessel_shape(r, s.vessel, path);
  read_vessel_ends(r, s.vessel);

  r.read("mesh.core_cells", s.mesh.core_cells);
  r.read("mesh.ring_cells", s.mesh.ring_cells);
  r.read("mesh.axial_cells", s.mesh.axial_cells);
  r.check(s.mesh.core_cells >= 1, "mesh.core_cells", "must be at least 1");
  r.check(s.mesh.ring_cells >= 1, "mesh.ring_cells", "must be at least 1");
  r.check(s.mesh.axial_cells >= 1, "mesh.axial_cells", "must be at least 1");
  read_choice(r, "mesh.wall_polygon", s.mesh.wall_polygon);
  r.read("mesh.surface_cell_size_um", s.mesh.surface_cell_size, units::um);
  r.check(s.mesh.surface_cell_size >= 0, "mesh.surface_cell_size_um",
          "must not be negative (0: the vessel's diameter / 12)");

  r.read("plasma.density_kg_m3", s.plasma.density);
  r.read("plasma.viscosity_Pa_s", s.plasma.viscosity);
  r.check(s.plasma.density > 0, "plasma.density_kg_m3", "must be positive");
  r.check(s.plasma.viscosity > 0, "plasma.viscosity_Pa_s", "must be positive");
  read_name(r, "plasma.suspension_viscosity", s.plasma.suspension_viscosity, suspension_viscosity_names());

  const bool has_dp = r.read("driving.pressure_drop_Pa", s.driving.pressure_drop);
  const bool has_shear = r.read("driving.wall_shear_rate_per_s", s.driving.wall_shear_rate);
  if (has_dp == has_shear)
    r.problem("driving", r.line_of("driving"), "give exactly one of pressure_drop_Pa and wall_shear_rate_per_s");
  r.check(s.driving.pressure_drop >= 0, "driving.pressure_drop_Pa", "must not be negative");
  r.check(s.driving.wall_shear_rate >= 0, "driving.wall_shear_rate_per_s", "must not be negative");
  // gamma_w = d dP / (4 mu l): the wall shear rate is defined from the pressure drop (docs/model.md §4).
  if (has_shear)
    s.driving.pressure_drop =
        pressure_drop_of(s.driving.wall_shear_rate, s.vessel.diameter, s.plasma.viscosity, s.vessel.length);
  else if (s.vessel.diameter > 0 && s.vessel.length > 0)
    s.driving.wall_shear_rate =
        wall_shear_rate_of(s.vessel.diameter, s.driving.pressure_drop, s.plasma.viscosity, s.vessel.length);

  read_species(r, s.rbc, true);
  read_species(r, s.platelet, false);
  refuse_cells_without_feeder(r, s);
  const double narrowest_end = check_surface_vessel(r, s);

  auto& c = s.contact;
  r.read("contact.cell_youngs_modulus_Pa", c.cell_youngs_modulus);
  r.read("contact.wall_youngs_modulus_Pa", c.wall_youngs_modulus);
  r.read("contact.cell_poisson_ratio", c.cell_poisson_ratio);
  r.read("contact.wall_poisson_ratio", c.wall_poisson_ratio);
  r.read("contact.cell_cell_restitution", c.cell_cell_restitution);
  r.read("contact.cell_wall_restitution", c.cell_wall_restitution);
  r.read("contact.friction", c.friction);
  r.check(c.cell_youngs_modulus > 0, "contact.cell_youngs_modulus_Pa", "must be positive");
  r.check(c.wall_youngs_modulus > 0, "contact.wall_youngs_modulus_Pa", "must be positive");
  r.check(c.cell_poisson_ratio > -1 && c.cell_poisson_ratio < 0.5, "contact.cell_poisson_ratio",
          "must be in (-1, 0.5)");
  r.check(c.wall_poisson_ratio > -1 && c.wall_poisson_ratio < 0.5, "contact.wall_poisson_ratio",
          "must be in (-1, 0.5)");
  r.check(c.cell_cell_restitution > 0 && c.cell_cell_restitution <= 1, "contact.cell_cell_restitution",
          "must be in (0, 1]");
  r.check(c.cell_wall_restitution > 0 && c.cell_wall_restitution <= 1, "contact.cell_wall_restitution",
          "must be in (0, 1]");
  r.check(c.friction >= 0, "contact.friction", "must not be negative");

  r.read("time.coupling_interval_s", s.time.coupling_interval);
  r.read("time.coupling_steps", s.time.coupling_steps);
  r.read("time.dem_substeps", s.time.dem_substeps);
  r.read("time.dem_steps_per_contact", s.time.steps_per_contact);
  r.read("time.dem_step_max_relaxation_times", s.time.relaxation_factor);
  r.read("time.closure_every_dem_steps", s.time.closure_every_dem_steps);
  r.check(s.time.closure_every_dem_steps >= 1, "time.closure_every_dem_steps",
          "must be at least 1 (1: every DEM step)");
  r.read("time.mass_scaling", s.time.mass_scaling);
  r.check(s.time.mass_scaling >= 1 && std::isfinite(s.time.mass_scaling), "time.mass_scaling",
          "must be at least 1 (1: the physical masses)");
  r.check(s.time.steps_per_contact >= 1, "time.dem_steps_per_contact", "must be at least 1");
  r.check(s.time.relaxation_factor >= 0, "time.dem_step_max_relaxation_times",
          "must not be negative (0: the drag relaxation time does not limit the DEM step)");
  r.check(s.time.coupling_interval > 0, "time.coupling_interval_s", "must be positive");
  r.check(s.time.coupling_steps >= 1, "time.coupling_steps", "must be at least 1");
  r.check(s.time.dem_substeps >= 0, "time.dem_substeps", "must not be negative (0 derives it)");
  r.read("time.coupling_relaxation_times", s.time.coupling_relaxation_times);
  r.check(s.time.coupling_relaxation_times >= 0 && std::isfinite(s.time.coupling_relaxation_times),
          "time.coupling_relaxation_times", "must not be negative (0: fixed coupling intervals)");

  read_choice(r, "dem.neighbour_rebuild", s.neighbour_rebuild);
  r.check(s.neighbour_rebuild == NeighbourRebuild::engine || uniform_vessel(s.vessel), "dem.neighbour_rebuild",
          "\"streaming\" predicts the straight tube's Poiseuille flow: use \"engine\" in a vessel.shape that narrows");
  r.check(s.neighbour_rebuild == NeighbourRebuild::engine || !known_ends(s.vessel) || !open_ends(s.vessel), "dem.neighbour_rebuild",
          "\"streaming\" predicts a periodic vessel's flow: use \"engine\" in an open vessel");

  r.read("output.every_steps", s.output.every_steps);
  r.check(s.output.every_steps >= 1, "output.every_steps", "must be at least 1");
  r.read("output.checkpoint_every_steps", s.output.checkpoint_every_steps);
  r.check(s.output.checkpoint_every_steps >= 0, "output.checkpoint_every_steps", "must not be negative (0: never)");

  r.read("gravity.x_m_s2", s.gravity.x);
  r.read("gravity.y_m_s2", s.gravity.y);
  r.read("gravity.z_m_s2", s.gravity.z);

  auto& f = s.fluid;
  r.read("fluid.pressure_tolerance", f.pressure_tolerance);
  r.read("fluid.pressure_relative_tolerance", f.pressure_relative_tolerance);
  r.read("fluid.velocity_tolerance", f.velocity_tolerance);
  r.read("fluid.velocity_relative_tolerance", f.velocity_relative_tolerance);
  r.read("fluid.momentum_predictor", f.momentum_predictor);
  r.read("fluid.min_correctors", f.min_correctors);
  r.read("fluid.max_correctors", f.max_correctors);
  r.read("fluid.corrector_tolerance", f.corrector_tolerance);
  r.read("fluid.non_orthogonal_correctors", f.non_orthogonal_correctors);
  r.read("fluid.skip_when_steady", f.skip_when_steady);
  r.read("fluid.steady_tolerance", f.steady_tolerance);
  r.read("fluid.solve_every", f.solve_every);
  read_name(r, "fluid.pressure_solver", f.pressure_solver, {"GAMG", "PCG"});
  r.check(f.pressure_tolerance > 0, "fluid.pressure_tolerance", "must be positive");
  r.check(f.pressure_relative_tolerance >= 0 && f.pressure_relative_tolerance < 1, "fluid.pressure_relative_tolerance",
          "must be in [0, 1)");
  r.check(f.velocity_tolerance > 0, "fluid.velocity_tolerance", "must be positive");
  r.check(f.velocity_relative_tolerance >= 0 && f.velocity_relative_tolerance < 1, "fluid.velocity_relative_tolerance",
          "must be in [0, 1)");
  r.check(f.min_correctors >= 1, "fluid.min_correctors", "must be at least 1");
  r.check(f.max_correctors >= f.min_correctors, "fluid.max_correctors", "must be at least fluid.min_correctors");
  r.check(f.corrector_tolerance > 0, "fluid.corrector_tolerance", "must be positive");
  r.check(f.non_orthogonal_correctors >= 0, "fluid.non_orthogonal_correctors",
          "must not be negative (0: one pressure solve per corrector)");
  r.check(f.steady_tolerance > 0, "fluid.steady_tolerance", "must be positive");
  r.check(f.solve_every >= 1, "fluid.solve_every", "must be at least 1 (1: the fluid solved every coupling step)");

  r.read("coupling.two_way", s.two_way);
  read_name(r, "coupling.solid_fraction", s.solid_fraction, known_solid_fractions());
  r.read("coupling.kernel_width_diameters", s.kernel_width_diameters);
  r.check(s.kernel_width_diameters > 0, "coupling.kernel_width_diameters", "must be positive");
  read_choice(r, "coupling.scheme", s.coupling_scheme);
  read_choice(r, "dem.load_balance", s.load_balance);
  r.read("dem.load_balance_every_steps", s.load_balance_every_steps);
  r.read("dem.load_balance_threshold", s.load_balance_threshold);
  r.check(s.load_balance_every_steps >= 1, "dem.load_balance_every_steps", "must be at least 1");
  r.check(s.load_balance_threshold >= 1 && std::isfinite(s.load_balance_threshold), "dem.load_balance_threshold",
          "must be at least 1 (1: any imbalance moves the cuts)");
  r.check(s.load_balance == LoadBalance::none || s.coupling_scheme == CouplingScheme::serial, "dem.load_balance",
          "moves the slabs between a step's feedback and its fluid state, which the parallel scheme overlaps: use "
          "coupling.scheme = \"serial\"");
  r.check(s.load_balance == LoadBalance::none || s.neighbour_rebuild == NeighbourRebuild::engine, "dem.load_balance",
          "\"streaming\" neighbour lists run on one particle rank: use dem.neighbour_rebuild = \"engine\"");
  r.check(s.load_balance == LoadBalance::none || !known_ends(s.vessel) || !open_ends(s.vessel), "dem.load_balance",
          "is tested in periodic vessels only: an open vessel's insertion and removal at moving slabs is not");
  read_choice(r, "coupling.implicit_drag", s.implicit_drag);
  r.read("coupling.return_held_back_momentum", s.return_held_back_momentum);
  read_choice(r, "coupling.fluid_velocity", s.fluid_velocity);
  read_choice(r, "coupling.fluid_force", s.fluid_force);
  read_name(r, "coupling.momentum", s.momentum, momentum_form_names());
  r.retired("coupling.pressure_gradient_force",
            "replaced by coupling.momentum (\"cfdem_A\": -V_p grad P and the viscous force on the particles; "
            "docs/scenes.md)");
  read_choice(r, "coupling.plasma_velocity", s.plasma_velocity);
  // A fluid step of several intervals averages feedback computed in one published state (serial
  // scheme: the state of the block's start) over intervals of one length.
  r.check(f.solve_every == 1 || s.coupling_scheme == CouplingScheme::serial, "fluid.solve_every",
          "above 1 needs coupling.scheme = \"serial\" (the parallel scheme's particles see two states in a block)");
  r.check(f.solve_every == 1 || !s.time.adaptive_interval(), "fluid.solve_every",
          "above 1 needs fixed coupling intervals (time.coupling_relaxation_times = 0)");
  // A developed feeder (model/feeder_develop.h) is an open vessel's, from a run whose last step,
  // known in advance, writes the checkpoint its cells are taken from.
  r.check(!(s.vessel.feeder_develop > 0) || !known_ends(s.vessel) || fed_by_feeder(s.vessel),
          "vessel.feeder_develop_s", "above 0 needs a feeder (vessel.ends = \"open\", vessel.inlet = \"feeder\")");
  r.check(!(s.vessel.feeder_develop > 0) || !s.time.adaptive_interval(), "vessel.feeder_develop_s",
          "above 0 needs fixed coupling intervals (time.coupling_relaxation_times = 0)");
  r.check(s.fluid_force == FluidForceUpdate::per_dem_step || s.implicit_drag != ImplicitDrag::co_relaxed, "coupling.fluid_force",
          "a held fluid force cannot be co-relaxed with the plasma (coupling.implicit_drag = \"co_relaxed\")");

  if (r.problems().empty()) check_geometry_and_work(r, s, narrowest_end);
  if (check == SceneCheck::placement && r.problems().empty()) check_placement(r, s);
  r.report_unknown();
  catalogue = std::move(r.catalogue());
  if (!r.problems().empty()) throw SceneError(path, r.problems());
  return s;
}

// A regular n-gon tangent to the circle of radius R has its corners at R / cos(π/n) and area over
// perimeter R/2; one with its corners on the circle has area over perimeter (R/2) cos(π/n).
std::optional<std::string> fluid_ranks_problem(const MeshSpec& mesh, int ranks) {
  if (ranks <= mesh.axial_cells) return std::nullopt;
  return fmt::format(
      "the fluid is decomposed along the vessel axis: {} ranks need at least as many axial cells (mesh.axial_cells = "
      "{})",
      ranks, mesh.axial_cells);
}

double MeshSpec::wall_corner_radius() const {
  return wall_polygon == WallPolygon::inscribed ? 1.0 : 1.0 / std::cos(units::pi / wall_sides());
}

double MeshSpec::hydraulic_diameter_ratio() const {
  return wall_polygon == WallPolygon::inscribed ? std::cos(units::pi / wall_sides()) : 1.0;
}

namespace {
template <class E>
NumericalReading reading_of(E value, const std::string& prefix = "") {
  const Choice<E>& c = choice_of(value);
  return {prefix + std::string(ChoiceTable<E>::key), std::string(c.name), std::string(c.reading)};
}
}  // namespace

std::vector<NumericalReading> numerical_readings(const Scene& s) {
  const std::string every =
      fmt::format("ours: closures every {} DEM step(s), drag on the current velocity every step (exponential)",
                  s.time.closure_every_dem_steps);
  std::vector<NumericalReading> r = {
      reading_of(s.fluid_velocity),
      {"coupling.fluid_force", name_of(s.fluid_force),
       s.fluid_force == FluidForceUpdate::per_dem_step ? every : std::string(choice_of(s.fluid_force).reading)},
      reading_of(s.implicit_drag),
      {"coupling.momentum", s.momentum, momentum_form(s.momentum).reading},
  };
  if (shares_over_kernel(s.solid_fraction))  // the others are the paper's unresolved sharing
    r.push_back({"coupling.solid_fraction", s.solid_fraction,
                 fmt::format("Capecelatro & Desjardins (2013)'s Gaussian filter, {:g} x the particle's diameter at half "
                             "maximum, cut at 3 sigma, read over the same cells",
                             s.kernel_width_diameters)});
  if (!surface_vessel(s.vessel))  // the O-grid's wall; a surface vessel's is snappyHexMesh's
    r.push_back(reading_of(s.mesh.wall_polygon));
  if (suspension_viscosity(s.plasma.suspension_viscosity).adds_stress())  // beyond the paper: named when chosen
    r.push_back({"plasma.suspension_viscosity", s.plasma.suspension_viscosity,
                 suspension_viscosity(s.plasma.suspension_viscosity).reading});
  r.push_back(reading_of(s.plasma_velocity));
  if (s.load_balance != LoadBalance::none) r.push_back(reading_of(s.load_balance));
  if (s.platelet.present)
    r.push_back(reading_of(s.platelet.orientation_integrator, "platelet."));
  return r;
}

bool load_balance_after(const Scene& scene, long step) {
  return scene.load_balance != LoadBalance::none && step > 0 && step % scene.load_balance_every_steps == 0;
}

}  // namespace hemo
