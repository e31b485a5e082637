// docs/design.md, "Extending hemocosim": the recipes for a message and a CLI command stay true,
// and the closure recipe's "no CMake edit". (The rest of the closure recipe's check is
// tests/particles/test_closure_table.cpp, the observable's tests/studies/test_observables.cpp, the
// scene keys' test_scene.cpp.)
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bus.h"
#include "run_command.h"

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
