// SPDX-License-Identifier: GPL-3.0-or-later
#include "feeder_develop.h"

#include "driving.h"
#include "units.h"
#include "vessel_ends.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace hemo {

bool develops_feeder(const Scene& scene) { return scene.vessel.feeder_develop > 0 && fed_by_feeder(scene.vessel); }

long feeder_develop_steps(const Scene& scene) {
  // The quotient of two decimal inputs (0.5 / 1e-4) may land a hair above the whole number.
  const double steps = scene.vessel.feeder_develop / scene.time.coupling_interval;
  return std::max(1L, static_cast<long>(std::ceil(steps * (1 - 1e-12))));
}

std::string feeder_develop_scene_text(const Scene& scene, const std::string& scene_text) {
  if (!develops_feeder(scene))
    throw std::invalid_argument("the scene develops no feeder (vessel.feeder_develop_s, vessel.inlet = \"feeder\")");
  toml::table file = toml::parse(scene_text);
  const FeederLayout feeder = feeder_layout(scene);
  auto table = [&](const char* name) -> toml::table& {
    if (!file[name].is_table()) file.insert_or_assign(name, toml::table{});
    return *file[name].as_table();
  };

  file.insert_or_assign("vessel", toml::table{{"diameter_um", 2 * feeder.radius / units::um},
                                              {"length_um", feeder.period / units::um}});
  toml::table& mesh = table("mesh");
  mesh.erase("surface_cell_size_um");
  mesh.insert_or_assign("axial_cells", feeder.layers);
  const double body_force_drop = driving_pressure_drop(scene) * feeder.period / scene.vessel.length;
  file.insert_or_assign("driving", toml::table{{"pressure_drop_Pa", body_force_drop}});

  const long steps = feeder_develop_steps(scene);
  table("time").insert_or_assign("coupling_steps", steps);
  const long every = scene.output.checkpoint_every_steps;
  table("output").insert_or_assign("checkpoint_every_steps", every > 0 && steps % every == 0 ? every : steps);
  table("run").insert_or_assign("name", scene.run.name + "-feeder-develop");

  std::ostringstream out;
  out << "# The feeder of " << scene.run.name << " developed on its own for " << scene.vessel.feeder_develop
      << " s (model/feeder_develop.h)\n"
      << file << "\n";
  return out.str();
}

}  // namespace hemo
