// hemocosim-particles: the particle node of a hemocosim run (LIGGGHTS 3.8 DEM of red cells and
// platelets, coupled in lockstep to the fluid node over the run's message bus).
//
//   hemocosim-particles --scene FILE --run-dir DIR --run-id ID --lcm-url URL --secret-file FILE
//                       [--ranks N] [--resume-step K]
//
// With --ranks N > 1 the node re-executes itself under mpirun; rank 0 talks to the bus and
// broadcasts what it receives (ranked_port.h), every rank runs its share of the DEM.
// With --resume-step K the node starts from DIR/checkpoints/step-K/particles (written on the
// same number of ranks) and its first report is the feedback of step K.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "liggghts_errors.h"
#include "mpi_launch.h"
#include "particle_node.h"
#include "ranked_port.h"

#include <mpi.h>
#include <node_port.h>
#include <scene.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include <cstdlib>
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
  int rank() const {
    int r = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &r);
    return r;
  }
};

std::string one_line(std::string text) {
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

// Tells the coordinator why this node stops (rank 0), and says it on stderr; the exit code is 1.
// Every rank leaves the bus.
int failed(hemo::particles::RankedPort& port, const std::string& why) {
  const std::string line = one_line(why);
  if (port.rank() == 0) spdlog::error("step {}: {}", port.step(), line);
  port.fail(line);
  return 1;
}

// A failure every rank agrees on: the node stops (its last snapshot stays in particles.h5).
int stop(hemo::particles::RankedPort& port, const std::string& why) {
  hemo::particles::disarm_liggghts_exit();
  return failed(port, why);
}

// A problem only some ranks see (an exception in the middle of a collective step) cannot be
// agreed on: say it and take the whole job down.
[[noreturn]] void abort_job(hemo::particles::RankedPort* port, const std::string& why) {
  if (port) failed(*port, why);
  std::cerr << "hemocosim-particles: error: " << one_line(why) << std::endl;
  MPI_Abort(MPI_COMM_WORLD, 1);
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  if (const int code = hemo::particles::relaunch_as_mpi_job(argc, argv)) return code;
  MpiSession mpi(&argc, &argv);
  CLI::App app{"hemocosim particle node: LIGGGHTS DEM of red cells and platelets, coupled to the fluid node"};
  std::string scene_path, run_dir;
  hemo::RunContext ctx;
  app.add_option("--scene", scene_path, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  app.add_option("--run-dir", run_dir, "Run directory (particles.h5, liggghts.log)")->required();
  ctx.add_options(app);
  CLI11_PARSE(app, argc, argv);
  if (ctx.ranks > 1 && mpi.size() != ctx.ranks) {
    if (mpi.rank() == 0)
      std::cerr << "hemocosim-particles: error: asked for " << ctx.ranks << " MPI ranks, running on " << mpi.size()
                << "\n";
    return 2;
  }
  // Plain text: under mpirun the output is a pseudo-terminal, and the log file would get colour
  // codes (which the coordinator's one-line errors quote).
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("", std::make_shared<spdlog::sinks::stdout_sink_mt>()));
  if (mpi.rank() != 0) spdlog::set_level(spdlog::level::warn);  // rank 0 speaks for the node

  hemo::Scene scene;
  std::unique_ptr<hemo::particles::RankedPort> port;
  try {
    scene = hemo::load_scene(scene_path);
    ctx.load_secret();
    port = std::make_unique<hemo::particles::RankedPort>(MPI_COMM_WORLD, ctx, [&] {
      return std::make_unique<hemo::ParticlePort>(ctx, "particles", kProgram, mpi.size(),
                                                  scene.coupling_scheme == hemo::CouplingScheme::parallel);
    });
  } catch (const std::exception& e) {
    if (mpi.rank() == 0) std::cerr << "hemocosim-particles: error: " << one_line(e.what()) << "\n";
    return 1;
  }

  // LIGGGHTS ends the process itself on a fatal error: still tell the coordinator why.
  hemo::particles::report_liggghts_exit({run_dir + "/liggghts.log.steps", run_dir + "/liggghts.log"},
                                        [&](const std::string& why) { failed(*port, why); });
  try {
    const hemo::mesh_t mesh = port->initialize();
    hemo::particles::ParticleNode node(scene, mesh, run_dir, MPI_COMM_WORLD, ctx.resume_step);
    if (port->partitioned())
      node.use_overlap(port->start_exchange(mesh, node.sub_domain(), node.exchange_margin(), ctx,
                                            scene.load_balance != hemo::LoadBalance::none));
    hemo::particle_feedback_t feedback = node.feedback();
    hemo::Diagnostics diagnostics = node.diagnostics();
    // dem.load_balance: after the feedback of a step the scene names, the slabs may move; the
    // overlap map of both nodes follows from the next step's state on (DOMAIN of that step).
    long balances = 0;
    const auto follow_boxes = [&](std::int64_t step) {
      if (!hemo::load_balance_after(scene, static_cast<long>(step - 1))) return;
      const bool moved = node.balance();
      if (auto map = port->publish_boxes(node.sub_domain(), node.exchange_margin(), step, moved)) {
        node.follow_overlap(*map);
        ++balances;
      }
    };

    while (auto step = port->advance(feedback, diagnostics, follow_boxes)) {
      if (auto why = node.check(step->fluid); !why.empty()) return stop(*port, why);
      if (auto why = node.advance(step->order, step->fluid); !why.empty()) return stop(*port, why);
      feedback = node.feedback();
      if (step->order.write_output) node.write_output(node.step(), node.time());
      if (step->order.write_checkpoint) node.write_checkpoint();  // acknowledged in the diagnostics
      diagnostics = node.diagnostics();
      if (scene.load_balance != hemo::LoadBalance::none) {  // one rank: nothing to move, 1
        diagnostics.emplace_back("load_balance_moves", static_cast<double>(balances));
        diagnostics.emplace_back("particle_rank_imbalance", node.particle_imbalance());
      }
    }

    node.write_output(node.step(), node.time());  // the final state (kept once if already written)
    hemo::particles::disarm_liggghts_exit();
    port->finalize();
  } catch (const hemo::particles::CheckpointError& e) {  // every rank knows it: a clean stop
    return stop(*port, e.what());
  } catch (const hemo::particles::ExchangeError& e) {  // likewise
    return stop(*port, e.what());
  } catch (const std::exception& e) {
    hemo::particles::disarm_liggghts_exit();
    if (mpi.size() > 1) abort_job(port.get(), e.what());
    return failed(*port, e.what());
  }
  return 0;
}
