// docs/design.md, "Extending hemocosim": the recipes for a message, a vessel shape and a CLI
// command stay true, and the closure recipe's "no CMake edit". (The rest of the closure recipe's check is
// tests/particles/test_closure_table.cpp, the observable's tests/studies/test_observables.cpp, the
// scene keys' test_scene.cpp.)
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bus.h"
#include "geometry.h"
#include "minimal_scene.h"
#include "run_command.h"
#include "scene.h"

#include <cmath>
#include <regex>

namespace fs = std::filesystem;

namespace {

const fs::path kSource = HEMO_SOURCE_DIR;

std::string read_text(const fs::path& path) { return hemo::test::file_text(path.string()); }

// The text of a markdown section, from its heading to the next heading of the same or a higher level.
std::string section(const std::string& doc, const std::string& heading) {
  const auto start = doc.find("\n" + heading + "\n");
  if (start == std::string::npos) return {};
  const std::string level = heading.substr(0, heading.find(' ') + 1);
  auto end = start + heading.size() + 1;
  for (;;) {
    end = doc.find("\n#", end + 1);
    if (end == std::string::npos) break;
    const auto hashes = doc.find_first_not_of('#', end + 1) - (end + 1);
    if (hashes <= level.size() - 1) break;
  }
  return doc.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

// The backticked first and second cells of a markdown table's rows: | `a` | `B` | ...
std::vector<std::pair<std::string, std::string>> table_rows(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> rows;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("| `", 0) != 0) continue;
    auto cell = [&](std::size_t from) {
      const auto bar = line.find('|', from);
      const auto next = line.find('|', bar + 1);
      std::string c = line.substr(bar + 1, next - bar - 1);
      c.erase(0, c.find_first_not_of(' '));
      c.erase(c.find_last_not_of(' ') + 1);
      return std::pair{c.size() > 2 && c.front() == '`' && c.back() == '`' ? c.substr(1, c.size() - 2) : "", next};
    };
    const auto [first, after] = cell(0);
    rows.push_back({first, cell(after).first});
  }
  return rows;
}

std::vector<std::string> lcm_types() {
  std::vector<std::string> types;
  for (const auto& e : fs::directory_iterator(kSource / "messages"))
    if (e.path().extension() == ".lcm") types.push_back(e.path().stem().string());
  std::sort(types.begin(), types.end());
  return types;
}

std::string messages_section() { return section(read_text(kSource / "docs" / "design.md"), "## Messages"); }

}  // namespace

// A message, steps 1 and 4: messages/*.lcm is the design's table of messages, type for type.
TEST(DesignRecipes, TheMessageTableListsEveryLcmType) {
  const auto rows = table_rows(messages_section());
  std::vector<std::string> documented;
  for (const auto& [type, kind] : rows) documented.push_back(type);
  std::sort(documented.begin(), documented.end());
  ASSERT_GE(lcm_types().size(), 10u);
  EXPECT_EQ(documented, lcm_types()) << "docs/design.md, \"Messages\": one row per messages/*.lcm";
}

// Step 1: in package hemo, the envelope first (the bus reads it from its fixed place).
TEST(DesignRecipes, EveryMessageCarriesTheEnvelopeFirst) {
  for (const auto& type : lcm_types()) {
    const std::string text = read_text(kSource / "messages" / (type + ".lcm"));
    EXPECT_NE(text.find("package hemo;"), std::string::npos) << type;
    if (type == "envelope_t") continue;
    const auto open = text.find('{', text.find("struct " + type));
    ASSERT_NE(open, std::string::npos) << type;
    std::istringstream body(text.substr(open + 1));
    std::string first;
    for (std::string line; std::getline(body, line);) {
      line = line.substr(0, line.find("//"));
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      first = line;
      break;
    }
    std::istringstream words(first);
    std::string field_type, name;
    words >> field_type >> name;
    EXPECT_EQ(field_type + " " + name, "envelope_t envelope;") << type;
  }
}

// Step 1: no CMake edit for a new message.
TEST(DesignRecipes, MessagesAreGlobbed) {
  const std::string cmake = read_text(kSource / "messages" / "CMakeLists.txt");
  EXPECT_NE(cmake.find("file(GLOB HEMO_LCM_TYPES CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.lcm)"),
            std::string::npos);
}

// A closure: no CMake edit either. Its sources are globbed, and so are the headers whose
// HEMO_CLOSURE lines closure_table.cmake makes into the closure table; an edited header re-runs
// the generator (CMake's own dependency).
TEST(DesignRecipes, ClosuresAreGlobbed) {
  const std::string top = read_text(kSource / "CMakeLists.txt");
  EXPECT_NE(
      top.find("file(GLOB HEMO_CLOSURE_HEADERS CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/particle-node/closures/*.h)"),
      std::string::npos);
  EXPECT_NE(top.find("set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${HEMO_CLOSURE_HEADERS})"),
            std::string::npos);
  EXPECT_NE(top.find("hemo_closure_table(${CMAKE_BINARY_DIR}/generated/closures ${HEMO_CLOSURE_HEADERS})"),
            std::string::npos);
  const std::string node = read_text(kSource / "particle-node" / "CMakeLists.txt");
  EXPECT_NE(node.find("file(GLOB HEMO_CLOSURE_SOURCES CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/closures/*.cpp)"),
            std::string::npos);
}

