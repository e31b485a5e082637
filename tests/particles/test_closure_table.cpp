// SPDX-License-Identifier: GPL-3.0-or-later
// docs/design.md, "Extending hemocosim", a closure: the HEMO_CLOSURE lines of the closures' own
// headers are the closure table (particle-node/closures/closure_table.cmake generates it), and the
// closures a scene may name are exactly the ones the registry builds from it: scene validation
// (hemocommon, and through it `hemocosim check`) and the particle node's registry read one table.
#include "closures/closure.h"
#include "minimal_scene.h"
#include "run_command.h"

#include <scene.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

using namespace hemo::particles;
namespace fs = std::filesystem;

namespace {

const fs::path kClosures = fs::path(HEMO_SOURCE_DIR) / "particle-node" / "closures";
const fs::path kGenerator = kClosures / "closure_table.cmake";

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string trim(std::string s) {
  s.erase(0, s.find_first_not_of(" \t"));
  s.erase(s.find_last_not_of(" \t;") + 1);
  return s;
}

// One HEMO_CLOSURE(slot, "name", Class) line.
struct Registration {
  std::string slot, name, cls;
  std::string header;  // file name
};

// The registration lines of a text, read here without closure_table.cmake's regex (so that a
// line it would skip is still seen): every line that spells HEMO_CLOSURE( outside a // comment,
// cut at its commas.
std::vector<Registration> registrations_in(const std::string& text, const std::string& header) {
  std::vector<Registration> found;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    const auto at = line.find("HEMO_CLOSURE");
    if (at == std::string::npos) continue;
    const auto comment = line.find("//");
    if (comment != std::string::npos && comment < at) continue;
    const auto open = line.find_first_not_of(" \t", at + 12);
    if (open == std::string::npos || line[open] != '(') continue;  // #ifdef HEMO_CLOSURE
    const auto close = line.find(')', open);
    std::vector<std::string> args;
    std::istringstream parts(line.substr(open + 1, close == std::string::npos ? std::string::npos : close - open - 1));
    for (std::string part; std::getline(parts, part, ',');) args.push_back(trim(part));
    Registration r;
    r.header = header;
    if (args.size() > 0) r.slot = args[0];
    if (args.size() > 1)
      r.name = args[1].size() >= 2 && args[1].front() == '"' ? args[1].substr(1, args[1].size() - 2) : "?" + args[1];
    if (args.size() > 2) r.cls = args[2];
    found.push_back(r);
  }
  return found;
}

std::vector<Registration> registrations() {
  std::vector<Registration> all;
  for (const auto& e : fs::directory_iterator(kClosures))
    if (e.path().extension() == ".h")
      for (auto& r : registrations_in(read_text(e.path()), e.path().filename().string())) all.push_back(r);
  return all;
}

// The slot's names among the registrations, in the table's order (byte order).
std::vector<std::string> registered_names(const std::vector<Registration>& rs, const std::string& slot) {
  std::vector<std::string> names;
  for (const auto& r : rs)
    if (r.slot == slot) names.push_back(r.name);
  std::sort(names.begin(), names.end());
  return names;
}

// The closure recipe of docs/design.md, "Extending hemocosim".
std::string closure_recipe() {
  const std::string doc = read_text(fs::path(HEMO_SOURCE_DIR) / "docs" / "design.md");
  const auto start = doc.find("\n### A closure");
  if (start == std::string::npos) return {};
  return doc.substr(start, doc.find("\n### ", start + 1) - start);
}

// closure_table.cmake as a script on a folder of headers: its exit code and output, and what it
// wrote (closure_table.h, closure_headers.h).
struct Generated {
  hemo::test::CommandResult result;
  std::string table, headers;
};
Generated generate(const fs::path& closure_dir, const fs::path& out_dir) {
  Generated g;
  g.result = hemo::test::run(std::string(HEMO_CMAKE_COMMAND) + " -DCLOSURE_DIR='" + closure_dir.string() +
                             "' -DOUT_DIR='" + out_dir.string() + "' -P '" + kGenerator.string() + "' 2>&1");
  g.table = read_text(out_dir / "closure_table.h");
  g.headers = read_text(out_dir / "closure_headers.h");
  return g;
}

