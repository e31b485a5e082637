// hemocosim-particles: the particle node of a hemocosim run (LIGGGHTS 3.8 DEM of red cells and
// platelets, coupled in lockstep to the fluid node over the run's message bus).
//
//   hemocosim-particles --scene FILE --run-dir DIR --run-id ID --lcm-url URL --secret-file FILE
// SPDX-License-Identifier: GPL-3.0-or-later
#include "particle_node.h"

#include <CLI/CLI.hpp>
#include <mpi.h>
#include <node_port.h>
#include <scene.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <memory>
#include <string>

namespace {

constexpr const char* kProgram = "hemocosim-particles (LIGGGHTS 3.8)";

struct MpiSession {
  MpiSession(int* argc, char*** argv) { MPI_Init(argc, argv); }
  ~MpiSession() { MPI_Finalize(); }
  int size() const {
    int n = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &n);
    return n;
  }
};

std::string one_line(std::string text) {
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

// Tells the coordinator why this node stops, and says it on stderr; the exit code is 1.
int failed(hemo::ParticlePort& port, const std::string& why) {
  const std::string line = one_line(why);
  spdlog::error("step {}: {}", port.step(), line);
  port.fail(line);
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  MpiSession mpi(&argc, &argv);
  CLI::App app{"hemocosim particle node: LIGGGHTS DEM of red cells and platelets, coupled to the fluid node"};
  std::string scene_path, run_dir;
  hemo::RunContext ctx;
  app.add_option("--scene", scene_path, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  app.add_option("--run-dir", run_dir, "Run directory (particles.h5, liggghts.log)")->required();
  ctx.add_options(app);
  CLI11_PARSE(app, argc, argv);
  if (mpi.size() > 1) {
    std::cerr << "hemocosim-particles: error: runs on one MPI rank for now (got " << mpi.size() << ")\n";
    return 2;
  }

  hemo::Scene scene;
  std::unique_ptr<hemo::ParticlePort> port;
  try {
    scene = hemo::load_scene(scene_path);
    ctx.load_secret();
    port = std::make_unique<hemo::ParticlePort>(ctx, "particles", kProgram);
  } catch (const std::exception& e) {
    std::cerr << "hemocosim-particles: error: " << one_line(e.what()) << "\n";
    return 1;
  }

  try {
    const hemo::mesh_t mesh = port->initialize();
    hemo::particles::ParticleNode node(scene, mesh, run_dir, MPI_COMM_WORLD);
    hemo::particle_feedback_t feedback = node.feedback();
    hemo::Diagnostics diagnostics = node.diagnostics();

    while (auto step = port->advance(feedback, diagnostics)) {
      if (auto why = node.check(step->fluid); !why.empty()) return failed(*port, why);
      if (auto why = node.advance(step->order, step->fluid); !why.empty()) return failed(*port, why);
      feedback = node.feedback();
      if (step->order.write_output) node.write_output(node.step(), node.time());
      diagnostics = node.diagnostics();
    }

    node.write_output(node.step(), node.time());  // the final state (kept once if already written)
    port->finalize();
  } catch (const std::exception& e) {
    return failed(*port, e.what());
  }
  return 0;
}
