// SPDX-License-Identifier: GPL-3.0-or-later
#include "synthetic_case.h"

#include "cell_fields.h"
#include "momentum_forms.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace hemo::particles::synthetic {

mesh_t box_mesh(int nx, int ny, int nz, double x0, double x1, double y0, double y1, double length, double diameter,
                const std::string& hash) {
  mesh_t m;
  m.mesh_hash = hash;
  m.vessel_diameter_m = diameter;
  m.vessel_length_m = length;
  auto pid = [&](int i, int j, int k) { return (k * (ny + 1) + j) * (nx + 1) + i; };
  auto cid = [&](int i, int j, int k) { return (k * ny + j) * nx + i; };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i)
        m.points.push_back({x0 + (x1 - x0) * i / nx, y0 + (y1 - y0) * j / ny, length * k / nz});
  m.n_points = static_cast<int>(m.points.size());

  struct Face {
    std::array<int, 4> p;
    int owner, neighbour;
  };
  std::vector<Face> internal, patch[6];
  // Faces normal to x at i (points ordered so the area vector points to +x), etc.
  auto fx = [&](int i, int j, int k) {
    return std::array<int, 4>{pid(i, j, k), pid(i, j + 1, k), pid(i, j + 1, k + 1), pid(i, j, k + 1)};
  };
  auto fy = [&](int i, int j, int k) {
    return std::array<int, 4>{pid(i, j, k), pid(i, j, k + 1), pid(i + 1, j, k + 1), pid(i + 1, j, k)};
  };
  auto fz = [&](int i, int j, int k) {
    return std::array<int, 4>{pid(i, j, k), pid(i + 1, j, k), pid(i + 1, j + 1, k), pid(i, j + 1, k)};
  };
  auto flip = [](std::array<int, 4> p) { return std::array<int, 4>{p[0], p[3], p[2], p[1]}; };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const int c = cid(i, j, k);
        if (i + 1 < nx) internal.push_back({fx(i + 1, j, k), c, cid(i + 1, j, k)});
        if (j + 1 < ny) internal.push_back({fy(i, j + 1, k), c, cid(i, j + 1, k)});
        if (k + 1 < nz) internal.push_back({fz(i, j, k + 1), c, cid(i, j, k + 1)});
        if (i == 0) patch[0].push_back({flip(fx(0, j, k)), c, -1});
        if (i == nx - 1) patch[1].push_back({fx(nx, j, k), c, -1});
        if (j == 0) patch[2].push_back({flip(fy(i, 0, k)), c, -1});
        if (j == ny - 1) patch[3].push_back({fy(i, ny, k), c, -1});
        if (k == 0) patch[4].push_back({flip(fz(i, j, 0)), c, -1});
        if (k == nz - 1) patch[5].push_back({fz(i, j, nz), c, -1});
      }
  auto add = [&](const Face& f) {
    m.face_offsets.push_back(static_cast<int>(m.face_points.size()));
    for (int p : f.p) m.face_points.push_back(p);
    m.owner.push_back(f.owner);
    if (f.neighbour >= 0) m.neighbour.push_back(f.neighbour);
  };
  for (const auto& f : internal) add(f);
  m.n_internal_faces = static_cast<int>(internal.size());
  const char* names[6] = {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"};
  for (int p = 0; p < 6; ++p) {
    m.patch_names.push_back(names[p]);
    m.patch_types.push_back(p < 4 ? "wall" : "cyclic");
    m.patch_start.push_back(static_cast<int>(m.owner.size()));
    m.patch_size.push_back(static_cast<int>(patch[p].size()));
    for (const auto& f : patch[p]) add(f);
  }
  m.n_patches = 6;
  m.n_faces = static_cast<int>(m.owner.size());
  m.n_face_points = static_cast<int>(m.face_points.size());
  m.n_cells = nx * ny * nz;
  const double vol = (x1 - x0) / nx * (y1 - y0) / ny * length / nz;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        m.cell_centres.push_back(
            {x0 + (x1 - x0) * (i + 0.5) / nx, y0 + (y1 - y0) * (j + 0.5) / ny, length * (k + 0.5) / nz});
        m.cell_volumes.push_back(vol);
      }
  return m;
}

