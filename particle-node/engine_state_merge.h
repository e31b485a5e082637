// A particle checkpoint restored on another rank count than it was written on: the ranks' states
// made one (merged), and each new rank's share of it (atoms_in).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "engine_state.h"

#include <algorithm>

namespace hemo::particles {

namespace detail {
// Every per-atom vector of a state (its rows: the same number of values for every atom), the
// contacts apart. A new per-atom value must be listed here, or a redistributed checkpoint would
// drop it (the restore's size checks then say so).
template <class F>
void for_each_atom_vector(F&& f) {
  f(&EngineState::tag);
  f(&EngineState::type);
  f(&EngineState::mask);
  f(&EngineState::image);
  f(&EngineState::partner_count);
  f(&EngineState::x);
  f(&EngineState::v);
  f(&EngineState::omega);
  f(&EngineState::radius);
  f(&EngineState::rmass);
  f(&EngineState::density);
  f(&EngineState::force);
  f(&EngineState::torque);
  f(&EngineState::impulse);
  f(&EngineState::rotation);
  f(&EngineState::closures);
  f(&EngineState::wall_history);
  f(&EngineState::feeder_wall_history);
}
}  // namespace detail

// The states of a checkpoint written on another rank count, made one: what is the same on every
// rank from the first, the atoms (and their contact histories) of all of them in rank order.
inline EngineState merged(std::vector<EngineState> ranks) {
  if (ranks.empty()) throw std::invalid_argument("the checkpoint has no rank's state");
  EngineState all = std::move(ranks.front());
  for (std::size_t r = 1; r < ranks.size(); ++r) {
    const EngineState& s = ranks[r];
    if (s.particles != all.particles || s.tag_capacity != all.tag_capacity || s.dem_step != all.dem_step ||
        s.ranks != all.ranks || s.contact_values != all.contact_values)
      throw std::invalid_argument("the checkpoint's ranks disagree on its particles, tags or step");
    const auto append = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
    detail::for_each_atom_vector([&](auto member) { append(all.*member, s.*member); });
    append(all.partner, s.partner);
    append(all.contact_history, s.contact_history);
  }
  return all;
}

// The atoms of `s` for which `keep(x, y, z)` is true, with their partners and values (each rank
// of the new count keeps those inside its own sub-domain).
template <class Keep>
EngineState atoms_in(const EngineState& s, Keep&& keep) {
  const std::size_t atoms = s.tag.size();
  expect_size(s.x, 3 * atoms, "x");
  expect_size(s.partner_count, atoms, "partner_count");
  std::size_t partners = 0;
  for (const auto count : s.partner_count) partners += static_cast<std::size_t>(std::max<std::int64_t>(count, 0));
  expect_size(s.partner, partners, "partner");
  expect_size(s.contact_history, partners * static_cast<std::size_t>(std::max<std::int64_t>(s.contact_values, 0)),
              "contact_history");
  std::vector<char> kept(atoms);
  for (std::size_t k = 0; k < atoms; ++k) kept[k] = keep(s.x[3 * k], s.x[3 * k + 1], s.x[3 * k + 2]);
  EngineState own = s;
  detail::for_each_atom_vector([&](auto member) {
    const auto& from = s.*member;
    auto& to = own.*member;
    to.clear();
    if (atoms == 0) return;
    const std::size_t width = from.size() / atoms;
    for (std::size_t k = 0; k < atoms; ++k)
      if (kept[k]) to.insert(to.end(), from.begin() + k * width, from.begin() + (k + 1) * width);
  });
  own.partner.clear();
  own.contact_history.clear();
  const std::size_t values = static_cast<std::size_t>(s.contact_values);
  for (std::size_t k = 0, p = 0; k < atoms; p += static_cast<std::size_t>(s.partner_count[k]), ++k) {
    if (!kept[k]) continue;
    const std::size_t n = static_cast<std::size_t>(s.partner_count[k]);
    own.partner.insert(own.partner.end(), s.partner.begin() + p, s.partner.begin() + p + n);
    own.contact_history.insert(own.contact_history.end(), s.contact_history.begin() + p * values,
                               s.contact_history.begin() + (p + n) * values);
  }
  return own;
}

}  // namespace hemo::particles
