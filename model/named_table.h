// The lookup every table of named options shares (momentum forms, suspension viscosities): its
// names in order, and the entry of a name with one line naming the known ones when there is none.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace hemo {

template <class Entry>
std::vector<std::string> names_of(const std::vector<Entry>& table) {
  std::vector<std::string> names;
  for (const Entry& e : table) names.push_back(e.name);
  return names;
}

// Throws std::invalid_argument "no <what> '<name>' (known: a, b, c)".
template <class Entry>
const Entry& named_entry(const std::vector<Entry>& table, const std::string& name, const std::string& what) {
  for (const Entry& e : table)
    if (e.name == name) return e;
  std::string known;
  for (const Entry& e : table) known += (known.empty() ? "" : ", ") + e.name;
  throw std::invalid_argument("no " + what + " '" + name + "' (known: " + known + ")");
}

}  // namespace hemo
