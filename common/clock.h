// Wall-clock seconds for the phase times the nodes report (phase_*_s diagnostics).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <chrono>

namespace hemo {

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace hemo
