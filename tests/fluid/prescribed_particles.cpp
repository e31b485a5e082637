// hemocosim-prescribed-particles: a stand-in particle node that publishes *prescribed* feedback,
// so the real fluid node can be driven and verified over the real bus without particles.
//
// It speaks the particle side of the protocol (hemo::ParticlePort): waits for the mesh, then
// publishes feedback for every step the coordinator orders. What it publishes (--mode):
//
//   none        phi = 0, K = 0, S = 0
//   uniform     phi = --phi everywhere
//   blob        phi = --phi + a Gaussian blob of peak --blob-phi and width --blob-sigma-um
//               centred at (--blob-x-um, 0, z0 + --blob-speed-m-s t), periodic in z; the blob
//               part is rescaled every step so that the total solid volume never changes
//   fill        phi rising linearly from 0 to --phi over --fill-time-s in the vessel's cells, 0 in
//               an open vessel's feeder: the vessel's solid volume grows, the feeder's does not
//   source      phi = --phi, explicit source S uniform per unit volume with total --force-N
//               (so that sum S V = F exactly), drag coefficient --drag-coefficient
//   nan         like none, but from --bad-at-step on the solid fraction of one cell is NaN
//   wrong-size  like none, but from --bad-at-step on the feedback has one cell too few
//   wrong-mesh  like none, but from --bad-at-step on the feedback names another mesh hash
//
// It reports, with each STEP_DONE, what it saw of the fluid (fluid_momentum_{x,y,z}_kg_m_s =
// sum rho (1 - phi) u V with the phi the fluid was given for that step, fluid_drag_{x,y,z}_N =
// sum K u V with the K it was given, fluid_time_s) and
// what it sent (solid_volume_m3, source_total_{x,y,z}_N), and with --relaxation-time-s a
// drag relaxation time (min_relaxation_time_s, read by the coordinator's adaptive clock; from
// --later-from-s on --relaxation-time-later-s instead). With --record FILE it writes the
// last fluid state it received, per cell, to RUN_DIR/FILE (CSV: cell, centre, volume, phi,
// u, grad u, grad P, div tau) for tests that need the fields.
//
// Its feedback is a function of the step and the options alone, so its checkpoint (written when
// an order asks, acknowledged with checkpoint_step like a real node's) is an empty folder: with
// --resume-step K it needs that folder and starts at step K. It lets the fluid node's
// checkpoints be tested through `hemocosim run --stop-after-step` and `hemocosim resume`.
//
// Use it from a scene:
//   [run] particle_command = "/path/to/hemocosim-prescribed-particles --mode blob --blob-phi 0.3"
// The coordinator appends --scene, --run-dir and the bus options.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <cell_fields.h>
#include <checkpoint.h>
#include <node_port.h>
#include <rank_exchange.h>
#include <scene.h>
#include <vessel_ends.h>

#include <CLI/CLI.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {

constexpr const char* kProgram = "hemocosim-prescribed-particles (test stand-in)";

enum class Mode { none, uniform, blob, fill, source, nan, wrong_size, wrong_mesh };

struct Options {
  Mode mode = Mode::none;
  double phi = 0;                        // uniform background solid fraction
  double blob_phi = 0.3;                 // peak of the moving blob
  double blob_sigma = 10e-6;             // m
  double blob_x = 10e-6;                 // m, off-axis position of the blob centre
  double blob_z0 = -1;                   // m, initial axial position (default: mid-length)
  double blob_speed = 0.05;              // m/s along z
  double fill_time = 1e-3;               // s, fill: time to reach --phi
  std::optional<hemo::FeederLayout> feeder;  // fill: an open vessel's feeder, whose cells stay at 0
  std::array<double, 3> force{0, 0, 0};  // N, total explicit source
  double drag_coefficient = 0;           // N s/m^4, uniform
  long bad_at_step = 1;                  // first step whose feedback is bad (bad modes)
  std::string record;                    // file (in the run dir) for the last fluid state received
  double relaxation_time = 0;            // s, reported as min_relaxation_time_s (0: not reported)
  double relaxation_time_later = 0;      // s, reported from later_from on (0: the same)
  double later_from = 0;                 // s
  // The relaxation time to report at the end of a step ending at time_s.
  std::optional<double> relaxation_at(double time_s) const {
    if (relaxation_time <= 0) return std::nullopt;
    return relaxation_time_later > 0 && time_s >= later_from ? relaxation_time_later : relaxation_time;
  }
};

