// What the open ends of a vessel report (dem_open_ends.h), without LIGGGHTS's headers: each list
// build's events (atoms leaving the DEM, copies entering it) and the counts of centres crossing
// the ends since the run started.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <cstdint>
#include <vector>

namespace hemo::particles::dem {

struct OpenEndsEvent {
  enum class Kind { left_outlet, left_inlet, inserted };
  Kind kind = Kind::inserted;
  int tag = 0;         // the atom removed, or the copy's new tag
  int type = 0;        // LIGGGHTS atom type
  int source_tag = 0;  // an insertion's feeder atom (0 for a removal)
  int outlet = 0;      // left_outlet: which outlet (from 0)
  double z = 0;        // an insertion's: the copy's z as made (m; below the box when before the inlet)
};

// Per LIGGGHTS atom type (index 0 unused), the same on every rank.
struct OpenEndsCounts {
  std::vector<std::int64_t> inserted;
  // Per outlet and type: outlet o's count of type t at o * types() + t (one outlet: per type).
  std::vector<std::int64_t> left_outlet;
  std::vector<std::int64_t> left_inlet;
  std::size_t types() const { return inserted.size(); }
  std::size_t outlets() const { return types() == 0 ? 0 : left_outlet.size() / types(); }
  std::int64_t& left_through(std::size_t outlet, std::size_t type) { return left_outlet[outlet * types() + type]; }
  std::int64_t left_through(std::size_t outlet, std::size_t type) const { return left_outlet[outlet * types() + type]; }
  // Through every outlet.
  std::int64_t left_outlets(std::size_t type) const {
    std::int64_t n = 0;
    for (std::size_t o = 0; o < outlets(); ++o) n += left_through(o, type);
    return n;
  }
  // Inserted - left, over all types.
  std::int64_t net() const {
    std::int64_t n = 0;
    for (std::size_t t = 0; t < types(); ++t) n += inserted[t] - left_outlets(t) - left_inlet[t];
    return n;
  }
};

// What a checkpoint carries of the open ends (the free tags are found again from the atoms).
struct OpenEndsState {
  OpenEndsCounts counts;
  long capacity = 0;  // the largest tag ever given
};

}  // namespace hemo::particles::dem