// A fresh folder under the temp dir, removed with its parent when the test ends.
struct Scratch {
  fs::path dir;
  explicit Scratch(const std::string& name) : dir(hemo::test::fresh_run_dir(name)) { fs::create_directories(dir); }
  ~Scratch() {
    std::error_code ignored;
    fs::remove_all(dir.parent_path(), ignored);
  }
};

// A fresh copy of closures/*.h, to add a header to.
struct CopyOfTheHeaders : Scratch {
  explicit CopyOfTheHeaders(const std::string& name) : Scratch(name) {
    for (const auto& e : fs::directory_iterator(kClosures))
      if (e.path().extension() == ".h") fs::copy_file(e.path(), dir / e.path().filename());
  }
};

// The X("name", Class) lines of one slot's list in a generated closure_table.h.
std::vector<std::string> table_lines(const std::string& table, const std::string& slot) {
  std::string upper = slot;
  std::transform(upper.begin(), upper.end(), upper.begin(), [](unsigned char c) { return std::toupper(c); });
  std::vector<std::string> lines;
  const auto start = table.find("#define HEMO_" + upper + "_CLOSURES(X)");
  if (start == std::string::npos) return lines;
  std::istringstream in(table.substr(start));
  std::string line;
  std::getline(in, line);
  while (line.size() && line.back() == '\\' && std::getline(in, line))
    lines.push_back(trim(line.substr(0, line.find(" \\"))));
  return lines;
}

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

// The table is the headers' registration lines: every one of them, nothing else, each slot's names
// in byte order; and each line names a class of its slot defined in the header that registers it
// (the table's "none" is closure.h's NoClosure: the slot left empty).
TEST(ClosureTable, TheRegistrationLinesInTheHeadersAreTheTable) {
  const auto rs = registrations();
  ASSERT_GE(rs.size(), 9u);
  const std::map<std::string, std::string> base = {
      {"drag", "DragClosure"}, {"lift", "LiftClosure"}, {"torque", "TorqueClosure"}};
  for (const auto& r : rs) {
    const std::string where = r.header + ": HEMO_CLOSURE(" + r.slot + ", \"" + r.name + "\", " + r.cls + ")";
    ASSERT_TRUE(base.count(r.slot)) << where;
    EXPECT_TRUE(std::regex_match(r.name, std::regex("[a-z0-9_]+"))) << where;
    const std::string text = read_text(kClosures / r.header);
    const std::string defined = r.cls == "NoClosure"
                                    ? "struct NoClosure \\{"
                                    : "class " + r.cls + "( final)? : public " + base.at(r.slot) + " \\{";
    EXPECT_TRUE(std::regex_search(text, std::regex(defined))) << where << ": no " << defined << " in the header";
  }
  for (const auto& slot : slots()) {
    const auto names = registered_names(rs, slot.key);
    EXPECT_EQ(std::adjacent_find(names.begin(), names.end()), names.end()) << slot.key << ": a name registered twice";
    EXPECT_EQ(slot.registry, names) << slot.key << ": the registry's names are not the headers' registration lines";
  }
  EXPECT_EQ(hemo::known_drag_closures(), registered_names(rs, "drag"));
  EXPECT_EQ(hemo::known_lift_closures(), registered_names(rs, "lift"));
  EXPECT_EQ(hemo::known_torque_closures(), registered_names(rs, "torque"));
}

