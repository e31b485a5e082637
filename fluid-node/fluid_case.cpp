// The fluid node's settings and case directory (see fluid_case.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_case.h"

#include <geometry.h>
#include <solid_fraction_names.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace hemo {
namespace {

std::string header(const char* cls, const char* location, const char* object) {
  std::string h =
      "/*--------------------------------*- C++ -*----------------------------------*\\\n"
      "  hemocosim fluid node case (written by hemocosim-fluid at start; do not edit)\n"
      "\\*---------------------------------------------------------------------------*/\n"
      "FoamFile\n{\n    version     2.0;\n    format      ascii;\n    class       ";
  h += cls;
  h += ";\n    location    \"";
  h += location;
  h += "\";\n    object      ";
  h += object;
  h += ";\n}\n\n";
  return h;
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::string control_dict(const FluidSettings& fluid) {
  std::string s = header("dictionary", "system", "controlDict");
  s += "application     hemocosim-fluid;\n"
       "startFrom       startTime;\n"
       "startTime       0;\n"
       "stopAt          endTime;\n"
       "endTime         1e30;           // the coordinator decides when to stop\n"
       "deltaT          " +
       num(fluid.dt) +
       ";  // coupling interval; each step order may change it\n"
       "writeControl    none;           // written only when the coordinator asks\n"
       "writeInterval   1;\n"
       "purgeWrite      0;\n"
       "writeFormat     ascii;\n"
       "writePrecision  12;\n"
       "writeCompression off;\n"
       "timeFormat      general;\n"
       "timePrecision   12;\n"
       "runTimeModifiable false;\n";
  return s;
}

std::string fv_schemes() {
  std::string s = header("dictionary", "system", "fvSchemes");
  s += "ddtSchemes\n{\n    default         Euler;\n}\n\n"
       "gradSchemes\n{\n    default         Gauss linear;\n}\n\n"
       "divSchemes\n{\n    default         none;\n    div(alphaPhi,U) Gauss linear;\n"
       "    div(transposedStress) Gauss linear;  // CFDEM's forms (coupling.momentum)\n}\n\n"
       "laplacianSchemes\n{\n    default         Gauss linear corrected;\n}\n\n"
       "interpolationSchemes\n{\n    default         linear;\n}\n\n"
       "snGradSchemes\n{\n    default         corrected;\n}\n";
  return s;
}

std::string pressure_solver(const std::string& name) {
  if (name == "PCG") return "        solver          PCG;\n        preconditioner  DIC;\n";
  if (name == "GAMG") return "        solver          GAMG;\n        smoother        GaussSeidel;\n";
  throw std::invalid_argument("unknown pressure solver '" + name + "' (GAMG or PCG)");
}

std::string fv_solution(const FluidSolver& solver) {
  std::string s = header("dictionary", "system", "fvSolution");
  s += "solvers\n{\n"
       "    p\n    {\n" +
       pressure_solver(solver.pressure_solver) + "        tolerance       " + num(solver.pressure_tolerance) +
       ";\n"
       "        relTol          " +
       num(solver.pressure_relative_tolerance) +
       ";\n    }\n"
       "    pFinal\n    {\n        $p;\n        relTol          0;\n    }\n"
       "    U\n    {\n        solver          GAMG;\n        smoother        symGaussSeidel;\n"
       "        tolerance       " +
       num(solver.velocity_tolerance) +
       ";\n"
       "        relTol          " +
       num(solver.velocity_relative_tolerance) +
       ";\n        maxIter         100;\n    }\n"
       "}\n\n"
       "PISO\n{\n    momentumPredictor " +
       (solver.momentum_predictor ? "yes" : "no") +
       ";\n"
       "    nCorrectors     " +
       std::to_string(solver.min_correctors) +
       ";\n"
       "    maxCorrectors   " +
       std::to_string(solver.max_correctors) +
       ";  // more correctors while the p residual is above:\n"
       "    correctorTolerance " +
       num(solver.corrector_tolerance) +
       ";\n"
       "    nNonOrthogonalCorrectors " +
       std::to_string(solver.non_orthogonal_correctors) +
       ";\n    pRefCell        0;\n    pRefValue       0;\n}\n";
  return s;
}

// A surface vessel's inlet (model/surface.h) faces any way: its profile is about the patch's
// area-weighted centre, the parabola R^2 - d^2 of its equivalent radius R = sqrt(A / pi) at the
// distance d from the line through the centre along the patch's normal, the velocity along the
// inward normal; scaled, as the O-grid's, to the faces' flux Q.
std::string surface_inlet_velocity(const FluidSettings& fluid, const PatchInfo& patch, const MeshGeometry& geometry) {
  using Profile = VesselInlet::Profile;
  if (fluid.inlet_profile == Profile::feeder)
    throw std::logic_error("a fed surface inlet is mapped, not a fixed profile");
  std::array<double, 3> sum{0, 0, 0}, centre{0, 0, 0};
  double area = 0;
  auto face_area = [&](int f) {
    const auto& a = geometry.face_areas[static_cast<std::size_t>(f)];
    return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  };
  for (int f = patch.start; f < patch.start + patch.size; ++f) {
    const double af = face_area(f);
    for (int c = 0; c < 3; ++c) {
      sum[static_cast<std::size_t>(c)] += geometry.face_areas[static_cast<std::size_t>(f)][static_cast<std::size_t>(c)];
      centre[static_cast<std::size_t>(c)] +=
          af * geometry.face_centres[static_cast<std::size_t>(f)][static_cast<std::size_t>(c)];
    }
    area += af;
  }
  const double norm = std::sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
  std::array<double, 3> inward{};
  for (int c = 0; c < 3; ++c) {
    inward[static_cast<std::size_t>(c)] = -sum[static_cast<std::size_t>(c)] / norm;
    centre[static_cast<std::size_t>(c)] /= area;
  }
  const double radius2 = area / 3.14159265358979323846;
  std::vector<double> profile;
  double profile_flux = 0;
  for (int f = patch.start; f < patch.start + patch.size; ++f) {
    const auto& x = geometry.face_centres[static_cast<std::size_t>(f)];
    std::array<double, 3> d{x[0] - centre[0], x[1] - centre[1], x[2] - centre[2]};
    const double along = d[0] * inward[0] + d[1] * inward[1] + d[2] * inward[2];
    const double off2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - along * along;
    profile.push_back(fluid.inlet_profile == Profile::flat ? 1.0 : std::max(0.0, radius2 - off2));
    // The flux through the face of a unit velocity along the inward normal.
    const auto& a = geometry.face_areas[static_cast<std::size_t>(f)];
    profile_flux -= profile.back() * (a[0] * inward[0] + a[1] * inward[1] + a[2] * inward[2]);
  }
  const double scale = fluid.inlet_flow_rate / profile_flux;
  std::string s = "        type            fixedValue;\n        value           nonuniform List<vector>\n" +
                  std::to_string(profile.size()) + "\n(\n";
  for (const double w : profile)
    s += "(" + num(scale * w * inward[0]) + " " + num(scale * w * inward[1]) + " " + num(scale * w * inward[2]) + ")\n";
  return s + ")\n;\n";
}

// The inlet's velocity, carrying fluid.inlet_flow_rate Q through the patch's faces (the mesh's
// section, a polygon: its area is not pi R^2). A mapped inlet (a feeder) takes the feeder's
// section, as it is (the feeder's own flow; Q / A is only its first value) or scaled by OpenFOAM
// to the mean velocity Q / A (setAverage); a fixed one its profile at the face centres, scaled to
// the faces' flux Q: the parabola R^2 - r^2 of the inlet's radius R, or a constant.
std::string inlet_velocity(const FluidSettings& fluid, const PatchInfo& patch, const MeshGeometry& geometry,
                           double inlet_radius) {
  using Profile = VesselInlet::Profile;
  double area = 0, profile_flux = 0;
  std::vector<double> profile;
  for (int f = patch.start; f < patch.start + patch.size; ++f) {
    const auto& a = geometry.face_areas[static_cast<std::size_t>(f)];
    const auto& c = geometry.face_centres[static_cast<std::size_t>(f)];
    const double face_area = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    profile.push_back(fluid.inlet_profile == Profile::flat
                          ? 1.0
                          : std::max(0.0, inlet_radius * inlet_radius - c[0] * c[0] - c[1] * c[1]));
    area += face_area;
    profile_flux += face_area * profile.back();
  }
  if (fluid.inlet_profile == Profile::feeder) {
    if (patch.type != "mappedPatch") throw std::logic_error("a feeder inlet needs the mesh's mapped inlet patch");
    const std::string mean = "(0 0 " + num(fluid.inlet_flow_rate / area) + ")";
    const std::string average = fluid.inlet_carries_q
                                    ? "        setAverage      true;\n        average         " + mean + ";\n"
                                    : "        setAverage      false;\n";
    return "        type            mapped;\n        field           U;\n" + average +
           "        interpolationScheme cell;\n"
           "        value           uniform " +
           mean + ";\n";
  }
  const double scale = fluid.inlet_flow_rate / profile_flux;
  std::string s = "        type            fixedValue;\n        value           nonuniform List<vector>\n" +
                  std::to_string(profile.size()) + "\n(\n";
  for (const double w : profile) s += "(0 0 " + num(scale * w) + ")\n";
  return s + ")\n;\n";
}

}  // namespace

FluidSettings fluid_settings(const Scene& scene) {
  FluidSettings f;
  f.density = scene.plasma.density;
  f.viscosity = scene.plasma.viscosity;
  if (!(f.density > 0) || !(f.viscosity > 0))
    throw std::invalid_argument("plasma density and viscosity must be positive");
  if (!(scene.vessel.length > 0) || !(scene.vessel.diameter > 0))
    throw std::invalid_argument("vessel diameter and length must be positive");
  f.kinematic_viscosity = f.viscosity / f.density;
  f.pressure_drop = driving_pressure_drop(scene);
  f.body_force = f.pressure_drop / (f.density * scene.vessel.length);
  f.momentum = momentum_form(scene.momentum);
  f.suspension = suspension_viscosity(scene.plasma.suspension_viscosity);
  f.publish_pressure_gradient = f.momentum.needs_pressure_gradient();
  f.publish_viscous_force = f.momentum.needs_viscous_force();
  f.publish_face_flux_velocity = scene.plasma_velocity == PlasmaVelocity::face_flux;
  f.open_ends = open_ends(scene.vessel);
  if (f.open_ends) {
    f.inlet_flow_rate = nominal_flow_rate(scene);
    f.inlet_profile = vessel_inlet(scene.vessel.inlet).profile;
    f.inlet_carries_q = vessel_inlet(scene.vessel.inlet).carries_q;
  }
  f.dt = scene.time.coupling_interval;
  if (!(f.dt > 0)) throw std::invalid_argument("time.coupling_interval must be positive");
  f.solver = scene.fluid;
  f.skip_when_steady = scene.fluid.skip_when_steady && !scene.two_way;
  // A kernel wider than the particles shares them over cells narrower than they are (the scene
  // checks the kernel against the cells): nothing to refuse here.
  if (!shares_over_kernel(scene.solid_fraction))
    for (const Species* s : {&scene.rbc, &scene.platelet})
      if (s->present) f.largest_particle_diameter = std::max(f.largest_particle_diameter, s->diameter);
  return f;
}

double poiseuille_velocity(const FluidSettings& fluid, const Vessel& vessel, double r) {
  const double R = vessel.radius();
  return fluid.pressure_drop / (4 * fluid.viscosity * vessel.length) * (R * R - r * r);
}

std::optional<std::string> unresolved_mesh_problem(const MeshGeometry& geometry, double largest_particle_diameter) {
  if (geometry.cell_volumes.empty() || !(largest_particle_diameter > 0)) return std::nullopt;
  const double v_min = *std::min_element(geometry.cell_volumes.begin(), geometry.cell_volumes.end());
  const double dx = std::cbrt(v_min);
  if (dx > largest_particle_diameter) return std::nullopt;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "mesh too fine for unresolved coupling: smallest cell size (cube root of volume) "
                "%.3g um is not larger than the largest particle diameter %.3g um (d_p/dx = %.2f >= 1); "
                "use fewer cells",
                dx * 1e6, largest_particle_diameter * 1e6, largest_particle_diameter / dx);
  return std::string(buf);
}

