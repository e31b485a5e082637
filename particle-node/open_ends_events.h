// What the open ends of a vessel report (dem_open_ends.h), without LIGGGHTS's headers: each list
// build's events and the counts since the run started.
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
};

// Per LIGGGHTS atom type (index 0 unused), the same on every rank.
struct OpenEndsCounts {
  std::vector<std::int64_t> inserted, left_outlet, left_inlet;
  // Inserted - left, over all types.
  std::int64_t net() const {
    std::int64_t n = 0;
    for (std::size_t t = 0; t < inserted.size(); ++t) n += inserted[t] - left_outlet[t] - left_inlet[t];
    return n;
  }
};

// What a checkpoint carries of the open ends (the free tags are found again from the atoms).
struct OpenEndsState {
  OpenEndsCounts counts;
  long capacity = 0;  // the largest tag ever given
};

}  // namespace hemo::particles::dem
