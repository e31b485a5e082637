// Units: SI everywhere in code. Scene files state their unit in each key's name
// (`diameter_um`, `viscosity_Pa_s`); these are the only conversions, done once at parse time.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

namespace hemo::units {
inline constexpr double um = 1e-6;     // micrometre -> m
inline constexpr double um3 = 1e-18;   // cubic micrometre -> m^3
inline constexpr double pg = 1e-15;    // picogram -> kg
inline constexpr double per_ul = 1e9;  // number per microlitre -> number per m^3
inline constexpr double pi = 3.14159265358979323846;
}  // namespace hemo::units
