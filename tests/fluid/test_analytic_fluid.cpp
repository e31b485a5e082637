// hemocosim-analytic-fluid in runs: with the prescribed particle node (it publishes exactly the
// analytic flow at cell centres) and with the real particle node (its core particles move with
// the analytic flow).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_run.h"
#include "vessel_mesh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#ifdef HEMO_WITH_PARTICLE_NODE
#include <hdf5.h>
#endif

using namespace hemo::fluidtest;

namespace {

SceneSpec analytic_scene(const std::string& name, const std::string& flow) {
  SceneSpec s;
  s.name = name;
  s.diameter_um = 40;
  s.length_um = 60;
  s.core = 4;
  s.ring = 3;
  s.axial = 6;
  s.driving = "wall_shear_rate_per_s = 800";
  s.dt = 2e-5;
  s.steps = 5;
  s.fluid_command = bin("hemocosim-analytic-fluid") + " " + flow;
  s.particle_command = bin("hemocosim-prescribed-particles") + " --record state.csv";
  return s;
}

}  // namespace

// The published state is the analytic flow at the cell centres, to round-off.
TEST(AnalyticFluid, PublishesPoiseuilleAndShearAtCellCentres) {
  const double R = 20e-6, a = 800 / (2 * R);  // gamma_w = 2 a R
  for (const std::string flow : {"--flow poiseuille", "--flow shear --shear-rate 300 --shear-velocity 0.002"}) {
    const auto r = run_scene(analytic_scene("analytic-prescribed", flow));
    ASSERT_EQ(r.command.exit_code, 0) << r.command.output;
    const auto cells = read_state(r.dir + "/state.csv");
    ASSERT_EQ(cells.size(), 6u * (16 + 4 * 4 * 3));
    double worst = 0;
    for (const auto& c : cells) {
      const bool poiseuille = flow.find("poiseuille") != std::string::npos;
      const double uz = poiseuille ? a * (R * R - c.x * c.x - c.y * c.y) : 0.002 + 300 * c.x;
      const double gx = poiseuille ? -2 * a * c.x : 300, gy = poiseuille ? -2 * a * c.y : 0;
      worst = std::max({worst, std::abs(c.u[2] - uz) / 8e-3, std::abs(c.grad[2] - gx) / 800,
                        std::abs(c.grad[5] - gy) / 800, std::abs(c.u[0]) + std::abs(c.u[1])});
    }
    EXPECT_LT(worst, 1e-12) << flow;
    const auto m = read_metrics(r.dir);
    EXPECT_NEAR(last(m, "fluid", "wall_shear_stress_Pa"),
                1.2e-3 * (flow.find("shear-rate") != std::string::npos ? 300 : 800), 1e-12);
  }
}

#ifdef HEMO_WITH_PARTICLE_NODE
namespace {
// Positions (N x 3, row-major) of the last snapshot in particles.h5 (/snapshots/<step>/position).
std::vector<double> final_positions(const std::string& path) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) throw std::runtime_error("cannot open " + path);
  const hid_t g = H5Gopen2(f, "/snapshots", H5P_DEFAULT);
  hsize_t n = 0;
  H5Gget_num_objs(g, &n);
  std::string lastName;
  for (hsize_t i = 0; i < n; ++i) {
    char name[256];
    H5Gget_objname_by_idx(g, i, name, sizeof name);
    lastName = std::max(lastName, std::string(name));  // zero-padded step numbers
  }
  const hid_t ds = H5Dopen2(g, (lastName + "/position").c_str(), H5P_DEFAULT);
  const hid_t space = H5Dget_space(ds);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space, dims, nullptr);
  std::vector<double> x(dims[0] * 3);
  if (!x.empty()) H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, x.data());
  H5Sclose(space);
  H5Dclose(ds);
  H5Gclose(g);
  H5Fclose(f);
  return x;
}

