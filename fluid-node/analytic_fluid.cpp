// hemocosim-analytic-fluid: a fluid node that publishes an analytic flow instead of solving
// one. It speaks the fluid side of the protocol (hemo::FluidPort) on the same vessel mesh as
// hemocosim-fluid, so a scene can swap it in for one-way runs and particle tests:
//
//   [run] fluid_command = "<bindir>/hemocosim-analytic-fluid --flow poiseuille"
//
//   --flow poiseuille   u_z = dP/(4 mu l) (R^2 - r^2) from the scene's driving
//   --flow shear        u_z = u0 + rate x (--shear-rate, default the scene's wall shear rate;
//                       --shear-velocity u0, default 0)
//
// Per cell it publishes the flow's velocity and gradient at the cell centre (exact there;
// the particle node's linear reconstruction u_c + G (x - x_c) is then exact for shear and
// smaller than Poiseuille by a |x - x_c|^2 across the section). Particle feedback is checked
// (mesh, sizes, finite values) and its momentum source reported, but the flow never changes.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "analytic_flow.h"
#include "cell_fields.h"
#include "feedback_check.h"
#include "fluid_case.h"
#include "vessel_mesh.h"

#include <node_port.h>
#include <rank_exchange.h>
#include <scene.h>
#include <hemo/mesh_t.hpp>

#include <CLI/CLI.hpp>

#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <string>

namespace {

constexpr const char* kProgram = "hemocosim-analytic-fluid";

std::string one_line(std::string text) {
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hemocosim-analytic-fluid: a fluid node publishing an analytic flow (Poiseuille or linear shear)"};
  std::string scene_path, run_dir, flow_name = "poiseuille";
  double shear_rate = -1, shear_velocity = 0;
  hemo::RunContext ctx;
  app.add_option("--flow", flow_name, "poiseuille (from the scene's pressure drop) or shear")
      ->check(CLI::IsMember({"poiseuille", "shear"}))
      ->capture_default_str();
  app.add_option("--shear-rate", shear_rate, "shear: d u_z / d x in 1/s (default: the scene's wall shear rate)");
  app.add_option("--shear-velocity", shear_velocity, "shear: u_z on the axis in m/s")->capture_default_str();
  app.add_option("--scene", scene_path, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  app.add_option("--run-dir", run_dir, "Run directory")->required();
  ctx.add_options(app);
  CLI11_PARSE(app, argc, argv);

  std::unique_ptr<hemo::FluidPort> port;
  hemo::Scene scene;
  try {
    scene = hemo::load_scene(scene_path);
    ctx.load_secret();
    port = std::make_unique<hemo::FluidPort>(ctx, "fluid", kProgram);
  } catch (const std::exception& e) {
    std::cerr << kProgram << ": error: " << one_line(e.what()) << std::endl;
    return 1;
  }

  try {
    const hemo::FluidSettings fluid = hemo::fluid_settings(scene);
    // Its flows are the periodic vessel's: an open one has a feeder region and an entrance.
    if (fluid.open_ends) throw std::runtime_error("the analytic fluid runs periodic vessels only (vessel.ends)");
    const hemo::PolyMesh mesh = hemo::make_vessel_mesh(scene.vessel, scene.mesh);
    const hemo::MeshGeometry geometry = hemo::compute_geometry(mesh);
    hemo::mesh_t mesh_msg;
    hemo::fill_mesh_message(mesh, geometry, scene.vessel, mesh_msg);

    const hemo::AnalyticFlow flow =
        flow_name == "poiseuille"
            ? hemo::poiseuille_flow(fluid, scene.vessel)
            : hemo::shear_flow(shear_rate >= 0 ? shear_rate : scene.driving.wall_shear_rate, shear_velocity);
    std::cout << kProgram << ": " << flow_name << " flow on " << mesh.n_cells << " cells (mesh " << mesh_msg.mesh_hash
              << "), wall shear rate " << flow.wall_shear_rate() << " 1/s"
              << (ctx.ranks > 1 ? "; analytic, runs on one process whatever --ranks says" : "") << std::endl;

    // Volume averages of the published field, reported every step (they never change).
    double volume = 0, mean_uz = 0, max_u = 0;
    for (std::size_t c = 0; c < geometry.cell_volumes.size(); ++c) {
      const auto u = flow.velocity(geometry.cell_centres[c]);
      volume += geometry.cell_volumes[c];
      mean_uz += u[2] * geometry.cell_volumes[c];
      max_u = std::max(max_u, std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]));
    }
    mean_uz /= volume;

    port->initialize(mesh_msg);
    // Its end of the partitioned exchange when the particles run on more than one rank.
    const auto partitions = hemo::open_one_rank_fluid_end(*port, mesh_msg, ctx);
    hemo::fluid_state_t state;
    hemo::fill_state(flow, geometry, mesh_msg.mesh_hash, 0.0, state, fluid.publish_pressure_gradient,
                     fluid.publish_viscous_force);
    hemo::Diagnostics diag{{"time_s", 0.0}};

    auto advance = [&] {
      if (!partitions) return port->advance(state, diag);
      partitions->state->publish(state, port->step());
      auto step = port->advance_partitioned(diag);
      if (step)  // serving the port meanwhile: the particles may be asking again for its report
        step->feedback = partitions->feedback->receive(step->order.envelope.step - 1, [&] { port->serve(); });
      return step;
    };
    while (auto step = advance()) {
      const auto& fb = step->feedback;
      if (const std::string problem = hemo::feedback_problem(fb, mesh_msg.mesh_hash, mesh.n_cells); !problem.empty())
        throw std::runtime_error(problem);
      // The momentum the particles hand over, at the velocity they saw: sum (S - K u) V.
      double source[3] = {0, 0, 0};
      for (int c = 0; c < mesh.n_cells; ++c)
        for (int k = 0; k < 3; ++k)
          source[k] += (hemo::source_of(fb, c)[k] - fb.drag_coefficient[c] * hemo::velocity_of(state, c)[k]) *
                       geometry.cell_volumes[c];
      hemo::fill_state(flow, geometry, mesh_msg.mesh_hash, step->order.time_s, state, fluid.publish_pressure_gradient,
                       fluid.publish_viscous_force);
      diag = {{"time_s", step->order.time_s},     {"mean_velocity_m_s", mean_uz},
              {"max_velocity_m_s", max_u},        {"wall_shear_stress_Pa", fluid.viscosity * flow.wall_shear_rate()},
              {"received_source_x_N", source[0]}, {"received_source_y_N", source[1]},
              {"received_source_z_N", source[2]}};
    }
    port->finalize();
    std::cout << kProgram << ": finished" << std::endl;
  } catch (const std::exception& e) {
    const std::string line = one_line(e.what());
    std::cerr << kProgram << ": error: " << line << std::endl;
    port->fail(line);
    return 1;
  }
  return 0;
}
