// SPDX-License-Identifier: GPL-3.0-or-later
#include "developed_feeder.h"

#include "checkpoint_file.h"
#include "engine_state.h"
#include "engine_state_merge.h"

#include <checkpoint.h>
#include <feeder_develop.h>
#include <fmt/format.h>
#include <vessel_ends.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace hemo::particles {

namespace {
constexpr int kRotationValues = 7;  // q (w, x, y, z), L (3): dem_fixes.h
}

std::vector<PlacedParticle> developed_feeder_cells(const Scene& scene, const std::string& develop_dir, double z0) {
  auto fail = [&](const std::string& why) {
    return std::runtime_error(fmt::format("the developed feeder {}: {}", develop_dir, why));
  };
  const long steps = feeder_develop_steps(scene);
  const auto last = last_complete_checkpoint(develop_dir);
  if (!last || *last != steps)
    throw fail(last ? fmt::format("its last checkpoint is of step {}, not of its last step {}", *last, steps)
                    : fmt::format("it has no checkpoint of its last step {}", steps));
  const std::string folder = checkpoint_of(develop_dir, steps, "particles");
  std::vector<EngineState> ranks;
  try {
    const long written_on = CheckpointReader(folder + "/node.h5").integer("ranks");
    for (long r = 0; r < written_on; ++r) ranks.push_back(read_engine_state(engine_state_file(folder, static_cast<int>(r))));
  } catch (const std::exception& e) {
    throw fail(e.what());
  }
  EngineState state;
  try {
    state = merged(std::move(ranks));
    const std::size_t atoms = state.tag.size();
    expect_size(state.type, atoms, "type");
    expect_size(state.radius, atoms, "radius");
    for (const auto* v : {&state.x, &state.v, &state.omega}) expect_size(*v, 3 * atoms, "x, v, omega");
  } catch (const std::invalid_argument& e) {
    throw fail(e.what());
  }

  const FeederLayout feeder = feeder_layout(scene);
  const std::size_t n = state.tag.size();
  const bool rotation = state.rotation.size() == kRotationValues * n;
  // By tag: the same cells in the same order whatever the ranks it was written on.
  std::vector<std::size_t> by_tag(n);
  std::iota(by_tag.begin(), by_tag.end(), 0);
  std::sort(by_tag.begin(), by_tag.end(), [&](std::size_t a, std::size_t b) { return state.tag[a] < state.tag[b]; });
  std::vector<PlacedParticle> cells;
  cells.reserve(n);
  for (const std::size_t i : by_tag) {
    PlacedParticle p;
    p.species = -1;
    for (int sp = 0; sp < kSpeciesCount && sp < static_cast<int>(state.type_of.size()); ++sp)
      if (state.type_of[sp] == state.type[i]) p.species = sp;
    const Species* species = p.species == kRbc ? &scene.rbc : p.species == kPlatelet ? &scene.platelet : nullptr;
    if (species == nullptr || !species->present)
      throw fail(fmt::format("its particle {} is of LIGGGHTS type {}, no species of this scene", state.tag[i],
                             state.type[i]));
    p.diameter = species->diameter;
    if (std::abs(2 * state.radius[i] - p.diameter) > 1e-9 * p.diameter)
      throw fail(fmt::format("its {} {} is {:.6g} um across, this scene's {:.6g} um", species->name, state.tag[i],
                             2e6 * state.radius[i], 1e6 * p.diameter));
    const auto row = [&](const std::vector<double>& v) { return Vec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]); };
    p.position = row(state.x);
    // The develop run's periodic box: z wrapped onto one period, from the feeder's z0.
    p.position.z() = z0 + std::fmod(std::fmod(p.position.z(), feeder.period) + feeder.period, feeder.period);
    if (std::hypot(p.position.x(), p.position.y()) > feeder.radius * (1 + 1e-9))
      throw fail(fmt::format("its particle {} lies {:.4g} um off the axis, outside the feeder's radius {:.4g} um",
                             state.tag[i], 1e6 * std::hypot(p.position.x(), p.position.y()), 1e6 * feeder.radius));
    PlacedParticle::Motion m;
    m.velocity = row(state.v);
    m.angular_velocity = row(state.omega);
    if (rotation) {
      const double* q = &state.rotation[kRotationValues * i];
      m.orientation = Eigen::Vector4d(q[0], q[1], q[2], q[3]);
      m.angular_momentum = Vec3(q[4], q[5], q[6]);
    }
    p.motion = m;
    cells.push_back(p);
  }
  return cells;
}

}  // namespace hemo::particles
