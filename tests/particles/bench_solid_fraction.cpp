// SPDX-License-Identifier: GPL-3.0-or-later
// What the solid-fraction model does on the calibration mesh (the paper's 1,536-cell O-grid of
// a 100 um x 600 um vessel), not a test: bench_solid_fraction [hematocrit steps]
//
//  * phi per cell from the same placement (Ht 15 % + platelets), centre_cell vs sphere_overlap:
//    largest phi, phi of the wall ring of cells against the particles' true volume there;
//  * time smoothness: all particles moved along z at the local Poiseuille velocity in small
//    steps; the largest |d phi| of any cell per step (what d alpha / dt sees) and its RMS;
//  * the cost of a deposition per particle.
#include "deposition.h"

#include <placement.h>
#include <vessel_mesh.h>
#include <hemo/mesh_t.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

using namespace hemo::particles;

int main(int argc, char** argv) {
  const double ht = argc > 1 ? std::atof(argv[1]) : 0.15;
  const int steps = argc > 2 ? std::atoi(argv[2]) : 200;
  hemo::Scene scene;
  scene.vessel.diameter = 100e-6;
  scene.vessel.length = 600e-6;
  scene.rbc.present = scene.platelet.present = true;
  scene.rbc.diameter = 5.56e-6;
  scene.rbc.volume = 90e-18;
  scene.rbc.hematocrit = ht;
  scene.platelet.diameter = 2.66e-6;
  scene.platelet.volume = 4.0 / 3 * 3.14159265358979 * 2.06e-6 * 2.06e-6 * 0.52e-6;
  scene.platelet.number_density = 3e14;
  const auto poly = hemo::make_vessel_mesh(scene.vessel, scene.mesh);
  hemo::mesh_t mesh;
  hemo::fill_mesh_message(poly, hemo::compute_geometry(poly), scene.vessel, mesh);
  const CellLocator loc(mesh);
  const double R = 50e-6, L = 600e-6, u_max = 799 * R / 2;
  auto placed = place_particles(R, L, loc.z0(), placement_requests(scene), 7);

  // Wall cells: those with a wall face (a point just inside the wall at their angle).
  std::vector<char> wall_cell(loc.n_cells(), 0);
  for (int c = 0; c < loc.n_cells(); ++c)
    loc.for_each_face(c, loc.centre(c), [&](double, int beyond, const Vec3&) { wall_cell[c] |= beyond < 0; });
  double wall_volume = 0;
  for (int c = 0; c < loc.n_cells(); ++c)
    if (wall_cell[c]) wall_volume += loc.volume(c);
  // The wall ring's inner radius: the smallest centre-to-axis distance of a wall cell's inner face is
  // not needed; the true particle volume in the ring is measured with fine sampling instead.
  std::printf("calibration mesh: %d cells, %zu particles (Ht %.2f); wall ring: %.0f %% of the volume\n", loc.n_cells(),
              placed.size(), ht, 100 * wall_volume / (3.14159265358979 * R * R * L));

  for (const char* name : {"centre_cell", "sphere_overlap"}) {
    Deposition dep(loc, make_solid_fraction_model(name, loc));
    auto deposit = [&](const std::vector<PlacedParticle>& ps) {
      dep.clear();
      for (const auto& p : ps) {
        const int c = loc.locate(p.position);
        const int cell = c >= 0 ? c : loc.locate_in_wall_gap(p.position);
        if (cell < 0) continue;
        dep.add_particle(cell, loc.wrap(p.position), p.diameter / 2,
                         p.species == kRbc ? scene.rbc.volume : scene.platelet.volume, Vec3::Zero(), 0.0);
      }
      std::vector<double> phi(loc.n_cells());
      for (int c = 0; c < loc.n_cells(); ++c)
        phi[c] = dep.data()[c * Deposition::kStride + Deposition::kVolume] / loc.volume(c);
      return phi;
    };
    const auto t0 = std::chrono::steady_clock::now();
    auto phi = deposit(placed);
    const double cost = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / placed.size();
    double phi_max = 0, wall_solid = 0;
    for (int c = 0; c < loc.n_cells(); ++c) {
      phi_max = std::max(phi_max, phi[c]);
      if (wall_cell[c]) wall_solid += phi[c] * loc.volume(c);
    }
    // Moving: dz = u(r) dt per step with dt = 20 us (one coupling interval).
    auto moving = placed;
    double worst = 0, sum2 = 0;
    long n = 0;
    for (int k = 0; k < steps; ++k) {
      for (auto& p : moving) {
        const double r2 = p.position.x() * p.position.x() + p.position.y() * p.position.y();
        p.position.z() += u_max * (1 - r2 / (R * R)) * 20e-6;
      }
      const auto next = deposit(moving);
      for (int c = 0; c < loc.n_cells(); ++c) {
        const double d = std::abs(next[c] - phi[c]);
        worst = std::max(worst, d);
        sum2 += d * d;
        ++n;
      }
      phi = next;
    }
    std::printf(
        "%-15s max phi %.3f; solid in the wall ring %.4g m^3 (%.1f %% of all); per coupling step of 20 us: "
        "max |d phi| %.4f, RMS %.2e; %.0f ns per particle\n",
        name, phi_max, wall_solid, 100 * wall_solid / dep.total_volume(), worst, std::sqrt(sum2 / n), cost * 1e9);
  }
  return 0;
}