std::string one_line(std::string text) {
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

// The feedback of one step, made from the options and the mesh.
class Prescription {
 public:
  Prescription(const Options& opt, const hemo::mesh_t& mesh) : opt_(opt), mesh_(mesh) {
    for (double v : mesh.cell_volumes) total_volume_ += v;
    if (opt_.blob_z0 < 0) opt_.blob_z0 = 0.5 * mesh.vessel_length_m;
    if (opt_.mode == Mode::blob) blob_volume_ = raw_blob_volume(0.0);
  }

  hemo::particle_feedback_t feedback(long step, double time_s) const {
    const int n = mesh_.n_cells;
    hemo::particle_feedback_t fb;
    fb.mesh_hash = mesh_.mesh_hash;
    hemo::resize_cells(fb, n);
    for (double& f : fb.total_particle_force) f = 0;

    if (opt_.mode == Mode::uniform || opt_.mode == Mode::blob || opt_.mode == Mode::source)
      fb.solid_fraction.assign(n, opt_.phi);
    if (opt_.mode == Mode::blob) {
      const std::vector<double> raw = raw_blob(time_s);
      double sum = 0;
      for (int c = 0; c < n; ++c) sum += raw[c] * mesh_.cell_volumes[c];
      const double scale = sum > 0 ? blob_volume_ / sum : 0.0;  // constant solid volume
      for (int c = 0; c < n; ++c) fb.solid_fraction[c] += scale * raw[c];
    }
    if (opt_.mode == Mode::fill) {
      const double phi = opt_.phi * std::min(1.0, time_s / opt_.fill_time);
      for (int c = 0; c < n; ++c)
        fb.solid_fraction[c] = opt_.feeder && opt_.feeder->in_feeder(mesh_.cell_centres[c][0]) ? 0.0 : phi;
    }
    if (opt_.mode == Mode::source) {
      for (int c = 0; c < n; ++c) {
        for (int d = 0; d < 3; ++d) hemo::source_of(fb, c)[d] = opt_.force[d] / total_volume_;
        fb.drag_coefficient[c] = opt_.drag_coefficient;
      }
      // The particles would feel minus what the fluid receives (at zero fluid velocity).
      for (int d = 0; d < 3; ++d) fb.total_particle_force[d] = -opt_.force[d];
    }

    if (step >= opt_.bad_at_step) {
      if (opt_.mode == Mode::nan) fb.solid_fraction[n / 2] = std::numeric_limits<double>::quiet_NaN();
      if (opt_.mode == Mode::wrong_size) {
        fb.n_cells = n - 1;
        fb.n_source_values = 3 * (n - 1);
        fb.solid_fraction.pop_back();
        fb.source_explicit.resize(static_cast<std::size_t>(fb.n_source_values));
        fb.drag_coefficient.pop_back();
      }
      if (opt_.mode == Mode::wrong_mesh) fb.mesh_hash = "0123456789abcdef";
    }
    return fb;
  }

  double total_volume() const { return total_volume_; }

 private:
  std::vector<double> raw_blob(double time_s) const {
    const double L = mesh_.vessel_length_m;
    const double zb = std::fmod(opt_.blob_z0 + opt_.blob_speed * time_s, L);
    std::vector<double> raw(static_cast<std::size_t>(mesh_.n_cells));
    for (int c = 0; c < mesh_.n_cells; ++c) {
      const auto& x = mesh_.cell_centres[c];
      double dz = x[2] - zb;
      dz -= L * std::round(dz / L);  // nearest periodic image
      const double d2 = (x[0] - opt_.blob_x) * (x[0] - opt_.blob_x) + x[1] * x[1] + dz * dz;
      raw[c] = opt_.blob_phi * std::exp(-d2 / (2 * opt_.blob_sigma * opt_.blob_sigma));
    }
    return raw;
  }
  double raw_blob_volume(double time_s) const {
    const auto raw = raw_blob(time_s);
    double sum = 0;
    for (int c = 0; c < mesh_.n_cells; ++c) sum += raw[c] * mesh_.cell_volumes[c];
    return sum;
  }

  Options opt_;
  const hemo::mesh_t& mesh_;
  double total_volume_ = 0;
  double blob_volume_ = 0;
};

// What this node saw of the fluid and what it sent, for STEP_DONE (and so metrics.csv).
hemo::Diagnostics diagnostics(const hemo::mesh_t& mesh, const hemo::particle_feedback_t& sent_before,
                              const hemo::particle_feedback_t& sent, const hemo::fluid_state_t* fluid, double density) {
  hemo::Diagnostics d;
  double solid = 0, source[3] = {0, 0, 0};
  const bool sized = sent.n_cells == mesh.n_cells;
  if (sized) {
    for (int c = 0; c < mesh.n_cells; ++c) {
      // Finite cells only: in --mode nan this node plays a corrupt sender whose report looks
      // clean (the coordinator's guards would otherwise stop the run on the report first), so
      // that the fluid node itself must refuse the NaN it receives.
      if (std::isfinite(sent.solid_fraction[c])) solid += sent.solid_fraction[c] * mesh.cell_volumes[c];
      for (int k = 0; k < 3; ++k) source[k] += hemo::source_of(sent, c)[k] * mesh.cell_volumes[c];
    }
  }
  d.push_back({"solid_volume_m3", solid});
  d.push_back({"source_total_x_N", source[0]});
  d.push_back({"source_total_y_N", source[1]});
  d.push_back({"source_total_z_N", source[2]});
  if (fluid != nullptr && fluid->n_cells == mesh.n_cells && sent_before.n_cells == mesh.n_cells) {
    // The fluid state of step k was computed with the feedback of step k-1.
    // Its momentum, and the implicit drag it felt at the velocity it reached (sum K u V).
    double p[3] = {0, 0, 0}, drag[3] = {0, 0, 0};
    for (int c = 0; c < mesh.n_cells; ++c) {
      const double V = mesh.cell_volumes[c];
      const double m = density * (1 - sent_before.solid_fraction[c]) * V;
      for (int k = 0; k < 3; ++k) {
        p[k] += m * hemo::velocity_of(*fluid, c)[k];
        drag[k] += sent_before.drag_coefficient[c] * hemo::velocity_of(*fluid, c)[k] * V;
      }
    }
    d.push_back({"fluid_momentum_x_kg_m_s", p[0]});
    d.push_back({"fluid_momentum_y_kg_m_s", p[1]});
    d.push_back({"fluid_momentum_z_kg_m_s", p[2]});
    d.push_back({"fluid_drag_x_N", drag[0]});
    d.push_back({"fluid_drag_y_N", drag[1]});
    d.push_back({"fluid_drag_z_N", drag[2]});
    d.push_back({"fluid_time_s", fluid->time_s});
  }
  return d;
}

void record_state(const std::string& path, const hemo::mesh_t& mesh, const hemo::fluid_state_t& fluid,
                  const hemo::particle_feedback_t& phi_source) {
  std::ofstream out(path);
  out.precision(17);
  out << "cell,x,y,z,volume,phi,ux,uy,uz,g00,g01,g02,g10,g11,g12,g20,g21,g22,gpx,gpy,gpz,fvx,fvy,fvz\n";
  for (int c = 0; c < fluid.n_cells && c < mesh.n_cells; ++c) {
    const auto& x = mesh.cell_centres[c];
    const double phi = phi_source.n_cells == mesh.n_cells ? phi_source.solid_fraction[c] : 0.0;
    out << c << ',' << x[0] << ',' << x[1] << ',' << x[2] << ',' << mesh.cell_volumes[c] << ',' << phi;
    for (int k = 0; k < hemo::kVectorValues; ++k) out << ',' << hemo::velocity_of(fluid, c)[k];
    for (int k = 0; k < hemo::kTensorValues; ++k) out << ',' << hemo::gradient_of(fluid, c)[k];
    // The pressure gradient and viscous force when the state carries them, else zeros.
    for (int k = 0; k < hemo::kVectorValues; ++k)
      out << ',' << (fluid.n_pressure_gradient_values > 0 ? hemo::pressure_gradient_of(fluid, c)[k] : 0.0);
    for (int k = 0; k < hemo::kVectorValues; ++k)
      out << ',' << (fluid.n_viscous_values > 0 ? hemo::viscous_force_of(fluid, c)[k] : 0.0);
    out << '\n';
  }
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "hemocosim-prescribed-particles: a particle node that publishes prescribed feedback "
      "(for verifying the fluid node over the real bus)"};
  Options opt;
  std::string scene_path, run_dir, force_text;
  hemo::RunContext ctx;
  const std::map<std::string, Mode> modes{{"none", Mode::none},
                                          {"uniform", Mode::uniform},
                                          {"blob", Mode::blob},
                                          {"fill", Mode::fill},
                                          {"source", Mode::source},
                                          {"nan", Mode::nan},
                                          {"wrong-size", Mode::wrong_size},
                                          {"wrong-mesh", Mode::wrong_mesh}};
  app.add_option("--mode", opt.mode, "What to publish")
      ->transform(CLI::CheckedTransformer(modes, CLI::ignore_case))
      ->capture_default_str();
  app.add_option("--phi", opt.phi, "Uniform solid fraction (uniform, blob, source)")->capture_default_str();
  app.add_option("--blob-phi", opt.blob_phi, "blob: peak solid fraction of the blob")->capture_default_str();
  double sigma_um = opt.blob_sigma * 1e6, x_um = opt.blob_x * 1e6, z0_um = -1;
  app.add_option("--blob-sigma-um", sigma_um, "blob: Gaussian width")->capture_default_str();
  app.add_option("--blob-x-um", x_um, "blob: distance of its path from the axis")->capture_default_str();
  app.add_option("--blob-z0-um", z0_um, "blob: axial position at t = 0 (default: mid-length)");
  app.add_option("--blob-speed-m-s", opt.blob_speed, "blob: axial speed")->capture_default_str();
  app.add_option("--fill-time-s", opt.fill_time, "fill: time for the vessel's solid fraction to reach --phi")
      ->capture_default_str();
  app.add_option("--force-N", force_text, "source: total explicit momentum source 'fx,fy,fz' in N");
  app.add_option("--drag-coefficient", opt.drag_coefficient, "source: uniform implicit drag coefficient, N s/m^4")
      ->capture_default_str();
  app.add_option("--bad-at-step", opt.bad_at_step, "nan, wrong-size, wrong-mesh: first bad step")
      ->capture_default_str();
  app.add_option("--relaxation-time-s", opt.relaxation_time, "Report this drag relaxation time (0: none)")
      ->capture_default_str();
  app.add_option("--relaxation-time-later-s", opt.relaxation_time_later, "... and this one from --later-from-s on");
  app.add_option("--later-from-s", opt.later_from, "When the later relaxation time starts");
  app.add_option("--record", opt.record, "Write the last fluid state received to RUN_DIR/FILE (CSV)");
  app.add_option("--scene", scene_path, "Scene file (TOML)")->required()->check(CLI::ExistingFile);
  app.add_option("--run-dir", run_dir, "Run directory")->required();
  ctx.add_options(app);
  CLI11_PARSE(app, argc, argv);
  opt.blob_sigma = sigma_um * 1e-6;
  opt.blob_x = x_um * 1e-6;
  if (z0_um >= 0) opt.blob_z0 = z0_um * 1e-6;
  if (!force_text.empty()) {
    std::stringstream ss(force_text);
    std::string item;
    for (int d = 0; d < 3; ++d) {
      if (!std::getline(ss, item, ',')) {
        std::cerr << "hemocosim-prescribed-particles: error: --force-N needs 'fx,fy,fz'\n";
        return 2;
      }
      opt.force[d] = std::stod(item);
    }
  }

  hemo::Scene scene;
  std::unique_ptr<hemo::ParticlePort> port;
  try {
    scene = hemo::load_scene(scene_path);
    if (hemo::fed_by_feeder(scene.vessel)) opt.feeder = hemo::feeder_layout(scene);
    // A fluid that follows moving slabs waits for the particle node's DOMAIN of each move, which
    // this stand-in never publishes: it would wait for ever.
    if (scene.load_balance != hemo::LoadBalance::none)
      throw std::runtime_error("dem.load_balance needs the real particle node: this stand-in publishes no moved slabs");
    ctx.load_secret();
    port = std::make_unique<hemo::ParticlePort>(ctx, "particles", kProgram, 1, scene.coupling_scheme == hemo::CouplingScheme::parallel);
  } catch (const std::exception& e) {
    std::cerr << "hemocosim-prescribed-particles: error: " << one_line(e.what()) << "\n";
    return 1;
  }

  try {
    const hemo::mesh_t mesh = port->initialize();
    std::cout << "hemocosim-prescribed-particles: mesh " << mesh.mesh_hash << ", " << mesh.n_cells << " cells"
              << std::endl;
    // Its end of the partitioned exchange when the fluid runs on more than one rank.
    const auto partitions = hemo::open_one_rank_particle_end(*port, mesh, ctx);
    const Prescription prescription(opt, mesh);
    const long first = ctx.resume_step;
    if (first > 0) hemo::checkpoint_of(run_dir, first, "particles");  // throws when there is none
    hemo::particle_feedback_t feedback =
        prescription.feedback(first, static_cast<double>(first) * scene.time.coupling_interval);
    hemo::particle_feedback_t previous = feedback;
    hemo::fluid_state_t last_fluid;
    bool have_fluid = false;
    // A resumed run's first report is of a step the coordinator has already recorded.
    hemo::Diagnostics diag;
    if (first == 0) diag = diagnostics(mesh, previous, feedback, nullptr, scene.plasma.density);
    if (const auto tau = opt.relaxation_at(0.0); tau && first == 0) diag.push_back({hemo::kRelaxationDiagnostic, *tau});

    auto advance = [&] {
      if (!partitions) return port->advance(feedback, diag);
      partitions->feedback->publish(feedback, port->step());
      auto step = port->advance_partitioned(diag);
      if (step)  // serving the port meanwhile: the fluid may be asking again for its report
        step->fluid =
            partitions->state->receive(step->order.envelope.step - port->fluid_lag(), [&] { port->serve(); });
      return step;
    };
    while (auto step = advance()) {
      const long k = step->order.envelope.step;
      last_fluid = std::move(step->fluid);
      have_fluid = true;
      previous = feedback;  // what the fluid used for this step
      feedback = prescription.feedback(k, step->order.time_s);
      diag = diagnostics(mesh, previous, feedback, &last_fluid, scene.plasma.density);
      if (const auto tau = opt.relaxation_at(step->order.time_s)) diag.push_back({hemo::kRelaxationDiagnostic, *tau});
      if (step->order.write_checkpoint) {
        hemo::begin_checkpoint(run_dir, k, "particles");
        hemo::commit_checkpoint(run_dir, k, "particles");
        diag.push_back({hemo::kCheckpointDiagnostic, static_cast<double>(k)});
      }
      std::cout << "step " << k << " t = " << step->order.time_s << std::endl;
    }

    if (have_fluid && !opt.record.empty()) {
      const std::string path = (std::filesystem::path(run_dir) / opt.record).string();
      record_state(path, mesh, last_fluid, previous);
      std::cout << "recorded the fluid state of t = " << last_fluid.time_s << " s in " << path << std::endl;
    }
    port->finalize();
  } catch (const std::exception& e) {
    const std::string line = one_line(e.what());
    std::cerr << "hemocosim-prescribed-particles: error: " << line << "\n";
    port->fail(line);
    return 1;
  }
  return 0;
}
