// The smallest valid scene: the paper's vessel and wall shear rate, every other key at its
// default. Tests append the tables they are about.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

namespace hemo::test {

inline constexpr const char* kMinimalScene = R"(
[vessel]
diameter_um = 100
length_um = 600

[driving]
wall_shear_rate_per_s = 799
)";

}  // namespace hemo::test
