// A generated corpus of malformed scenes (issue #21): every key with the wrong type, negative,
// zero, NaN, infinite, huge and out-of-range values; syntax errors; deep nesting; empty, binary,
// huge and special files; scenes whose particles cannot be placed. Each must be refused naming
// its key, one line per problem; a sample goes through `hemocosim check` itself: exit code 2, no
// crash, no hang.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_command.h"
#include "scene.h"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

using namespace hemo;

namespace {

using Tables = std::map<std::string, std::map<std::string, std::string>>;  // table -> key -> TOML literal

// A valid scene (the quick start's shape) that every variant starts from.
const Tables kBase = {
    {"run", {{"name", "\"corpus\""}, {"seed", "1"}}},
    {"vessel", {{"diameter_um", "50"}, {"length_um", "100"}}},
    {"mesh", {{"core_cells", "2"}, {"ring_cells", "2"}, {"axial_cells", "8"}}},
    {"driving", {{"wall_shear_rate_per_s", "799"}}},
    {"rbc", {{"hematocrit", "0.15"}}},
    {"platelet", {{"number_density_per_ul", "300000"}}},
    {"time", {{"coupling_interval_s", "2e-5"}, {"coupling_steps", "100"}}},
};

std::string text_of(const Tables& t) {
  std::string s;
  for (const auto& [table, keys] : t) {
    s += "[" + table + "]\n";
    for (const auto& [k, v] : keys) s += k + " = " + v + "\n";
  }
  return s;
}

// The base with `key` (dotted, table.name) set to a TOML literal.
std::string with(const std::string& key, const std::string& literal) {
  Tables t = kBase;
  const auto dot = key.find('.');
  const std::string table = key.substr(0, dot), name = key.substr(dot + 1);
  // The driving is one of two keys: giving the other one alone keeps the base's driving valid.
  if (table == "driving") t["driving"].clear();
  t[table][name] = literal;
  return text_of(t);
}

const std::string& scratch() {
  static const std::string dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("hemo-scene-corpus-" + std::to_string(getpid()));
    std::filesystem::create_directories(d);
    return d.string();
  }();
  return dir;
}

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = scratch() + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// The problems of a scene file; empty when it loads.
std::vector<SceneProblem> problems_of_file(const std::string& path, SceneCheck check = SceneCheck::values) {
  try {
    load_scene(path, check);
  } catch (const SceneError& e) {
    return e.problems();
  }
  return {};
}

const std::set<std::string> kIntegerKeys = {"run.seed",
                                            "run.drop_every",
                                            "run.max_restarts",
                                            "run.fluid_ranks",
                                            "run.particle_ranks",
                                            "mesh.core_cells",
                                            "mesh.ring_cells",
                                            "mesh.axial_cells",
                                            "time.coupling_steps",
                                            "time.dem_substeps",
                                            "time.closure_every_dem_steps",
                                            "output.every_steps",
                                            "output.checkpoint_every_steps",
                                            "fluid.min_correctors",
                                            "fluid.max_correctors",
                                            "fluid.non_orthogonal_correctors",
                                            "run.bus_ttl"};
// -1 is "chosen for you" (run.bus_ttl: 0 on one host, 1 across hosts); below it is refused.
const std::set<std::string> kMinusOneIsAuto = {"run.bus_ttl"};
// Numbers that may be negative; numbers and integers that may be zero.
const std::set<std::string> kMayBeNegative = {"gravity.x_m_s2", "gravity.y_m_s2", "gravity.z_m_s2",
                                              "contact.cell_poisson_ratio", "contact.wall_poisson_ratio"};