// The table the build compiled is what closure_table.cmake makes of the headers today (the class
// of each name too, which the names alone do not show), and it spells every line of theirs.
TEST(ClosureTable, TheBuildsTableIsTheGeneratorsOnTheHeaders) {
  const Scratch scratch("closure-table-now");
  const fs::path& out = scratch.dir;
  const auto g = generate(kClosures, out);
  ASSERT_EQ(g.result.exit_code, 0) << g.result.output;
  EXPECT_EQ(g.table, read_text(fs::path(HEMO_CLOSURE_TABLE_DIR) / "closure_table.h"));
  EXPECT_EQ(g.headers, read_text(fs::path(HEMO_CLOSURE_TABLE_DIR) / "closure_headers.h"));
  for (const auto& r : registrations()) {
    const auto lines = table_lines(g.table, r.slot);
    EXPECT_NE(std::find(lines.begin(), lines.end(), "X(\"" + r.name + "\", " + r.cls + ")"), lines.end())
        << r.header << ": " << r.slot << " " << r.name << " " << r.cls << "\n"
        << g.table;
    EXPECT_NE(g.headers.find("#include \"closures/" + r.header + "\"\n"), std::string::npos) << g.headers;
  }
}

// The recipe's step 1 is all it takes: its registration block, in a new header beside the others,
// adds its line to its slot's list (in byte order) and the header to the registry's includes.
TEST(ClosureTable, TheRecipesRegistrationInANewHeaderIsAllItTakes) {
  const std::string recipe = closure_recipe();
  ASSERT_FALSE(recipe.empty()) << "docs/design.md has no \"### A closure\" recipe";
  const auto fence = recipe.find("```cpp\n");
  ASSERT_NE(fence, std::string::npos) << recipe;
  const auto end = recipe.find("```", fence + 7);
  std::string block;
  std::istringstream in(recipe.substr(fence + 7, end - fence - 7));
  for (std::string line; std::getline(in, line);) block += trim(line) + "\n";
  const auto mine = registrations_in(block, "my_law.h");
  ASSERT_EQ(mine.size(), 1u) << block;
  const auto& r = mine[0];
  ASSERT_NE(block.find("#ifdef HEMO_CLOSURE\n"), std::string::npos) << block;

  const CopyOfTheHeaders copy("closure-table-new");
  const fs::path& dir = copy.dir;
  std::ofstream(dir / "my_law.h") << "#pragma once\n\n" << block << "\nclass " << r.cls << ";\n";
  const auto g = generate(dir, dir / "out");
  ASSERT_EQ(g.result.exit_code, 0) << g.result.output;
  auto names = registered_names(registrations(), r.slot);
  names.push_back(r.name);
  std::sort(names.begin(), names.end());
  const auto lines = table_lines(g.table, r.slot);
  ASSERT_EQ(lines.size(), names.size()) << g.table;
  const auto at = std::find(names.begin(), names.end(), r.name) - names.begin();
  EXPECT_EQ(lines[at], "X(\"" + r.name + "\", " + r.cls + ")") << g.table;
  EXPECT_NE(g.headers.find("#include \"closures/my_law.h\"\n"), std::string::npos) << g.headers;
}

// What the generator refuses, naming the header: a line it cannot read, an unknown slot, a name
// registered twice in a slot.
TEST(ClosureTable, TheGeneratorRefusesABadRegistrationNamingItsHeader) {
  for (const std::string line :
       {"HEMO_CLOSURE(drag, my_law, MyLaw)", "HEMO_CLOSURE(drag, \"My-Law\", MyLaw)",
        "HEMO_CLOSURE(drag, \"my_law\", MyLaw)  // a comment", "HEMO_CLOSURE(adhesion, \"my_law\", MyLaw)",
        "HEMO_CLOSURE(drag, \"stokes\", MyLaw)"}) {
    const CopyOfTheHeaders copy("closure-table-bad");
    const fs::path& dir = copy.dir;
    std::ofstream(dir / "my_law.h") << "#pragma once\n#ifdef HEMO_CLOSURE\n" << line << "\n#endif\n";
    const auto g = generate(dir, dir / "out");
    EXPECT_NE(g.result.exit_code, 0) << line << "\n" << g.result.output;
    EXPECT_NE(g.result.output.find("my_law.h"), std::string::npos) << line << "\n" << g.result.output;
    EXPECT_FALSE(fs::exists(dir / "out" / "closure_table.h")) << line;
  }
}
