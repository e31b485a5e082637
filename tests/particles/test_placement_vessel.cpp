// SPDX-License-Identifier: GPL-3.0-or-later
// `hemocosim check` and `run` place a scene's particles before any node starts
// (SceneCheck::placement, model/scene.cpp): in the scene's vessel, from z = 0, with the scene's
// seed. The particle node places them at step 0 in the vessel of its CellLocator on the built-in
// fluid node's mesh. These must be one vessel, bit for bit, so that the check's placement is the
// node's: what the check passes, the node places; what it refuses, the node cannot place, for the
// same cause.
#include "cell_locator.h"
#include "run_command.h"

#include <placement.h>
#include <scene.h>
#include <vessel_mesh.h>
#include <hemo/mesh_t.hpp>

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

using namespace hemo::particles;

namespace {

// The mesh the built-in fluid node sends for a scene (fluid-node/writeCase.H).
hemo::mesh_t fluid_node_mesh(const hemo::Scene& scene) {
  const auto poly = hemo::make_vessel_mesh(scene.vessel, scene.mesh);
  hemo::mesh_t message;
  hemo::fill_mesh_message(poly, hemo::compute_geometry(poly), scene.vessel, message);
  return message;
}

std::string scratch_file(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / ("hemo-placement-vessel-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

}  // namespace

TEST(PlacementInTheMesh, TheCheckPlacesInTheNodesVesselBitForBit) {
  const std::string dir = HEMO_SCENES_DIR;
  // The committed scenes, and the diameter study's largest vessel (d = 200 um).
  std::vector<std::string> scenes = {dir + "/quickstart.toml", dir + "/calibration.toml",
                                     dir + "/calibration-cfdem.toml", dir + "/bench/base.toml"};
  const std::string d200 =
      std::regex_replace(hemo::test::file_text(dir + "/calibration.toml"), std::regex("\ndiameter_um = 100\n"), "\ndiameter_um = 200\n");
  ASSERT_NE(d200.find("\ndiameter_um = 200\n"), std::string::npos);
  scenes.push_back(scratch_file("d200.toml", d200));
  for (const auto& path : scenes) {
    const hemo::Scene scene = hemo::load_scene(path, hemo::SceneCheck::placement);
    const CellLocator locator(fluid_node_mesh(scene));
    EXPECT_EQ(locator.radius(), scene.vessel.radius()) << path;
    EXPECT_EQ(locator.length(), scene.vessel.length) << path;
    EXPECT_EQ(locator.z0(), 0.0) << path;
    const auto requests = placement_requests(scene);
    const auto by_node = place_particles(locator.radius(), locator.length(), locator.z0(), requests, scene.run.seed);
    const auto by_check = place_particles(scene.vessel.radius(), scene.vessel.length, 0.0, requests, scene.run.seed);
    ASSERT_EQ(by_node.size(), by_check.size()) << path;
    ASSERT_EQ(static_cast<long>(by_node.size()), rbc_count(scene) + platelet_count(scene)) << path;
    for (std::size_t i = 0; i < by_node.size(); ++i) {
      ASSERT_EQ(by_node[i].position, by_check[i].position) << path << ", particle " << i;
      ASSERT_EQ(by_node[i].species, by_check[i].species) << path << ", particle " << i;
    }
  }
}

// Issue #21's example: Ht 0.58 in the quick start's 50-um vessel. The scene loader the nodes use
// takes it; the check refuses it naming rbc.hematocrit; the node's placement, in its own vessel,
// fails on the same species with the same message the check quotes.
TEST(PlacementInTheMesh, WhatTheCheckRefusesTheNodeCannotPlace) {
  const std::string text = std::regex_replace(hemo::test::file_text(std::string(HEMO_SCENES_DIR) + "/quickstart.toml"),
                                              std::regex("\nhematocrit = 0.15\n"), "\nhematocrit = 0.58\n");
  ASSERT_NE(text.find("\nhematocrit = 0.58\n"), std::string::npos);
  const std::string path = scratch_file("ht58.toml", text);
  const hemo::Scene scene = hemo::load_scene(path);  // the nodes' loader does not place
  std::string check_says;
  try {
    hemo::load_scene(path, hemo::SceneCheck::placement);
    FAIL() << "the check passed Ht 0.58 in a 50-um vessel";
  } catch (const hemo::SceneError& e) {
    ASSERT_EQ(e.problems().size(), 1u) << e.what();
    EXPECT_EQ(e.problems()[0].key, "rbc.hematocrit");
    check_says = e.problems()[0].message;
  }
  const CellLocator locator(fluid_node_mesh(scene));
  try {
    place_particles(locator.radius(), locator.length(), locator.z0(), placement_requests(scene), scene.run.seed);
    FAIL() << "the node placed what the check refused";
  } catch (const PlacementError& e) {
    EXPECT_EQ(e.species, kRbc);
    EXPECT_LT(e.placed, e.requested);
    EXPECT_NE(std::string(e.what()).find("too full"), std::string::npos) << e.what();
    EXPECT_NE(check_says.find(e.what()), std::string::npos) << check_says << "\n" << e.what();
  }
}