const std::set<std::string> kMayBeZero = {"run.seed",
                                          "run.drop_every",
                                          "run.max_restarts",
                                          "driving.pressure_drop_Pa",
                                          "driving.wall_shear_rate_per_s",
                                          "run.bus_ttl",
                                          "hosts.relay_port",  // 0: a free port, chosen by the kernel
                                          "rbc.hematocrit",
                                          "vessel.stenosis_area_reduction",  // 0: no constriction
                                          "vessel.stenosis_length_um",       // taken by "stenosis" only
                                          "vessel.daughter_1_diameter_um",   // 0: Murray's law
                                          "vessel.daughter_2_diameter_um",
                                          "vessel.daughter_length_um",  // 0: the parent's length
                                          "vessel.feeder_develop_s",    // 0: the feeder is not developed first
                                          "mesh.surface_cell_size_um",  // 0: the vessel's diameter / 12
                                          "rbc.mass_scaling",
                                          "platelet.number_density_per_ul",
                                          "platelet.mass_scaling",
                                          "contact.cell_poisson_ratio",
                                          "contact.wall_poisson_ratio",
                                          "contact.friction",
                                          "time.dem_substeps",
                                          "time.dem_step_max_relaxation_times",
                                          "time.coupling_relaxation_times",
                                          "output.checkpoint_every_steps",
                                          "gravity.x_m_s2",
                                          "gravity.y_m_s2",
                                          "gravity.z_m_s2",
                                          "fluid.pressure_relative_tolerance",
                                          "fluid.velocity_relative_tolerance",
                                          "fluid.non_orthogonal_correctors"};

enum class Kind { string, boolean, integer, number };
Kind kind_of(const SceneKey& k) {
  if (kIntegerKeys.count(k.key)) return Kind::integer;
  if (!k.default_value.empty() && k.default_value[0] == '"') return Kind::string;
  if (k.default_value == "true" || k.default_value == "false") return Kind::boolean;
  return Kind::number;
}

struct Case {
  std::string name;  // what the variant is
  std::string key;   // the key that must be named ("(file)", "(syntax)" for the file as a whole)
  std::string text;  // the scene
};

std::vector<Case> key_cases() {
  std::vector<Case> cases;
  for (const auto& k : scene_keys()) {
    std::vector<std::string> bad;
    switch (kind_of(k)) {
      case Kind::string:
        bad = {"12", "true", "[\"a\"]", "{ a = 1 }", "1979-05-27"};
        break;
      case Kind::boolean:
        bad = {"1", "0", "\"true\"", "1.0", "[true]"};
        break;
      case Kind::integer:
        bad = {"\"3\"",
               "1.5",
               "true",
               "4294967299",
               "-4294967293",
               "9223372036854775807",
               "-9223372036854775808",
               "nan",
               "inf",
               kMinusOneIsAuto.count(k.key) ? "-2" : "-1"};
        if (!kMayBeZero.count(k.key)) bad.push_back("0");
        break;
      case Kind::number:
        bad = {"\"1\"", "true", "nan", "-nan", "inf", "-inf", "1e300", "-1e300", "[1.0]"};
        if (!kMayBeNegative.count(k.key)) bad.push_back("-1");
        if (!kMayBeZero.count(k.key)) bad.push_back("0");
        break;
    }
    for (const auto& v : bad) cases.push_back({k.key + " = " + v, k.key, with(k.key, v)});
  }
  return cases;
}

bool names(const std::vector<SceneProblem>& ps, const std::string& key) {
  for (const auto& p : ps)
    if (p.key == key) return true;
  return false;
}

}  // namespace

TEST(SceneCorpus, TheBaseSceneIsValid) {
  EXPECT_TRUE(problems_of_file(write_file("base.toml", text_of(kBase))).empty());
  EXPECT_TRUE(problems_of_file(write_file("base.toml", text_of(kBase)), SceneCheck::placement).empty());
}

TEST(SceneCorpus, EveryKeyWithEveryKindOfBadValueIsRefusedNamingIt) {
  const auto cases = key_cases();
  std::printf("%zu malformed scenes, %zu keys\n", cases.size(), scene_keys().size());
  ASSERT_GE(cases.size(), 400u);
  int i = 0;
  for (const auto& c : cases) {
    const auto ps = problems_of_file(write_file("key-" + std::to_string(i++) + ".toml", c.text));
    ASSERT_FALSE(ps.empty()) << c.name << " was accepted";
    EXPECT_TRUE(names(ps, c.key)) << c.name << ": " << ps[0].str("scene");
    for (const auto& p : ps) {
      const auto line = p.str("scene");
      EXPECT_EQ(line.find('\n'), std::string::npos) << c.name;
      if (p.key == c.key) {
        EXPECT_GT(p.line, 0) << c.name << ": " << line;  // the key is in the file: its line
      }
      if (p.key == c.key && c.key != "run.name") {
        EXPECT_NE(line.find(" = "), std::string::npos) << line;  // its value
      }
    }
  }
}