mesh_t wedge_mesh(int n, int nz, double radius, double length, const std::string& hash) {
  mesh_t m;
  m.mesh_hash = hash;
  m.vessel_diameter_m = 2 * radius;
  m.vessel_length_m = length;
  const double pi = 3.14159265358979323846;
  // Points: per layer k, the axis point then n ring points.
  auto axis = [&](int k) { return k * (n + 1); };
  auto ring = [&](int i, int k) { return k * (n + 1) + 1 + (i % n); };
  for (int k = 0; k <= nz; ++k) {
    m.points.push_back({0, 0, length * k / nz});
    for (int i = 0; i < n; ++i)
      m.points.push_back({radius * std::cos(2 * pi * i / n), radius * std::sin(2 * pi * i / n), length * k / nz});
  }
  m.n_points = static_cast<int>(m.points.size());
  auto cell = [&](int i, int k) { return k * n + (i % n); };
  struct Face {
    std::vector<int> p;
    int owner, neighbour;
  };
  std::vector<Face> internal, wall, zmin, zmax;
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < n; ++i) {
      const int c = cell(i, k);
      // Side face between wedge i and i+1 (along ring point i+1); owner the smaller index.
      const int other = cell(i + 1, k);
      internal.push_back(
          {{axis(k), ring(i + 1, k), ring(i + 1, k + 1), axis(k + 1)}, std::min(c, other), std::max(c, other)});
      if (k + 1 < nz) internal.push_back({{axis(k + 1), ring(i, k + 1), ring(i + 1, k + 1)}, c, cell(i, k + 1)});
      wall.push_back({{ring(i, k), ring(i + 1, k), ring(i + 1, k + 1), ring(i, k + 1)}, c, -1});
      if (k == 0) zmin.push_back({{axis(0), ring(i + 1, 0), ring(i, 0)}, c, -1});
      if (k == nz - 1) zmax.push_back({{axis(nz), ring(i, nz), ring(i + 1, nz)}, c, -1});
    }
  std::sort(internal.begin(), internal.end(), [](const Face& a, const Face& b) {
    return a.owner != b.owner ? a.owner < b.owner : a.neighbour < b.neighbour;
  });
  auto add = [&](const Face& f) {
    m.face_offsets.push_back(static_cast<int>(m.face_points.size()));
    for (int q : f.p) m.face_points.push_back(q);
    m.owner.push_back(f.owner);
    if (f.neighbour >= 0) m.neighbour.push_back(f.neighbour);
  };
  for (const auto& f : internal) add(f);
  m.n_internal_faces = static_cast<int>(internal.size());
  const std::vector<std::pair<std::string, std::vector<Face>*>> patches = {
      {"wall", &wall}, {"zmin", &zmin}, {"zmax", &zmax}};
  for (const auto& [name, faces] : patches) {
    m.patch_names.push_back(name);
    m.patch_types.push_back(name == "wall" ? "wall" : "cyclic");
    m.patch_start.push_back(static_cast<int>(m.owner.size()));
    m.patch_size.push_back(static_cast<int>(faces->size()));
    for (const auto& f : *faces) add(f);
  }
  m.n_patches = 3;
  m.n_faces = static_cast<int>(m.owner.size());
  m.n_face_points = static_cast<int>(m.face_points.size());
  m.n_cells = n * nz;
  const double dz = length / nz;
  const double area = 0.5 * radius * radius * std::sin(2 * pi / n);
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < n; ++i) {
      const double a0 = 2 * pi * i / n, a1 = 2 * pi * (i + 1) / n;
      m.cell_centres.push_back(
          {radius * (std::cos(a0) + std::cos(a1)) / 3, radius * (std::sin(a0) + std::sin(a1)) / 3, dz * (k + 0.5)});
      m.cell_volumes.push_back(area * dz);
    }
  return m;
}

