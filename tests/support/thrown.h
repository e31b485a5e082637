// What a call throws, for tests of one-line errors.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <exception>
#include <functional>
#include <string>

namespace hemo::test {

// The message of the std::exception `f` throws, or "(nothing thrown)".
inline std::string what_thrown(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(nothing thrown)";
}

}  // namespace hemo::test
