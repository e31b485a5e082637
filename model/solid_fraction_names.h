// The solid-fraction models a scene may choose with coupling.solid_fraction: the one registration
// of their names on the model's side, so that validating a scene reads nothing of the particle
// node. The classes are the particle node's (particle-node/deposition.h, gaussian_kernel.h);
// particle-node/deposition.cpp's factory table static_asserts that it names exactly these, in this
// order, so a model added on one side only stops the particle node's build. In byte order.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace hemo {

inline constexpr std::array<std::string_view, 3> kSolidFractionNames = {"centre_cell", "gaussian_kernel",
                                                                         "sphere_overlap"};
// The model that shares a particle over a kernel wider than the particle, set by
// coupling.kernel_width_diameters; the scene accepts fluid cells narrower than a particle with it.
inline constexpr std::string_view kKernelSolidFraction = kSolidFractionNames[1];
inline bool shares_over_kernel(const std::string& solid_fraction) { return solid_fraction == kKernelSolidFraction; }

inline const std::vector<std::string>& known_solid_fractions() {
  static const std::vector<std::string> n(kSolidFractionNames.begin(), kSolidFractionNames.end());
  return n;
}

// The Gaussian kernel's full width at half maximum is kernel_width_diameters times the particle's
// volume-equivalent diameter; it reaches kKernelReachSigmas standard deviations from the centre,
// where it is cut (and shifted to vanish there, so that a cell enters with nothing).
inline constexpr double kKernelReachSigmas = 3.0;
// FWHM / sigma of a Gaussian, 2 sqrt(2 ln 2).
inline constexpr double kFwhmPerSigma = 2.3548200450309493;
inline double kernel_sigma(double width_diameters, double diameter) {
  return width_diameters * diameter / kFwhmPerSigma;
}
inline double kernel_reach(double width_diameters, double diameter) {
  return kKernelReachSigmas * kernel_sigma(width_diameters, diameter);
}

// How far from its centre, per radius, a particle shared by this model reaches the fluid's
// cells: its sphere (1), or the kernel's reach. An open vessel keeps a cell in the DEM until its
// centre is this far past an end (particle-node/dem_open_ends.h).
inline double reach_per_radius(const std::string& solid_fraction, double width_diameters) {
  return shares_over_kernel(solid_fraction) ? kernel_reach(width_diameters, 2.0) : 1.0;
}

}  // namespace hemo