fluid_state_t fluid_state(const mesh_t& mesh, const FieldAt& field, double time) {
  fluid_state_t s;
  s.mesh_hash = mesh.mesh_hash;
  s.time_s = time;
  resize_cells(s, mesh.n_cells);
  for (int c = 0; c < mesh.n_cells; ++c) {
    std::array<double, 3> x{mesh.cell_centres[c][0], mesh.cell_centres[c][1], mesh.cell_centres[c][2]};
    std::array<double, 3> u{};
    std::array<double, 9> g{};
    field(x, u, g);
    std::copy(u.begin(), u.end(), velocity_of(s, c));
    std::copy(g.begin(), g.end(), gradient_of(s, c));
  }
  return s;
}

fluid_state_t with_poiseuille_stress(fluid_state_t state, const Scene& scene) {
  const MomentumForm& form = momentum_form(scene.momentum);
  const int n = state.n_cells;
  const double drop_per_length = scene.driving.pressure_drop / scene.vessel.length;  // Pa/m
  if (form.needs_pressure_gradient()) {
    state.n_pressure_gradient_values = kVectorValues * n;
    state.pressure_gradient.assign(static_cast<std::size_t>(state.n_pressure_gradient_values), 0.0);
    for (int c = 0; c < n; ++c) pressure_gradient_of(state, c)[2] = -drop_per_length;
  }
  if (form.needs_viscous_force()) {
    state.n_viscous_values = kVectorValues * n;
    state.viscous_force.assign(static_cast<std::size_t>(state.n_viscous_values), 0.0);
    for (int c = 0; c < n; ++c) viscous_force_of(state, c)[2] = -drop_per_length;
  }
  return state;
}

Scene blood_scene(double diameter, double length, double hematocrit, double wall_shear_rate) {
  Scene s;
  s.vessel.diameter = diameter;
  s.vessel.length = length;
  s.driving.wall_shear_rate = wall_shear_rate;
  s.rbc.present = true;
  s.rbc.diameter = 5.56e-6;
  s.rbc.volume = 90e-18;
  s.rbc.mass = 1100 * 90e-18;
  s.rbc.hematocrit = hematocrit;
  s.platelet.present = true;
  s.platelet.diameter = 2.66e-6;
  s.platelet.volume = 3.14159265358979323846 / 6 * 2.60e-6 * 2.60e-6 * 2.60e-6;
  s.platelet.mass = 8.79e-15;
  s.platelet.number_density = 3e5 * 1e9;
  // fluid_state() gives the velocity alone: no pressure gradient or viscous force for F_p, F_v.
  s.momentum = "plasma_driven";
  return s;
}

void use_paper_closures(Scene& s) {
  s.rbc.drag = "rbc_fit";
  s.rbc.lift = "rbc_lift";
  s.rbc.torque = "none";
  s.platelet.drag = "oblate";
  s.platelet.lift = "oblate";
  s.platelet.torque = "oblate";
  s.platelet.semi_axis_a = 2.06e-6;
  s.platelet.semi_axis_c = 0.52e-6;
  s.solid_fraction = "sphere_overlap";
}

FieldAt poiseuille(double radius, double u_max) {
  return [=](const std::array<double, 3>& x, std::array<double, 3>& u, std::array<double, 9>& g) {
    const double r2 = x[0] * x[0] + x[1] * x[1];
    u = {0, 0, 0};
    g = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    if (r2 >= radius * radius) return;
    u[2] = u_max * (1 - r2 / (radius * radius));
    g[0 * 3 + 2] = -2 * u_max * x[0] / (radius * radius);  // d u_z / d x
    g[1 * 3 + 2] = -2 * u_max * x[1] / (radius * radius);  // d u_z / d y
  };
}

}  // namespace hemo::particles::synthetic