// The issue's examples, with the cause each must name.
TEST(SceneCorpus, TheIssuesExamplesNameTheRightCause) {
  struct Example {
    std::string key, literal, cause;
  };
  for (const auto& e : std::vector<Example>{
           {"mesh.axial_cells", "4294967299", "out of range"},
           {"run.max_restarts", "-4294967293", "out of range"},
           {"run.drop_every", "9223372036854775807", "out of range"},
           {"vessel.diameter_um", "1e300", "must be in"},
           {"vessel.length_um", "1e300", "must be at most"},
           {"coupling.two_way", "1", "expected true or false"},
           {"vessel.diameter_um", "4", "must be in"},
           {"rbc.diameter_um", "60", "does not fit a vessel"},
           {"mesh.axial_cells", "100", "larger than the fluid cells"},
           {"time.coupling_interval_s", "1", "DEM substeps per coupling interval"},
       }) {
    const auto ps = problems_of_file(write_file("example.toml", with(e.key, e.literal)));
    ASSERT_EQ(ps.size(), 1u) << e.key << " = " << e.literal;
    EXPECT_EQ(ps[0].key, e.key) << ps[0].str("scene");
    EXPECT_NE(ps[0].message.find(e.cause), std::string::npos) << ps[0].str("scene");
    EXPECT_NE(ps[0].str("scene").find(e.key + " = "), std::string::npos) << ps[0].str("scene");  // with its value
    EXPECT_EQ(ps[0].message.find("negative"), std::string::npos) << ps[0].str("scene");
  }
}

// Scenes valid key by key whose particles cannot be placed (issue #21: "placement feasible at
// the hematocrit"). The base's vessel is the quick start's (50 x 100 um); random addition and the
// close-packed lattice fill it to a sphere volume fraction of ~0.54.
std::vector<Case> placement_cases() {
  return {{"Ht 0.58 in a 50-um vessel", "rbc.hematocrit", with("rbc.hematocrit", "0.58")},
          {"platelets at 4e7 per ul beside Ht 0.15", "platelet.number_density_per_ul",
           with("platelet.number_density_per_ul", "40000000")}};
}

// The line of `table.name` in a text made by text_of.
int line_in(const std::string& text, const std::string& key) {
  const auto dot = key.find('.');
  const auto table = text.find("[" + key.substr(0, dot) + "]\n");
  const auto at = text.find("\n" + key.substr(dot + 1) + " = ", table);
  if (table == std::string::npos || at == std::string::npos) return 0;
  return 2 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

// load_scene, which every node calls, takes them (the particle node places its particles itself,
// once); SceneCheck::placement, which `hemocosim check` and `run` use, refuses each in one problem
// naming the species' key, its line and its value.
TEST(SceneCorpus, ParticlesThatCannotBePlacedAreRefusedNamingTheSpeciesKey) {
  int i = 0;
  for (const auto& c : placement_cases()) {
    const std::string path = write_file("placement-" + std::to_string(i++) + ".toml", c.text);
    EXPECT_TRUE(problems_of_file(path).empty()) << c.name;
    const auto ps = problems_of_file(path, SceneCheck::placement);
    ASSERT_EQ(ps.size(), 1u) << c.name;
    EXPECT_EQ(ps[0].key, c.key) << ps[0].str("scene");
    EXPECT_GT(ps[0].line, 0);
    EXPECT_EQ(ps[0].line, line_in(c.text, c.key)) << ps[0].str("scene");
    EXPECT_EQ(ps[0].message.rfind("cannot be placed: ", 0), 0u) << ps[0].str("scene");
    EXPECT_NE(ps[0].message.find("volume fraction"), std::string::npos) << ps[0].str("scene");
    EXPECT_NE(ps[0].str("scene").find(c.key + " = "), std::string::npos) << ps[0].str("scene");
    EXPECT_EQ(ps[0].str("scene").find('\n'), std::string::npos);
  }
}

// The same through the program: `hemocosim check` exits 2 with one line naming the file, the
// line, the key and its value; `hemocosim run` refuses it alike before it makes a run directory
// or starts a node.
TEST(SceneCorpus, HemocosimCheckAndRunRefuseHematocrit058InA50umVessel) {
  const Case c = placement_cases().front();
  const std::string path = write_file("program-placement.toml", c.text);
  const std::string expected = "hemocosim: error: " + path + ":" + std::to_string(line_in(c.text, c.key)) +
                               ": rbc.hematocrit = 0.58: cannot be placed: ";
  const auto check = test::run("timeout -s KILL 60 " + test::bin("hemocosim") + " check '" + path + "' 2>&1");
  EXPECT_EQ(check.exit_code, 2) << check.output;
  EXPECT_EQ(check.output.rfind(expected, 0), 0u) << check.output;
  EXPECT_EQ(std::count(check.output.begin(), check.output.end(), '\n'), 1) << check.output;
  const std::string out = scratch() + "/refused-run";
  const auto run =
      test::run("timeout -s KILL 60 " + test::bin("hemocosim") + " run '" + path + "' --out '" + out + "' 2>&1");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_EQ(run.output.rfind(expected, 0), 0u) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out)) << "the refused run made its directory";
}

