// What the DEM carries from one coupling step to the next, as one rank holds it: the file
// engine-rank<r>.h5 of a particle checkpoint (DemEngine::checkpoint_state / restore; each of the
// engine's pieces saves and restores its own part).
//
// LIGGGHTS keeps no more between two runs than its atoms, their fixes' per-atom values and the
// contact histories (pair and wall); its neighbour lists and ghost atoms are rebuilt from those
// (LiggghtsSession::rebuild_neighbours), and the checkpoint is taken right after such a rebuild, in
// the ranks' own atom order, so that a restored engine rebuilds exactly the same lists. Our own
// per-tag tracking (periodic crossings, last z, the locate cache) is kept whole on every rank.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "checkpoint_file.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace hemo::particles {

struct EngineState {
  // The same on every rank.
  std::int64_t ranks = 1;
  std::int64_t particles = 0;     // the atoms held: present, and an open vessel's straddling its ends
  std::int64_t created = 0;       // at the run's start
  std::int64_t tag_capacity = 0;  // tags in use lie in 1..tag_capacity
  // An open vessel's counts per LIGGGHTS atom type (index 0 unused; empty for a periodic one);
  // left_outlet per outlet and type (OpenEndsCounts: one outlet, per type).
  std::vector<std::int64_t> inserted, left_outlet, left_inlet;
  std::vector<std::int64_t> type_of;     // LIGGGHTS atom type per species (0: none)
  std::int64_t dem_step = 0;             // LIGGGHTS's ntimestep
  double dt = 0;                         // the DEM step of the last run
  std::int64_t last_rotation_step = -1;  // the DEM step whose orientation kick was applied last
  double rotation_dt = 0;                // and its length
  std::int64_t neighbour_builds = 0;     // LIGGGHTS's count (0: no list to measure overlaps on yet)
  std::vector<double> max_reynolds;      // per species, of the last run
  double min_relaxation_time = 0;        // s, of the last run (NaN: no run yet)
  std::int64_t outside_total = 0;        // particles outside the mesh in the last run
  std::int64_t lost = 0;
  std::vector<std::int64_t> pending_tags;    // set_orientation not applied yet
  std::vector<double> pending_orientations;  // 4 per pending tag

  // This rank's atoms, in LIGGGHTS's local order; vectors hold 3 (or the fix's width) per atom.
  std::vector<std::int64_t> tag, type, mask, image;
  std::vector<double> x, v, omega, radius, rmass, density;
  std::vector<double> force, torque;        // of the last DEM step: the next run's first half kick
  std::vector<double> impulse;              // hemoImpulse: this interval's F dt, beta dt; the last F, beta
  std::vector<double> rotation;             // hemoRotation: q, L (platelets); empty without orientation
  std::vector<double> closures;             // hemoClosures: the held closures; empty when m = 1
  std::vector<double> wall_history;         // the wall contacts' tangential history
  std::vector<double> feeder_wall_history;  // the feeder's wall's (an open vessel's)
  std::vector<std::int64_t> partner_count;  // pair contacts with history, per atom
  std::vector<std::int64_t> partner;        // their partners' tags
  std::vector<double> contact_history;      // contact_values per partner
  std::int64_t contact_values = 0;

  // Per tag (index 0 unused), as this rank has it: locate cache (anchor x, y, z, clearance,
  // cell), last z seen, periodic crossings, present (1) or free (0).
  static constexpr int kTrackedValues = 8;
  std::vector<double> tracked;

  template <class F>
  void visit(F&& f) {
    f("ranks", ranks);
    f("particles", particles);
    f("created", created);
    f("tag_capacity", tag_capacity);
    f("inserted", inserted);
    f("left_outlet", left_outlet);
    f("left_inlet", left_inlet);
    f("type_of", type_of);
    f("dem_step", dem_step);
    f("dt", dt);
    f("last_rotation_step", last_rotation_step);
    f("rotation_dt", rotation_dt);
    f("neighbour_builds", neighbour_builds);
    f("max_reynolds", max_reynolds);
    f("min_relaxation_time", min_relaxation_time);
    f("outside_total", outside_total);
    f("lost", lost);
    f("pending_tags", pending_tags);
    f("pending_orientations", pending_orientations);
    f("tag", tag);
    f("type", type);
    f("mask", mask);
    f("image", image);
    f("x", x);
    f("v", v);
    f("omega", omega);
    f("radius", radius);
    f("rmass", rmass);
    f("density", density);
    f("force", force);
    f("torque", torque);
    f("impulse", impulse);
    f("rotation", rotation);
    f("closures", closures);
    f("wall_history", wall_history);
    f("feeder_wall_history", feeder_wall_history);
    f("partner_count", partner_count);
    f("partner", partner);
    f("contact_history", contact_history);
    f("contact_values", contact_values);
    f("tracked", tracked);
  }
};

// A vector of a checkpoint that must hold `expected` values: std::invalid_argument otherwise.
template <class T>
void expect_size(const std::vector<T>& values, std::size_t expected, const char* name) {
  if (values.size() != expected)
    throw std::invalid_argument(std::string("the checkpoint's '") + name + "' holds " + std::to_string(values.size()) +
                                " values, not " + std::to_string(expected));
}

inline std::string engine_state_file(const std::string& folder, int rank) {
  return folder + "/engine-rank" + std::to_string(rank) + ".h5";
}

inline void write_engine_state(EngineState& state, const std::string& path) {
  CheckpointWriter out(path);
  state.visit([&](const char* name, const auto& value) { out.put(name, value); });
  out.close();
}

inline EngineState read_engine_state(const std::string& path) {
  const CheckpointReader in(path);
  EngineState state;
  state.visit([&](const char* name, auto& value) {
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_same_v<T, double>)
      value = in.real(name);
    else if constexpr (std::is_same_v<T, std::int64_t>)
      value = in.integer(name);
    else
      in.get(name, value);
  });
  return state;
}

}  // namespace hemo::particles