// Step 2: the table's channel kinds are the bus's, each heard by some process (CONTROL by the
// coordinator's control desk on its own bus).
TEST(DesignRecipes, TheTablesChannelKindsAreTheBuses) {
  std::set<std::string> documented;
  for (const auto& [type, kind] : table_rows(messages_section()))
    if (!kind.empty()) documented.insert(kind);
  const auto all = hemo::channel::all();
  EXPECT_EQ(documented, std::set<std::string>(all.begin(), all.end()));
  std::set<std::string> heard;
  for (const auto& list :
       {hemo::channel::heard_by_coordinator(), hemo::channel::heard_by_fluid(), hemo::channel::heard_by_particles()})
    heard.insert(list.begin(), list.end());
  for (const auto& kind : all) {
    if (kind != hemo::channel::control) {
      EXPECT_TRUE(heard.count(kind)) << kind << " is heard by no process";
    }
  }
}

// A CLI command, step 4: every subcommand `hemocosim --help` lists is in README.md's "Using it".
TEST(DesignRecipes, EveryCommandIsListedInTheReadme) {
  const std::string hemocosim = hemo::test::bin("hemocosim");
  ASSERT_TRUE(fs::exists(hemocosim)) << hemocosim;
  const auto r = hemo::test::run("timeout -s KILL 60 " + hemocosim + " --help 2>&1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto list = r.output.find("Subcommands:\n");
  ASSERT_NE(list, std::string::npos) << r.output;
  const std::string using_it = section(read_text(kSource / "README.md"), "## Using it");
  ASSERT_FALSE(using_it.empty());
  std::istringstream in(r.output.substr(list + 13));
  int commands = 0;
  for (std::string line; std::getline(in, line);) {
    std::istringstream words(line);
    std::string name;
    if (!(words >> name)) continue;
    ++commands;
    EXPECT_NE(using_it.find("hemocosim " + name + " "), std::string::npos)
        << "hemocosim " << name << " is not in README.md's \"Using it\"";
  }
  EXPECT_GE(commands, 10);
}

namespace {

std::string shape_recipe() { return section(read_text(kSource / "docs" / "design.md"), "### A new vessel shape"); }

// Step 1 of the shape recipe: the text from "1." to "2.".
std::string shape_step_one() {
  const std::string r = shape_recipe();
  const auto one = r.find("\n1. "), two = r.find("\n2. ");
  return one == std::string::npos || two == std::string::npos ? "" : r.substr(one, two - one);
}

// VesselGeometry's virtual members in model/geometry.h: name -> pure.
std::map<std::string, bool> geometry_virtuals() {
  const std::string h = read_text(kSource / "model" / "geometry.h");
  const auto begin = h.find("class VesselGeometry"), end = h.find("\n};", begin);
  std::map<std::string, bool> out;
  const std::regex member(R"(virtual [^(]*?(\w+)\(.*\)\s*const\s*(= 0)?)");
  const std::string body = h.substr(begin, end - begin);
  for (std::sregex_iterator m(body.begin(), body.end(), member), e; m != e; ++m) out[(*m)[1]] = (*m)[2].matched;
  // And VesselWall's, which VesselGeometry answers from R(z) (a shape may override them too).
  const std::regex answered(R"((\w+)\([^()]*\)\s*const\s*override)");
  for (std::sregex_iterator m(body.begin(), body.end(), answered), e; m != e; ++m) out[(*m)[1]] = false;
  return out;
}

// Every registered shape, as a scene with its example builds it (d = 100 um, l = 600 um).
struct BuiltShape {
  std::string name, scene_path;
  std::unique_ptr<hemo::VesselGeometry> geometry;
};
std::vector<BuiltShape> built_shapes() {
  std::vector<BuiltShape> out;
  for (const auto& shape : hemo::vessel_shapes()) {
    // A surface vessel is no wall r = R(z): its own recipe ("Surface vessels") and tests
    // (tests/model/test_surface.cpp, tests/fluid/test_surface_mesh.cpp, test_fluid_surface.cpp).
    if (shape.surface()) continue;
    const std::string text = "[vessel]\ndiameter_um = 100\nlength_um = 600\nshape = \"" + shape.name + "\"\n" +
                             shape.example + "\n[driving]\nwall_shear_rate_per_s = 799\n";
    const std::string path = hemo::test::write_temp(text);
    const hemo::Scene scene = hemo::load_scene(path);
    out.push_back({shape.name, path, hemo::make_vessel_geometry(scene.vessel)});
  }
  return out;
}

}  // namespace

// A vessel shape, step 1: the members it names are VesselGeometry's, the ones it must answer
// its pure virtual ones, and every other virtual member is named as one to override or one that
// follows from R(z).
TEST(DesignRecipes, TheShapeRecipeNamesVesselGeometrysMembers) {
  const std::string step = shape_step_one();
  ASSERT_FALSE(step.empty()) << "docs/design.md has no \"### A new vessel shape\" with steps 1 and 2";
  const auto virtuals = geometry_virtuals();
  ASSERT_GE(virtuals.size(), 8u);
  const auto override_at = step.find("Override");
  ASSERT_NE(override_at, std::string::npos);
  for (const auto& [name, pure] : virtuals) {
    const auto at = step.find("`" + name + "`");
    EXPECT_NE(at, std::string::npos) << name << " is not in the recipe's step 1";
    if (pure) {
      EXPECT_LT(at, override_at) << name << " is pure virtual: the recipe must say it is to be answered";
    }
  }
  for (const char* name : {"wall_surface", "dem_wall_resolution", "axial"})
    EXPECT_NE(read_text(kSource / "model" / "geometry.h").find(std::string(name) + "("), std::string::npos) << name;
  const std::string recipe = shape_recipe();
  for (const char* place : {"vessel_shapes()", "read_vessel_shape", "model/geometry.cpp", "model/scene.cpp"})
    EXPECT_NE(recipe.find(place), std::string::npos) << place;
  EXPECT_NE(read_text(kSource / "model" / "scene.cpp").find("read_vessel_shape("), std::string::npos);
}

// What the recipe says follows for every registered shape, built from its example: periodic and
// continuous, its throat the narrowest radius, its volume the integral of pi R^2, its signed
// distance zero on the wall and of the right sign on either side, its DEM wall surface on
// r = R(z).
TEST(DesignRecipes, EveryRegisteredShapeIsAVesselWall) {
  const auto shapes = built_shapes();
  ASSERT_GE(shapes.size(), 2u);
  for (const auto& s : shapes) {
    const hemo::VesselGeometry& g = *s.geometry;
    const double R0 = g.nominal_radius(), L = g.length();
    EXPECT_NEAR(g.radius_at(0), g.radius_at(L), 1e-12 * R0) << s.name;
    constexpr int n = 20000;
    double slope = 0, narrowest = R0, volume = 0;
    for (int i = 0; i < n; ++i) slope = std::max(slope, std::abs(g.radius_slope(L * i / n)));
    for (int i = 0; i < n; ++i) {
      const double z = L * (i + 0.5) / n, R = g.radius_at(z);
      narrowest = std::min(narrowest, R);
      volume += 3.14159265358979323846 * R * R * L / n;
      ASSERT_LE(std::abs(g.radius_at(z + L / n) - R), 1.01 * slope * L / n + 1e-15 * R0) << s.name << " jumps at " << z;
      for (double theta : {0.0, 2.0}) {
        const hemo::VesselGeometry::Point on(R * std::cos(theta), R * std::sin(theta), z);
        ASSERT_NEAR(g.signed_distance(on), 0, 1e-12 * R0) << s.name << " at " << z;
        ASSERT_LT(g.signed_distance(on * 0.5 + hemo::VesselGeometry::Point(0, 0, z / 2)), 0) << s.name;
      }
      ASSERT_GT(g.signed_distance(hemo::VesselGeometry::Point(1.01 * R0, 0, z)), 0) << s.name;
    }
    EXPECT_LE(g.throat_radius(), narrowest * (1 + 1e-12)) << s.name;
    EXPECT_NEAR(g.throat_radius(), narrowest, 1e-6 * R0) << s.name;
    EXPECT_NEAR(g.volume() / volume, 1, 1e-6) << s.name;
    const auto res = hemo::dem_wall_resolution(g);
    for (const auto& t : hemo::wall_surface(g, res.around, res.along))
      for (const auto& v : t.vertex) ASSERT_NEAR(std::hypot(v.x(), v.y()), g.radius_at(v.z()), 1e-15 * R0) << s.name;
  }
}

// ... and `hemocosim check` offers every shape's name (--keys) and accepts its example.
TEST(DesignRecipes, HemocosimCheckOffersAndAcceptsEveryShape) {
  const std::string hemocosim = hemo::test::bin("hemocosim");
  const auto keys = hemo::test::run("timeout -s KILL 60 " + hemocosim + " check --keys 2>&1");
  ASSERT_EQ(keys.exit_code, 0) << keys.output;
  std::string row;
  std::istringstream in(keys.output);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("| `vessel.shape`", 0) == 0) row = line;
  ASSERT_FALSE(row.empty()) << keys.output;
  for (const auto& s : built_shapes()) {
    EXPECT_NE(row.find("\"" + s.name + "\""), std::string::npos) << s.name << " is not offered: " << row;
    const auto r = hemo::test::run("timeout -s KILL 60 " + hemocosim + " check " + s.scene_path + " 2>&1");
    EXPECT_EQ(r.exit_code, 0) << s.name << ": " << r.output;
    if (!s.geometry->uniform()) {
      EXPECT_NE(r.output.find("  shape       " + s.name + ":"), std::string::npos) << r.output;
    }
  }
}
