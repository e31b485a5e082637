// SPDX-License-Identifier: GPL-3.0-or-later
// The closures a scene may name are exactly the ones the registry builds: scene validation
// (hemocommon, and through it `hemocosim check`) and the particle node's registry read one table.
#include "closures/closure.h"
#include "minimal_scene.h"
#include "run_command.h"

#include <scene.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

using namespace hemo::particles;

namespace {

ClosureParams platelet_params() {
  ClosureParams p;
  p.diameter = 2.66e-6;
  p.fluid_density = 1025;
  p.viscosity = 1.2e-3;
  p.aspect_ratio = 0.25;
  p.vessel_diameter = 100e-6;
  return p;
}

struct Slot {
  std::string key;  // the platelet's, which may take every closure (the RBC refuses "oblate")
  std::vector<std::string> registry;
  std::function<void(const std::string&)> make;  // throws for a name the registry lacks
};

std::vector<Slot> slots() {
  return {
      {"drag", drag_closure_names(), [](const std::string& n) { make_drag_closure(n, platelet_params()); }},
      {"lift", lift_closure_names(), [](const std::string& n) { make_lift_closure(n, platelet_params()); }},
      {"torque", torque_closure_names(), [](const std::string& n) { make_torque_closure(n, platelet_params()); }},
  };
}

std::string write_scene(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("hemocosim-closure-table-" + name + ".toml");
  std::ofstream(path) << text;
  return path.string();
}

std::string platelet_scene(const std::string& slot, const std::string& closure) {
  return std::string(hemo::test::kMinimalScene) + "\n[platelet]\n" + slot + " = \"" + closure + "\"\n";
}

// The problems load_scene finds in a scene (none when it loads).
std::vector<hemo::SceneProblem> problems_of(const std::string& path) {
  try {
    hemo::load_scene(path);
  } catch (const hemo::SceneError& e) {
    return e.problems();
  }
  return {};
}

// "... (known: a, b, c)" -> {a, b, c}
std::vector<std::string> known_list(const std::string& message) {
  const std::string open = "(known: ";
  const auto start = message.rfind(open);
  const auto end = message.rfind(')');
  if (start == std::string::npos || end == std::string::npos || end < start) return {};
  std::vector<std::string> names;
  std::string rest = message.substr(start + open.size(), end - start - open.size());
  for (std::size_t pos = 0;;) {
    const auto comma = rest.find(", ", pos);
    names.push_back(rest.substr(pos, comma - pos));
    if (comma == std::string::npos) break;
    pos = comma + 2;
  }
  return names;
}

}  // namespace

TEST(ClosureTable, SceneListsAreTheRegistrys) {
  EXPECT_EQ(hemo::known_drag_closures(), drag_closure_names());
  EXPECT_EQ(hemo::known_lift_closures(), lift_closure_names());
  EXPECT_EQ(hemo::known_torque_closures(), torque_closure_names());
}

TEST(ClosureTable, EveryRegisteredClosureIsBuiltAndAnswersToItsName) {
  for (const auto& slot : slots()) {
    ASSERT_FALSE(slot.registry.empty()) << slot.key;
    for (const auto& name : slot.registry) EXPECT_NO_THROW(slot.make(name)) << slot.key << " " << name;
    EXPECT_THROW(slot.make("no_such_closure"), std::invalid_argument) << slot.key;
  }
  // The name is the table's, handed over by the registry (the classes do not spell it).
  const auto sp = platelet_params();
  for (const auto& n : drag_closure_names()) EXPECT_EQ(make_drag_closure(n, sp)->name(), n);
  for (const auto& n : lift_closure_names()) {
    const auto c = make_lift_closure(n, sp);
    EXPECT_EQ(c == nullptr, n == "none") << n;
    if (c) {
      EXPECT_EQ(c->name(), n);
    }
  }
  for (const auto& n : torque_closure_names()) {
    const auto c = make_torque_closure(n, sp);
    EXPECT_EQ(c == nullptr, n == "none") << n;
    if (c) {
      EXPECT_EQ(c->name(), n);
    }
  }
}

// load_scene takes every name the registry has, and for any other lists exactly the registry's.
TEST(ClosureTable, SceneValidatorAcceptsExactlyTheRegistrysNames) {
  for (const auto& slot : slots()) {
    for (const auto& name : slot.registry) {
      const auto ps = problems_of(write_scene(slot.key + "-" + name, platelet_scene(slot.key, name)));
      EXPECT_TRUE(ps.empty()) << slot.key << " = " << name << ": " << (ps.empty() ? "" : ps[0].message);
    }
    const auto ps = problems_of(write_scene(slot.key + "-unknown", platelet_scene(slot.key, "no_such_closure")));
    ASSERT_EQ(ps.size(), 1u) << slot.key;
    EXPECT_EQ(ps[0].key, "platelet." + slot.key);
    EXPECT_NE(ps[0].message.find("no_such_closure"), std::string::npos) << ps[0].message;
    EXPECT_EQ(known_list(ps[0].message), slot.registry) << ps[0].message;
  }
}

// The same through the program: one error line naming the key and offering the registry's names.
TEST(ClosureTable, HemocosimCheckOffersTheRegistrysNames) {
  const std::string hemocosim = hemo::test::bin("hemocosim");
  ASSERT_TRUE(std::filesystem::exists(hemocosim)) << hemocosim;
  for (const auto& slot : slots()) {
    const auto path = write_scene(slot.key + "-check", platelet_scene(slot.key, "no_such_closure"));
    const auto r = hemo::test::run("timeout -s KILL 60 " + hemocosim + " check '" + path + "' 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    const std::string line = hemo::test::error_line(r.output);
    EXPECT_EQ(r.output.find('\n'), r.output.size() - 1) << "one line: " << r.output;
    EXPECT_NE(line.find("platelet." + slot.key), std::string::npos) << line;
    EXPECT_EQ(known_list(line), slot.registry) << line;
  }
}

// docs/design.md, "Extending hemocosim": `hemocosim check --keys` lists each closure key with
// exactly the registry's names (the RBC's rows too: its refusal of "oblate" is a rule beside them).
TEST(ClosureTable, CheckKeysListsTheRegistrysNames) {
  const std::string hemocosim = hemo::test::bin("hemocosim");
  ASSERT_TRUE(std::filesystem::exists(hemocosim)) << hemocosim;
  const auto r = hemo::test::run("timeout -s KILL 60 " + hemocosim + " check --keys 2>&1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // | `platelet.drag` | "oblate" | one of "oblate", "schiller_naumann", "stokes" |  ->  {oblate, ...}
  auto listed = [&](const std::string& key) {
    const auto row = r.output.find("| `" + key + "` |");
    if (row == std::string::npos) return std::vector<std::string>{};
    const auto line = r.output.substr(row, r.output.find('\n', row) - row);
    const auto start = line.find("one of ");
    if (start == std::string::npos) return std::vector<std::string>{};
    std::vector<std::string> names;
    for (auto q = line.find('"', start); q != std::string::npos && q < line.find_first_of(";|", start);
         q = line.find('"', line.find('"', q + 1) + 1)) {
      const auto end = line.find('"', q + 1);
      names.push_back(line.substr(q + 1, end - q - 1));
    }
    return names;
  };
  for (const auto& slot : slots())
    for (const std::string species : {"rbc", "platelet"})
      EXPECT_EQ(listed(species + "." + slot.key), slot.registry) << species << "." << slot.key << "\n" << r.output;
}
