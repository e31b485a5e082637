// SPDX-License-Identifier: GPL-3.0-or-later
#include "synthetic_run.h"

#include "geometry.h"
#include "scene.h"

#include <fmt/format.h>
#include <hdf5.h>

#include <unistd.h>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace fs = std::filesystem;

namespace hemo::studytest {

namespace {

void dataset(hid_t group, const char* name, hid_t mem_type, hid_t file_type, hsize_t rows, hsize_t cols,
             const void* data) {
  const hsize_t dims[2] = {rows, cols};
  const hid_t space = H5Screate_simple(cols > 1 ? 2 : 1, dims, nullptr);
  const hid_t set = H5Dcreate2(group, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (rows > 0) H5Dwrite(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
  H5Dclose(set);
  H5Sclose(space);
}

void write_snapshot(hid_t root, long step, double t, const std::vector<std::int64_t>& id,
                    const std::vector<std::int8_t>& species, const std::vector<double>& pos,
                    const std::vector<double>& vel) {
  const std::string name = fmt::format("{:08d}", step);
  const hid_t g = H5Gcreate2(root, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t scalar = H5Screate(H5S_SCALAR);
  const hid_t attr = H5Acreate2(g, "time_s", H5T_IEEE_F64LE, scalar, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attr, H5T_NATIVE_DOUBLE, &t);
  H5Aclose(attr);
  H5Sclose(scalar);
  const hsize_t n = id.size();
  dataset(g, "id", H5T_NATIVE_INT64, H5T_STD_I64LE, n, 1, id.data());
  dataset(g, "species", H5T_NATIVE_INT8, H5T_STD_I8LE, n, 1, species.data());
  dataset(g, "position", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, n, 3, pos.data());
  dataset(g, "velocity", H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, n, 3, vel.data());
  H5Gclose(g);
}

// A bifurcation's run: the cells spread over its branches (moving along their axes), and the ends'
// metrics of SyntheticRun.
void write_surface_run(const std::string& dir, const Scene& scene, const SyntheticRun& spec,
                       const std::vector<std::int8_t>& species, const std::vector<std::int64_t>& id,
                       std::mt19937& rng) {
  const auto wall = make_vessel_wall(scene.vessel);
  const auto branches = wall->branches();
  if (branches.empty()) throw std::runtime_error("a synthetic surface run needs a branching vessel");
  std::uniform_real_distribution<double> u(0, 1);
  const double pi = 3.14159265358979323846, speed = 0.01;
  const std::size_t n = id.size();
  std::vector<double> pos(3 * n), vel(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const VesselWall::Branch& b = branches[i % branches.size()];
    const VesselWall::Point axis = (b.end - b.start).normalized();
    // The bifurcation's axes lie in the x-z plane: y is across every one.
    const VesselWall::Point across = VesselWall::Point::UnitY(), other = axis.cross(across);
    const double r = 0.8 * b.radius * std::sqrt(u(rng)), phi = 2 * pi * u(rng);
    const VesselWall::Point x =
        b.start + (0.5 + 0.5 * u(rng)) * (b.end - b.start) + r * (std::cos(phi) * across + std::sin(phi) * other);
    for (int d = 0; d < 3; ++d) {
      pos[3 * i + d] = x[d];
      vel[3 * i + d] = speed * axis[d];
    }
  }
  const hid_t f = H5Fcreate((fs::path(dir) / "particles.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) throw std::runtime_error("cannot create particles.h5 in " + dir);
  const hid_t root = H5Gcreate2(f, "snapshots", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  for (int s = 0; s < spec.snapshots; ++s)
    write_snapshot(root, static_cast<long>(s) * spec.steps_per_snapshot, s * spec.dt_s, id, species, pos, vel);
  H5Gclose(root);
  H5Fclose(f);

  std::ofstream m(fs::path(dir) / "metrics.csv");
  m << "step,time_s,node,name,value\n";
  const long last = std::max(1L, static_cast<long>(spec.snapshots - 1) * spec.steps_per_snapshot);
  double rbc_1 = 0;
  for (long k = 0; k <= last; ++k) {
    const double t = k * spec.dt_s / spec.steps_per_snapshot;
    if (k > 0) rbc_1 += 2 * k <= last ? spec.rbc_1_early : spec.rbc_1_late;
    auto metric = [&](const char* node, const std::string& name, double value) {
      m << fmt::format("{},{:.17g},{},{},{:.17g}\n", k, t, node, name, value);
    };
    metric("fluid", "inlet_plasma_flux_m3_s", spec.plasma_in);
    metric("fluid", "outlet_1_plasma_flux_m3_s", spec.plasma_1);
    metric("fluid", "outlet_2_plasma_flux_m3_s", spec.plasma_in - spec.plasma_1);
    metric("particles", "rbc_inserted", spec.rbc_in * k);
    metric("particles", "rbc_left_inlet", 0);
    metric("particles", "rbc_left_outlet_1", rbc_1);
    metric("particles", "rbc_left_outlet_2", spec.rbc_in * k - rbc_1);
    metric("particles", "platelet_inserted", spec.platelets_in * k);
    metric("particles", "platelet_left_inlet", 0);
    metric("particles", "platelet_left_outlet_1", spec.platelets_1 * k);
    metric("particles", "platelet_left_outlet_2", (spec.platelets_in - spec.platelets_1) * k);
  }
}

}  // namespace

void write_synthetic_run(const std::string& dir, const std::string& scene_path, const SyntheticRun& spec) {
  fs::create_directories(dir);
  fs::copy_file(scene_path, fs::path(dir) / "scene.toml", fs::copy_options::overwrite_existing);
  const Scene scene = load_scene(scene_path);
  const double R = scene.vessel.radius(), L = scene.vessel.length;
  const double pi = 3.14159265358979323846;

  // Initial positions: RBCs uniform over the core r < 0.8 R, platelets uniform over the tube.
  std::mt19937 rng(spec.seed);
  std::uniform_real_distribution<double> u(0, 1);
  const int n = spec.rbcs + spec.platelets;
  std::vector<double> r0(n), theta(n), z0(n);
  std::vector<std::int8_t> species(n);
  std::vector<std::int64_t> id(n);
  for (int i = 0; i < n; ++i) {
    const bool rbc = i < spec.rbcs;
    species[i] = rbc ? 0 : 1;
    id[i] = i + 1;
    r0[i] = (rbc ? 0.8 : 0.95) * R * std::sqrt(u(rng));
    theta[i] = 2 * pi * u(rng);
    z0[i] = L * u(rng);
  }
  if (surface_vessel(scene.vessel)) return write_surface_run(dir, scene, spec, species, id, rng);

  const hid_t f = H5Fcreate((fs::path(dir) / "particles.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) throw std::runtime_error("cannot create particles.h5 in " + dir);
  const hid_t root = H5Gcreate2(f, "snapshots", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const long steps_per_snapshot = spec.steps_per_snapshot;
  for (int s = 0; s < spec.snapshots; ++s) {
    const double t = s * spec.dt_s;
    const double progress = spec.snapshots > 1 ? static_cast<double>(s) / (spec.snapshots - 1) : 0;
    std::vector<double> pos(3 * n), vel(3 * n);
    for (int i = 0; i < n; ++i) {
      // Platelets drift outward (margination), everybody moves axially with a Poiseuille speed.
      double r = r0[i];
      if (species[i] == 1) r += spec.drift * progress * (0.95 * R - r);
      const double vz = 0.01 * (1 - (r / R) * (r / R));
      pos[3 * i + 0] = r * std::cos(theta[i]);
      pos[3 * i + 1] = r * std::sin(theta[i]);
      pos[3 * i + 2] = z0[i] + vz * t;
      vel[3 * i + 2] = vz;
    }
    write_snapshot(root, s * steps_per_snapshot, t, id, species, pos, vel);
  }
  H5Gclose(root);
  H5Fclose(f);

  // The fluid node's metrics: mean velocity a little below Poiseuille's (as with cells in it).
  const double poiseuille_mean = scene.driving.wall_shear_rate * scene.vessel.diameter / 8;
  std::ofstream m(fs::path(dir) / "metrics.csv");
  m << "step,time_s,node,name,value\n";
  const long last = std::max(1L, static_cast<long>(spec.snapshots - 1) * steps_per_snapshot);
  for (long k = 1; k <= last; ++k) {
    const double t = k * spec.dt_s / steps_per_snapshot;
    m << fmt::format("{},{:.9g},fluid,mean_velocity_m_s,{:.9g}\n", k, t, poiseuille_mean / 1.3);
    m << fmt::format("{},{:.9g},fluid,wall_shear_stress_Pa,{:.9g}\n", k, t,
                     scene.plasma.viscosity * scene.driving.wall_shear_rate);
  }
}

ScratchDir::ScratchDir(const std::string& name)
    : path_((fs::temp_directory_path() / fmt::format("hemo-studies-{}-{}", ::getpid(), name)).string()) {
  fs::remove_all(path_);
  fs::create_directories(path_);
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

const char* const kSmallBaseScene = R"(# a small base scene
[run]
name = "base"
seed = 3

[vessel]
diameter_um = 40
length_um = 60

[mesh]        # cells larger than a red cell (unresolved coupling; the paper's 1,536 would be 3.7 um)
core_cells = 2
ring_cells = 2
axial_cells = 6

[driving]
wall_shear_rate_per_s = 800

[rbc]
hematocrit = 0.1

[platelet]
number_density_per_ul = 300000

[time]
coupling_interval_s = 1e-5
coupling_steps = 100
)";

}  // namespace hemo::studytest