// The cell holding x (wrapped into the period along z): the vessel's cells are prisms of
// their z faces' polygons, so it is the one whose polygon contains (x, y) and whose z range
// contains z.
class PrismLocator {
 public:
  explicit PrismLocator(const hemo::PolyMesh& mesh) : centres_(hemo::compute_geometry(mesh).cell_centres) {
    const auto geo = hemo::compute_geometry(mesh);
    cells_.resize(static_cast<std::size_t>(mesh.n_cells));
    for (int f = 0; f < mesh.n_faces(); ++f) {
      const auto& a = geo.face_areas[static_cast<std::size_t>(f)];
      if (std::abs(a[2]) < 0.999 * std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])) continue;
      for (int cell : {mesh.owner[static_cast<std::size_t>(f)],
                       f < mesh.n_internal_faces() ? mesh.neighbour[static_cast<std::size_t>(f)] : -1}) {
        if (cell < 0) continue;
        auto& c = cells_[static_cast<std::size_t>(cell)];
        const double z = mesh.points[static_cast<std::size_t>(mesh.faces[static_cast<std::size_t>(f)][0])][2];
        if (c.polygon.empty()) {
          for (int p : mesh.faces[static_cast<std::size_t>(f)])
            c.polygon.push_back(mesh.points[static_cast<std::size_t>(p)]);
          c.z0 = c.z1 = z;
        }
        c.z0 = std::min(c.z0, z);
        c.z1 = std::max(c.z1, z);
      }
    }
  }
  int find(const hemo::Vec3& x) const {
    for (std::size_t i = 0; i < cells_.size(); ++i) {
      const auto& c = cells_[i];
      if (x[2] < c.z0 || x[2] >= c.z1) continue;
      bool inside = false;  // ray casting along +x
      for (std::size_t k = 0, j = c.polygon.size() - 1; k < c.polygon.size(); j = k++) {
        const auto &p = c.polygon[k], &q = c.polygon[j];
        if ((p[1] > x[1]) != (q[1] > x[1]) && x[0] < (q[0] - p[0]) * (x[1] - p[1]) / (q[1] - p[1]) + p[0])
          inside = !inside;
      }
      if (inside) return static_cast<int>(i);
    }
    return -1;
  }
  const hemo::Vec3& centre(int cell) const { return centres_[static_cast<std::size_t>(cell)]; }

 private:
  struct Prism {
    std::vector<hemo::Vec3> polygon;
    double z0 = 0, z1 = 0;
  };
  std::vector<Prism> cells_;
  std::vector<hemo::Vec3> centres_;
};

}  // namespace

// One-way: platelets (no RBCs, no lift) in the analytic Poiseuille flow of a 40 um vessel. The
// particle node samples the fluid at a particle as u_c + G_c (x - x_c) from its cell's published
// centre values, which for this concave profile lies above the analytic u_z(x) by
// a |x - x_c|^2 across the section. Checked at the core platelets (r < R/2) of the last snapshot:
// - the node's sample (core_fluid_axial_velocity_m_s) is that reconstruction, to round-off;
// - the platelets move with it (core_particle_axial_velocity_m_s; relaxation ~1 us << 0.4 ms);
// - both are within 3 % of the analytic flow at the same positions (measured: 1.6 %).
TEST(AnalyticFluid, CoreParticlesOfTheRealParticleNodeMoveWithTheAnalyticFlow) {
  auto s = analytic_scene("analytic-particles", "--flow poiseuille");
  s.particle_command.clear();  // the real particle node
  s.steps = 20;
  s.every_steps = 10;
  s.extra = "[platelet]\nnumber_density_per_ul = 3000000\n";
  const auto r = run_scene(s);
  ASSERT_EQ(r.command.exit_code, 0) << r.command.output;
  const auto m = read_metrics(r.dir);
  const double particle = last(m, "particles", "core_particle_axial_velocity_m_s");
  const double sampled = last(m, "particles", "core_fluid_axial_velocity_m_s");
  const double count = last(m, "particles", "core_particles");

  const hemo::Vessel vessel{40e-6, 60e-6};
  const PrismLocator locator(hemo::make_vessel_mesh(vessel, hemo::MeshSpec{s.core, s.ring, s.axial}));
  const auto positions = final_positions(r.dir + "/particles.h5");
  const double R = vessel.radius(), a = 800 / (2 * R);
  double analytic = 0, reconstructed = 0;
  int n = 0;
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3) {
    hemo::Vec3 x{positions[i], positions[i + 1], positions[i + 2]};
    if (x[0] * x[0] + x[1] * x[1] >= 0.25 * R * R) continue;
    x[2] -= vessel.length * std::floor(x[2] / vessel.length);
    const int cell = locator.find(x);
    ASSERT_GE(cell, 0) << "particle at " << x[0] << " " << x[1] << " " << x[2];
    const auto& c = locator.centre(cell);
    const double uc = a * (R * R - c[0] * c[0] - c[1] * c[1]);
    reconstructed += uc - 2 * a * c[0] * (x[0] - c[0]) - 2 * a * c[1] * (x[1] - c[1]);
    analytic += a * (R * R - x[0] * x[0] - x[1] * x[1]);
    ++n;
  }
  ASSERT_GT(n, 20);
  EXPECT_EQ(n, static_cast<int>(count));
  analytic /= n;
  reconstructed /= n;
  std::printf(
      "analytic Poiseuille, %d core platelets: particles %.6e m/s, node's sample %.6e m/s, "
      "reconstruction %.6e m/s, analytic %.6e m/s (particles/analytic - 1 = %.2e)\n",
      n, particle, sampled, reconstructed, analytic, particle / analytic - 1);
  EXPECT_NEAR(sampled / reconstructed, 1, 1e-9);
  EXPECT_NEAR(particle / sampled, 1, 1e-3);
  EXPECT_NEAR(particle / analytic, 1, 0.03);
  EXPECT_GE(reconstructed, analytic);
}
#endif