TEST(SceneCorpus, ARunOfTooManyParticleStepsIsRefusedWithTheFigure) {
  Tables t = kBase;
  t["time"]["coupling_steps"] = "900000000";
  t["time"]["dem_substeps"] = "100000";
  const auto ps = problems_of_file(write_file("work.toml", text_of(t)));
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].key, "time.coupling_steps");
  EXPECT_NE(ps[0].message.find("particle-steps"), std::string::npos) << ps[0].str("scene");
  EXPECT_NE(ps[0].message.find("e+16"), std::string::npos) << ps[0].str("scene");  // ~386 x 1e5 x 9e8
}

std::vector<Case> file_cases() {
  const std::string base = text_of(kBase);
  std::vector<Case> cases = {
      {"empty", "vessel.diameter_um", ""},
      {"only a comment", "vessel.diameter_um", "# nothing\n"},
      {"unclosed table", "(syntax)", "[vessel\ndiameter_um = 1\n"},
      {"no value", "(syntax)", base + "[x]\ny =\n"},
      {"unclosed string", "(syntax)", base + "[z]\nq = \"abc\n"},
      {"duplicate key", "(syntax)", base + "[vessel]\ndiameter_um = 60\n"},
      {"bare word", "(syntax)", base + "hello\n"},
      {"bad escape", "(syntax)", base + "[w]\nq = \"\\x\"\n"},
      {"invalid utf-8", "(syntax)", base + "[w]\nq = \"\xff\xfe\"\n"},
      {"unknown table", "bogus", base + "[bogus]\nx = 1\n"},
      {"unknown key", "vessel.width_um", with("vessel.width_um", "3")},
      {"a value for a table", "vessel",
       "vessel = 3\n" +
           [] {
             Tables t = kBase;
             t.erase("vessel");
             return text_of(t);
           }()},
      {"binary", "(file)",
       [] {
         // Its length from the array: the 18 bytes with their NULs (a count of 20 read past it).
         static const char elf[] =
             "\x7f"
             "ELF\x02\x01\x01\0\0\0\0garbage";
         return std::string(elf, sizeof elf - 1);
       }()},
      {"huge", "(file)", std::string(kMaxSceneBytes + 10, '#')},
      {"dotted 50,000 levels", "(file)",
       [] {
         std::string k = "a";
         for (int i = 0; i < 50000; ++i) k += ".a";
         return k + " = 1\n";
       }()},
      {"dotted 70 levels", "(file)",
       [] {
         std::string k = "a";
         for (int i = 0; i < 70; ++i) k += ".a";
         return k + " = 1\n";
       }()},
      {"header 40 + key 40 levels", "(file)",
       [] {
         std::string h = "[a", k = "b";
         for (int i = 0; i < 40; ++i) h += ".a", k += ".b";
         return h + "]\n" + k + " = 1\n";
       }()},
      {"nested arrays", "(file)", std::string(5000, '[') + std::string(5000, ']')},
      {"x = nested arrays", "(file)", "x = " + std::string(100, '[') + std::string(100, ']') + "\n"},
      {"nested inline tables", "(file)",
       [] {
         std::string s = "x = ";
         for (int i = 0; i < 100; ++i) s += "{ a = ";
         s += "1";
         for (int i = 0; i < 100; ++i) s += " }";
         return s + "\n";
       }()},
  };
  return cases;
}