void write_case(const std::string& case_dir, const FluidSettings& fluid, const Vessel& vessel, const PolyMesh& mesh,
                const MeshGeometry& geometry, InitialFlow initial) {
  namespace fs = std::filesystem;
  const fs::path dir(case_dir);
  write_text(dir / "system" / "controlDict", control_dict(fluid));
  write_text(dir / "system" / "fvSchemes", fv_schemes());
  write_text(dir / "system" / "fvSolution", fv_solution(fluid.solver));
  write_polymesh(mesh, case_dir);

  // The feeder's cells, if any: a straight tube about its own axis (vessel_ends.h).
  const CellZone* feeder = nullptr;
  for (const auto& z : mesh.cell_zones)
    if (z.name == feeder_zone) feeder = &z;
  const bool surface = surface_vessel(vessel);
  const double inlet_radius = surface ? vessel.radius() : make_vessel_geometry(vessel)->radius_at(0);

  std::string u = header("volVectorField", "0", "U");
  u += "dimensions      [0 1 -1 0 0 0 0];\n\n";
  // A surface vessel starts at rest: the tube's profile means nothing in its branches.
  if (initial == InitialFlow::rest || surface) {
    u += "internalField   uniform (0 0 0);\n\n";
  } else {
    // The developed particle-free flow for the imposed pressure drop (in an open vessel: of the
    // inlet's flow rate, in the nominal tube).
    u += "internalField   nonuniform List<vector>\n" + std::to_string(geometry.cell_centres.size()) + "\n(\n";
    const Vessel feeder_tube{2 * inlet_radius, vessel.length};
    for (std::size_t i = 0; i < geometry.cell_centres.size(); ++i) {
      const auto& c = geometry.cell_centres[i];
      const int cell = static_cast<int>(i);
      const bool in_feeder = feeder != nullptr && cell >= feeder->first && cell < feeder->first + feeder->size;
      const double velocity =
          in_feeder ? poiseuille_velocity(fluid, feeder_tube, std::hypot(c[0] - feeder_axis_x(vessel), c[1]))
                    : poiseuille_velocity(fluid, vessel, std::hypot(c[0], c[1]));
      u += "(0 0 " + num(velocity) + ")\n";
    }
    u += ")\n;\n\n";
  }
  std::string p = header("volScalarField", "0", "p");
  p += "dimensions      [0 2 -2 0 0 0 0];  // kinematic: pressure / density\n\n"
       "internalField   uniform 0;\n\n";
  std::string u_patches, p_patches;
  auto entry = [](const std::string& name, const std::string& body) {
    return "    " + name + "\n    {\n" + body + "    }\n";
  };
  for (const auto& patch : mesh.patches) {
    if (patch.type == "wall") {
      u_patches += entry(patch.name, "        type            noSlip;\n");
      p_patches += entry(patch.name, "        type            zeroGradient;\n");
    } else if (patch.type == "cyclic") {
      u_patches += entry(patch.name, "        type            cyclic;\n");
      p_patches += entry(patch.name, "        type            cyclic;\n");
    } else if (patch.name == patch_name::inlet) {
      // (A fed surface vessel's inlet faces -z, as the O-grid's: the same mapped condition.)
      u_patches += entry(patch.name, surface && fluid.inlet_profile != VesselInlet::Profile::feeder
                                         ? surface_inlet_velocity(fluid, patch, geometry)
                                         : inlet_velocity(fluid, patch, geometry, inlet_radius));
      // The gradient that makes the face flux the fixed velocity's, with the momentum at the face
      // extrapolated from the inlet's cells (pEqn.H): the developed flow's own pressure gradient
      // where the inflow is developed. (zeroGradient, OpenFOAM's usual partner of a fixed
      // velocity, halves the first cells' pressure gradient: measured, it disturbs the first
      // 0.75 d by up to 0.35 % of u_max and adds 2 % to a 6 d tube's pressure drop.)
      p_patches += entry(patch.name,
                         "        type            fixedFluxExtrapolatedPressure;\n        gradient        uniform 0;\n"
                         "        value           uniform 0;\n");
    } else if (patch_name::is_outlet(patch.name)) {
      // inletOutlet, not zeroGradient: where the flow leaves (everywhere in the flows tested) it is
      // zeroGradient, the developed profile's own condition; should a recirculation (downstream
      // of a stenosis at higher Re) reach the outlet, the faces it enters through take u = 0
      // instead of an unbounded inflow extrapolated from inside.
      u_patches += entry(patch.name,
                         "        type            inletOutlet;\n        inletValue      uniform (0 0 0);\n"
                         "        value           uniform (0 0 0);\n");
      p_patches += entry(patch.name, "        type            fixedValue;\n        value           uniform 0;\n");
    } else {
      throw std::logic_error("no boundary condition for patch " + patch.name + " of type " + patch.type);
    }
  }
  u += "boundaryField\n{\n" + u_patches + "}\n";
  write_text(dir / "0" / "U", u);
  p += "boundaryField\n{\n" + p_patches + "}\n";
  write_text(dir / "0" / "p", p);
}

void write_decomposition(const std::string& case_dir, int ranks, const MeshSpec& mesh) {
  if (ranks < 2) throw std::invalid_argument("a decomposed fluid needs at least 2 ranks");
  if (const auto problem = fluid_ranks_problem(mesh, ranks)) throw std::invalid_argument(*problem);
  std::string s = header("dictionary", "system", "decomposeParDict");
  s += "numberOfSubdomains " + std::to_string(ranks) +
       ";\n\n"
       "// Whole cross-sections, split along the vessel axis.\n"
       "method          simple;\n\n"
       "coeffs\n{\n    n               (1 1 " +
       std::to_string(ranks) + ");\n}\n";
  write_text(std::filesystem::path(case_dir) / "system" / "decomposeParDict", s);
}

}  // namespace hemo