TEST(SceneCorpus, MalformedAndHostileFilesAreRefusedInOneLine) {
  int i = 0;
  for (const auto& c : file_cases()) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto ps = problems_of_file(write_file("file-" + std::to_string(i++) + ".toml", c.text));
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(2)) << c.name;
    ASSERT_FALSE(ps.empty()) << c.name << " was accepted";
    EXPECT_TRUE(names(ps, c.key)) << c.name << ": " << ps[0].str("scene");
    for (const auto& p : ps) EXPECT_EQ(p.str("scene").find('\n'), std::string::npos) << c.name;
  }
}

TEST(SceneCorpus, SpecialFilesAreRefusedBeforeTheyAreRead) {
  const std::string fifo = scratch() + "/fifo.toml";
  ::unlink(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string link = scratch() + "/link-to-fifo.toml";
  ::unlink(link.c_str());
  ASSERT_EQ(::symlink(fifo.c_str(), link.c_str()), 0);
  struct Special {
    std::string path, says;
  };
  for (const auto& s : std::vector<Special>{{fifo, "a FIFO"},
                                            {link, "a FIFO"},
                                            {scratch(), "a directory"},
                                            {"/dev/null", "a character device"},
                                            {"/dev/zero", "a character device"},
                                            {scratch() + "/does-not-exist.toml", "cannot open"}}) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto ps = problems_of_file(s.path);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(2)) << s.path;  // a FIFO does not hang it
    ASSERT_EQ(ps.size(), 1u) << s.path;
    EXPECT_EQ(ps[0].key, "(file)");
    EXPECT_NE(ps[0].message.find(s.says), std::string::npos) << ps[0].str(s.path);
  }
}

// The whole corpus through the program, in shards run as separate tests: exit code 2, every line
// of its error output one "hemocosim: error:" line, the key named, within the time limit (a hang
// or a crash fails). Shard 0 also takes the malformed files and a FIFO.
constexpr int kProgramShards = 8;

class SceneCorpusProgram : public ::testing::TestWithParam<int> {};

TEST_P(SceneCorpusProgram, HemocosimCheckRefusesEveryCorpusSceneWithExitCode2) {
  const int shard = GetParam();
  const std::string hemocosim = test::bin("hemocosim");
  ASSERT_TRUE(std::filesystem::exists(hemocosim)) << hemocosim;
  std::vector<std::pair<std::string, std::string>> cases;  // path, key
  const auto keys = key_cases();
  for (std::size_t i = shard; i < keys.size(); i += kProgramShards)
    cases.push_back({write_file("program-" + std::to_string(i) + ".toml", keys[i].text), keys[i].key});
  if (shard == 0) {
    int i = 0;
    for (const auto& c : file_cases())
      cases.push_back({write_file("program-file-" + std::to_string(i++) + ".toml", c.text), c.key});
    const std::string fifo = scratch() + "/fifo2.toml";
    ::unlink(fifo.c_str());
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    cases.push_back({fifo, "(file)"});
    for (const auto& c : placement_cases())
      cases.push_back({write_file("program-file-" + std::to_string(i++) + ".toml", c.text), c.key});
  }
  ASSERT_GE(keys.size(), 400u) << "the corpus has shrunk";
  for (const auto& [path, key] : cases) {
    const auto r = test::run("timeout -s KILL 20 " + hemocosim + " check '" + path + "' 2>&1");
    EXPECT_EQ(r.exit_code, 2) << path << "\n" << r.output.substr(0, 500);
    std::size_t start = 0;
    bool named = false;
    while (start < r.output.size()) {
      const auto end = r.output.find('\n', start);
      const std::string line = r.output.substr(start, end - start);
      EXPECT_EQ(line.rfind("hemocosim: error: ", 0), 0u) << path << ": " << line.substr(0, 300);
      named |= line.find(": " + key) != std::string::npos;
      start = end == std::string::npos ? r.output.size() : end + 1;
    }
    EXPECT_TRUE(named) << path << " does not name " << key << ":\n" << r.output.substr(0, 500);
  }
}

INSTANTIATE_TEST_SUITE_P(Shards, SceneCorpusProgram, ::testing::Range(0, kProgramShards));
