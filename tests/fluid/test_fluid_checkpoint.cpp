// Checkpoints of the fluid node (docs/design.md "Checkpoint, restart, swap"): the real
// hemocosim-fluid, serial and on 2 ranks, under a small driver in this test that plays the
// coordinator and the particle node over the real bus (orders, prescribed feedback, STEP_DONE).
//
// A run writes checkpoint K and goes on to step L; a copy of its run directory is resumed from
// K (--resume-step K) and driven through the same steps with the same feedback. The published
// fields and diagnostics of every step after K must be the uninterrupted run's, bit for bit:
// the checkpoint holds the state in binary and the node's computation is deterministic, so
// anything short of exact equality means a piece of state was lost.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "fluid_run.h"

#include <bus.h>
#include <cell_fields.h>
#include <checkpoint.h>
#include <node_port.h>
#include <partition_exchange.h>
#include <rank_exchange.h>
#include <run_files.h>

#include <hemo/hello_t.hpp>
#include <hemo/step_done_t.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

using namespace hemo::fluidtest;
namespace fs = std::filesystem;

namespace {

double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Feedback the driver hands the fluid for a step (as a particle node would after that step).
using Prescription = std::function<hemo::particle_feedback_t(const hemo::mesh_t&, long step, double time_s)>;

// A moving solid-fraction blob (peak 0.25 on 0.1, sigma 12 um, 15 um off the axis, 5 cm/s along
// the axis) with drag K and an explicit source S that follow it: the flow changes every step
// and depends on alpha, its old time, K and S.
hemo::particle_feedback_t moving_blob(const hemo::mesh_t& mesh, long /*step*/, double time_s) {
  const int n = mesh.n_cells;
  const double L = mesh.vessel_length_m, sigma = 12e-6;
  const double zb = std::fmod(0.5 * L + 0.05 * time_s, L);
  hemo::particle_feedback_t fb;
  fb.mesh_hash = mesh.mesh_hash;
  hemo::resize_cells(fb, n);
  for (int c = 0; c < n; ++c) {
    const auto& x = mesh.cell_centres[static_cast<std::size_t>(c)];
    double dz = x[2] - zb;
    dz -= L * std::round(dz / L);
    const double blob = std::exp(-((x[0] - 15e-6) * (x[0] - 15e-6) + x[1] * x[1] + dz * dz) / (2 * sigma * sigma));
    fb.solid_fraction[static_cast<std::size_t>(c)] = 0.1 + 0.25 * blob;
    fb.drag_coefficient[static_cast<std::size_t>(c)] = 1e6 * blob;
    double* s = hemo::source_of(fb, static_cast<std::size_t>(c));
    s[0] = 2e3 * blob, s[1] = 0.0, s[2] = 1e4 * blob;
  }
  for (double& f : fb.total_particle_force) f = 0;
  return fb;
}

// What the driver asks of one run of the node.
struct Drive {
  std::string scene_file;
  std::string run_dir;
  int ranks = 1;
  long first = 0;  // the step the node starts at (> 0: --resume-step)
  long last = 0;   // the last step ordered
  double dt = 0;
  long output_every = 0;       // write_output every this many steps (0: never)
  std::set<long> checkpoints;  // steps ordered with write_checkpoint
  Prescription feedback = moving_blob;
  // The program run: the launcher, or (with the environment it would give) the solver itself.
  std::string program = "hemocosim-fluid";
};

// What the node published.
struct Published {
  std::map<long, hemo::fluid_state_t> states;
  std::map<long, std::map<std::string, double>> diagnostics;  // STEP_DONE's, per step
  std::string failure;                                        // a STEP_DONE with ok = false
  long failed_at = -1;
  hemo::test::CommandResult command;
  bool complete = false;             // every ordered step done and the node exited
  std::optional<hemo::mesh_t> mesh;  // as the node published it
};

std::string shell_quoted(const std::string& s) { return "'" + s + "'"; }

// Runs hemocosim-fluid under the driver: orders first+1 .. last, hands it the feedback of the
// step before each order, records what it publishes, then orders it to stop.
Published drive(const Drive& d) {
  std::random_device rd;
  hemo::RunContext ctx;
  ctx.run_id = "fluid-ckpt-" + std::to_string(rd() % 1000000);
  ctx.lcm_url =
      "udpm://239.255.78." + std::to_string(1 + rd() % 250) + ":" + std::to_string(20000 + rd() % 40000) + "?ttl=0";
  ctx.secret.resize(32);
  for (auto& b : ctx.secret) b = static_cast<std::uint8_t>(rd());
  ctx.secret_file = d.run_dir + ".secret";
  std::filesystem::remove(ctx.secret_file);
  hemo::create_private_file(ctx.secret_file, ctx.secret);  // the node reads only a private secret
  ctx.retry_s = 1;

  // Listen before the node starts (its first reports must be heard), and say hello as a particle
  // node of one rank would: the fluid waits for it (its rank count decides the exchange).
  hemo::Bus bus(ctx, "coordinator");
  hemo::hello_t hello{};
  hello.role = "particles";
  hello.program = "the test's driver";
  hello.ranks = 1;
  bus.publish(hemo::channel::hello, hello, 0, /*keep=*/true);
  std::string command = (d.program == "hemocosim-fluid"
                             ? ""
                             : "WM_PROJECT_DIR=/usr/share/openfoam FOAM_ETC=/usr/share/openfoam/etc ") +
                        bin(d.program) + " --scene " + shell_quoted(d.scene_file) + " --run-dir " +
                        shell_quoted(d.run_dir) + " --run-id " + ctx.run_id + " --lcm-url " +
                        shell_quoted(ctx.lcm_url) + " --secret-file " + shell_quoted(ctx.secret_file) +
                        " --timeout 60 --ranks " + std::to_string(d.ranks);
  if (d.first > 0) command += " --resume-step " + std::to_string(d.first);
  auto process = std::async(std::launch::async, [command] { return run(command); });
  auto exited = [&] { return process.wait_for(std::chrono::seconds(0)) == std::future_status::ready; };

  Published out;
  std::optional<hemo::mesh_t> mesh;
  std::optional<hemo::fluid_decomposition_t> partition;
  auto poll = [&] {
    bus.poll(0.05, [&](const hemo::Received& m) {
      if (m.kind == hemo::channel::mesh && !mesh) mesh = m.as<hemo::mesh_t>();
      if (m.kind == hemo::channel::partition && !partition) partition = m.as<hemo::fluid_decomposition_t>();
      if (m.kind == hemo::channel::fluid_state) out.states[m.envelope.step] = m.as<hemo::fluid_state_t>();
      if (m.kind == hemo::channel::step_done) {
        const auto done = m.as<hemo::step_done_t>();
        if (done.node != "fluid") return;
        if (!done.ok && out.failure.empty()) {
          out.failure = done.error;
          out.failed_at = m.envelope.step;
        }
        if (done.ok && !out.diagnostics.count(m.envelope.step)) {
          auto& diag = out.diagnostics[m.envelope.step];
          for (std::size_t i = 0; i < done.names.size(); ++i) diag[done.names[i]] = done.values[i];
        }
      }
    });
  };
  // Waits until `ready`, asking again for what is missing; false if the node failed or left.
  auto await = [&](const std::function<bool()>& ready, const std::function<void()>& ask) {
    const double start = seconds_now();
    double asked = start;
    while (!ready()) {
      poll();
      if (!out.failure.empty() || exited() || seconds_now() - start > 120) return false;
      if (seconds_now() - asked > ctx.retry_s) {
        ask();
        asked = seconds_now();
      }
    }
    return true;
  };

  // Two fluid ranks: the state comes by partition (common/rank_exchange.h), to this driver as to a
  // particle node of one rank whose box is the mesh's.
  std::unique_ptr<hemo::ParticleRankReceiver> partitions;
  std::unique_ptr<hemo::ParticleRankPublisher> partials;  // the feedback, back to each fluid rank
  bool ok = d.ranks == 1 ||
            await([&] { return mesh && partition; },
                  [&] {
                    if (!mesh) bus.request_resend(hemo::channel::mesh, 0);
                    if (!partition) bus.request_resend(hemo::channel::partition, 0);
                  });
  if (ok && d.ranks > 1) {
    hemo::ParticleDecomposition one;
    one.boxes = {{hemo::particles::Vec3::Constant(-1), hemo::particles::Vec3::Constant(1)}};  // all of it, in metres
    hemo::particle_domain_t domain = hemo::domain_message(mesh->mesh_hash, one);
    bus.publish(hemo::channel::domain, domain, 0, /*keep=*/true);
    const auto map = hemo::overlap_map(hemo::cell_points_of(*mesh), hemo::fluid_decomposition_of(*partition, *mesh), one,
                                       hemo::period_of(*mesh));
    partitions = std::make_unique<hemo::ParticleRankReceiver>(ctx, 0, 1, d.ranks, map.from[0], mesh->mesh_hash,
                                                              mesh->n_cells, 120.0);
    partials = std::make_unique<hemo::ParticleRankPublisher>(ctx, 0, 1, d.ranks, map.from[0]);
  }
  // The state of step k, as the node published it.
  auto have_state = [&](long k) {
    if (partitions && !out.states.count(k))
      if (auto s = partitions->receive_within(k, 0.0)) out.states[k] = std::move(*s);
    return out.states.count(k) > 0;
  };
  ok = ok && await([&] { return mesh && out.diagnostics.count(d.first) && have_state(d.first); },
                   [&] {
                     if (!mesh) bus.request_resend(hemo::channel::mesh, 0);
                     bus.request_resend(hemo::channel::step_done, d.first);
                     if (!partitions) bus.request_resend(hemo::channel::fluid_state, d.first);
                   });
  long k = d.first + 1;
  for (; ok && k <= d.last; ++k) {
    hemo::step_order_t order{};
    order.time_s = static_cast<double>(k) * d.dt;
    order.dt_s = d.dt;
    order.write_output = d.output_every > 0 && k % d.output_every == 0;
    order.write_checkpoint = d.checkpoints.count(k) > 0;
    order.stop = false;
    bus.publish(hemo::channel::step, order, k, /*keep=*/true);
    auto fb = d.feedback(*mesh, k - 1, static_cast<double>(k - 1) * d.dt);
    if (partials)
      partials->publish(fb, k - 1);
    else
      bus.publish(hemo::channel::particle_feedback, fb, k - 1, /*keep=*/true);
    ok = await([&] { return out.diagnostics.count(k) && have_state(k); },
               [&] {
                 bus.request_resend(hemo::channel::step_done, k);
                 if (!partitions) bus.request_resend(hemo::channel::fluid_state, k);
               });
    bus.forget_before(k - 1);
  }
  if (ok) {
    hemo::step_order_t stop{};
    stop.time_s = static_cast<double>(d.last) * d.dt;
    stop.stop = true;
    bus.publish(hemo::channel::step, stop, d.last + 1, /*keep=*/true);
  }
  // Answer late resend requests until the node is gone.
  const double start = seconds_now();
  while (!exited() && seconds_now() - start < 120) poll();
  out.command = process.get();
  out.complete = ok && out.command.exit_code == 0;
  out.mesh = mesh;
  return out;
}

// The run `a` drove, driven again from its checkpoint of step K in a copy of its run directory,
// writing no checkpoints of its own.
Published resume_copy(const Drive& a, const std::string& name, long K) {
  Drive b = a;
  b.run_dir = fresh_run_dir(name + "-resumed-" + std::to_string(K));
  fs::copy(a.run_dir, b.run_dir, fs::copy_options::recursive);
  b.first = K;
  b.checkpoints = {};
  return drive(b);
}

// Per-step difference of two runs' published states: max |du| and max |dG|, over the steps of
// `b` from `from` on (all must be in `a`).
struct Difference {
  double velocity = 0, gradient = 0, time = 0;
  double velocity_scale = 0;
  long steps = 0;
};

Difference compare_states(const Published& a, const Published& b, long from) {
  Difference d;
  for (const auto& [k, sb] : b.states) {
    if (k < from) continue;
    const auto it = a.states.find(k);
    if (it == a.states.end()) {
      ADD_FAILURE() << "step " << k << " is not in the uninterrupted run";
      continue;
    }
    const auto& sa = it->second;
    EXPECT_EQ(sa.n_cells, sb.n_cells);
    if (sa.n_cells != sb.n_cells) continue;
    ++d.steps;
    d.time = std::max(d.time, std::abs(sa.time_s - sb.time_s));
    for (std::size_t i = 0; i < sa.velocity.size(); ++i) {
      d.velocity = std::max(d.velocity, std::abs(sa.velocity[i] - sb.velocity.at(i)));
      d.velocity_scale = std::max(d.velocity_scale, std::abs(sa.velocity[i]));
    }
    for (std::size_t i = 0; i < sa.velocity_gradient.size(); ++i)
      d.gradient = std::max(d.gradient, std::abs(sa.velocity_gradient[i] - sb.velocity_gradient.at(i)));
  }
  return d;
}

// Diagnostics of the steps of `b` after `after` that differ from `a`'s (wall-clock phase times
// aside), as "step k: name a != b" lines.
std::vector<std::string> differing_diagnostics(const Published& a, const Published& b, long after) {
  std::vector<std::string> out;
  for (const auto& [k, db] : b.diagnostics) {
    if (k <= after) continue;
    const auto& da = a.diagnostics.at(k);
    std::set<std::string> names;
    for (const auto& [n, v] : da) names.insert(n);
    for (const auto& [n, v] : db) names.insert(n);
    for (const auto& n : names) {
      // Timings and bytes (*_B: heartbeats and resends) differ from run to run.
      if (n.rfind("phase_", 0) == 0 || n == hemo::kCheckpointDiagnostic ||
          (n.size() > 2 && n.substr(n.size() - 2) == "_B"))
        continue;
      const auto ia = da.find(n), ib = db.find(n);
      if (ia == da.end() || ib == db.end() || !(ia->second == ib->second)) {
        std::ostringstream line;
        line.precision(17);
        line << "step " << k << ": " << n << " " << (ia == da.end() ? NAN : ia->second)
             << " != " << (ib == db.end() ? NAN : ib->second);
        out.push_back(line.str());
      }
    }
  }
  return out;
}

// The OpenFOAM time directories in a case folder: name -> value.
std::map<double, std::string> time_dirs(const std::string& folder) {
  std::map<double, std::string> out;
  if (!fs::is_directory(folder)) return out;
  for (const auto& e : fs::directory_iterator(folder)) {
    if (!e.is_directory()) continue;
    const std::string name = e.path().filename().string();
    try {
      std::size_t used = 0;
      const double t = std::stod(name, &used);
      if (used == name.size()) out[t] = name;
    } catch (const std::exception&) {
    }
  }
  return out;
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The case folders that hold output: RUN_DIR/fluid, or its processor folders.
std::vector<std::string> output_folders(const std::string& run_dir, int ranks) {
  if (ranks == 1) return {run_dir + "/fluid"};
  std::vector<std::string> out;
  for (int r = 0; r < ranks; ++r) out.push_back(run_dir + "/fluid/processor" + std::to_string(r));
  return out;
}

SceneSpec small_scene(const std::string& name, double dt) {
  SceneSpec s;
  s.name = name;
  s.core = 4;
  s.ring = 3;
  s.axial = 4;
  s.dt = dt;
  s.steps = 1000;
  return s;
}

std::string write_scene(const SceneSpec& s, const std::string& run_dir) {
  const std::string file = run_dir + ".toml";
  fs::create_directories(fs::path(run_dir).parent_path());
  std::ofstream(file) << s.text();
  return file;
}

// Two-way moving blob: K = 5, L = 10, output every 2 steps; resume a copy from 5.
void resumed_equals_uninterrupted(int ranks) {
  constexpr long K = 5, L = 10;
  const std::string tag = ranks == 1 ? "serial" : std::to_string(ranks) + "-ranks";
  const std::string whole = fresh_run_dir("fluid-checkpoint-" + tag);
  const SceneSpec scene = small_scene("fluid-checkpoint-" + tag, 1e-4);

  Drive a;
  a.scene_file = write_scene(scene, whole);
  a.run_dir = whole;
  a.ranks = ranks;
  a.last = L;
  a.dt = scene.dt;
  a.output_every = 2;
  a.checkpoints = {K};
  const Published pa = drive(a);
  ASSERT_TRUE(pa.complete) << pa.failure << "\n" << pa.command.output;

  // The acknowledgement: step K's report, and only it, says checkpoint_step = K, and the
  // checkpoint is complete.
  for (const auto& [k, diag] : pa.diagnostics) {
    const auto it = diag.find(hemo::kCheckpointDiagnostic);
    if (k == K) {
      ASSERT_NE(it, diag.end()) << "step " << K << " acknowledges its checkpoint";
      EXPECT_EQ(it->second, double(K));
    } else {
      EXPECT_EQ(it, diag.end()) << "step " << k << " acknowledges no checkpoint";
    }
  }
  EXPECT_NO_THROW(hemo::checkpoint_of(whole, K, "fluid"));
  EXPECT_FALSE(fs::exists(hemo::checkpoint_folder(whole, K) + "/fluid.partial"));

  // A copy of the finished run, with marks: an output time before K (must be kept as it is), one
  // after K (must be dropped and written again), and a later one no step writes (must go).
  const std::string parts = fresh_run_dir("fluid-checkpoint-" + tag + "-resumed");
  fs::copy(whole, parts, fs::copy_options::recursive);
  const double tK = K * scene.dt;
  std::vector<fs::path> kept_marks, dropped_marks, stale;
  for (const auto& folder : output_folders(parts, ranks)) {
    const auto times = time_dirs(folder);
    ASSERT_GE(times.size(), 4u) << folder;
    for (const auto& [t, name] : times) {
      if (t > 0 && t < tK) kept_marks.push_back(fs::path(folder) / name / "mark");
      if (t > tK) dropped_marks.push_back(fs::path(folder) / name / "mark");
    }
    const fs::path later = fs::path(folder) / "0.0015";
    fs::copy(fs::path(folder) / times.rbegin()->second, later, fs::copy_options::recursive);
    stale.push_back(later);
  }
  ASSERT_FALSE(kept_marks.empty());
  ASSERT_FALSE(dropped_marks.empty());
  for (const auto& m : kept_marks) std::ofstream(m) << "kept\n";
  for (const auto& m : dropped_marks) std::ofstream(m) << "dropped\n";

  Drive b = a;
  b.run_dir = parts;
  b.first = K;
  b.checkpoints = {K + 3};  // a resumed run writes checkpoints too
  const Published pb = drive(b);
  ASSERT_TRUE(pb.complete) << pb.failure << "\n" << pb.command.output;
  EXPECT_EQ(pb.diagnostics.at(K + 3).count(hemo::kCheckpointDiagnostic), 1u);
  EXPECT_NO_THROW(hemo::checkpoint_of(parts, K + 3, "fluid"));
  EXPECT_NE(pb.command.output.find("resumed from checkpoint 5"), std::string::npos) << pb.command.output;

  // The first report after the resume is step K's, with its state and no diagnostics (as
  // step 0 of a fresh run: the coordinator already has K's).
  EXPECT_EQ(pb.states.begin()->first, K);
  EXPECT_TRUE(pb.diagnostics.at(K).empty());
  const Difference diff = compare_states(pa, pb, K);
  const auto differing = differing_diagnostics(pa, pb, K);
  std::printf(
      "fluid checkpoint (%s, moving blob 4/3/4, dt = 1e-4 s): resumed from step %ld, steps %ld..%ld vs "
      "uninterrupted: max |du| = %.3e m/s (max |u| %.3e), max |dG| = %.3e 1/s, max |dt| = %.3e s; "
      "%zu of the diagnostics differ\n",
      tag.c_str(), K, K, L, diff.velocity, diff.velocity_scale, diff.gradient, diff.time, differing.size());
  EXPECT_EQ(diff.steps, L - K + 1);
  EXPECT_EQ(diff.velocity, 0.0) << "bit for bit";
  EXPECT_EQ(diff.gradient, 0.0) << "bit for bit";
  EXPECT_EQ(diff.time, 0.0);
  for (const auto& line : differing) ADD_FAILURE() << line;

  // Output: earlier times kept untouched, later ones written again (the same bytes as the
  // uninterrupted run's), times after the end gone; the case was neither rewritten nor
  // decomposed again (the marks before K are still there).
  for (const auto& m : kept_marks) EXPECT_TRUE(fs::exists(m)) << m;
  for (const auto& m : dropped_marks) EXPECT_FALSE(fs::exists(m)) << m;
  for (const auto& s : stale) EXPECT_FALSE(fs::exists(s)) << s;
  const auto folders_a = output_folders(whole, ranks), folders_b = output_folders(parts, ranks);
  for (std::size_t i = 0; i < folders_a.size(); ++i) {
    const auto ta = time_dirs(folders_a[i]), tb = time_dirs(folders_b[i]);
    EXPECT_EQ(ta, tb) << folders_b[i];
    const std::string last = ta.rbegin()->second;
    for (const auto* field : {"U", "p", "phi", "alpha", "K", "S"})
      EXPECT_EQ(read_text(fs::path(folders_a[i]) / last / field), read_text(fs::path(folders_b[i]) / last / field))
          << folders_b[i] << "/" << last << "/" << field;
  }
}

// A short two-way run with checkpoint 2 and output every step, for the failure tests.
struct ShortRun {
  Drive drive;
  Published published;
};

ShortRun short_run(const std::string& name, int ranks) {
  ShortRun r;
  const SceneSpec scene = small_scene(name, 1e-4);
  r.drive.run_dir = fresh_run_dir(name);
  r.drive.scene_file = write_scene(scene, r.drive.run_dir);
  r.drive.ranks = ranks;
  r.drive.last = 4;
  r.drive.dt = scene.dt;
  r.drive.output_every = 1;
  r.drive.checkpoints = {2};
  r.published = drive(r.drive);
  return r;
}

// Every file under a folder with its size and modification time: what "nothing lost" compares.
std::map<std::string, std::pair<std::uintmax_t, fs::file_time_type>> listing(const std::string& folder) {
  std::map<std::string, std::pair<std::uintmax_t, fs::file_time_type>> out;
  for (const auto& e : fs::recursive_directory_iterator(folder))
    if (e.is_regular_file()) out[e.path().string()] = {e.file_size(), e.last_write_time()};
  return out;
}

// A resume that cannot start: a one-line reason in the node's STEP_DONE for the resumed step and
// on its stderr, exit status != 0, and the run's output as it was.
void expect_refused_resume(const ShortRun& run, const std::string& dir, long step, const std::string& reason) {
  const auto before = listing(dir + "/fluid");
  Drive d = run.drive;
  d.run_dir = dir;
  d.first = step;
  d.checkpoints = {};
  const Published p = drive(d);
  std::printf("resume from step %ld (%d rank%s): exit %d, \"%s\"\n", step, d.ranks, d.ranks > 1 ? "s" : "",
              p.command.exit_code, p.failure.c_str());
  EXPECT_NE(p.command.exit_code, 0) << p.command.output;
  EXPECT_EQ(p.failed_at, step) << p.command.output;
  EXPECT_NE(p.failure.find(reason), std::string::npos) << p.failure;
  EXPECT_EQ(p.failure.find('\n'), std::string::npos) << "one line: " << p.failure;
  EXPECT_NE(p.command.output.find("hemocosim-fluid: error: " + p.failure), std::string::npos) << p.command.output;
  EXPECT_TRUE(p.states.empty()) << "no state published";
  EXPECT_EQ(listing(dir + "/fluid"), before) << "the output is kept as it was";
}

// A one-way scene (the fluid ignores the feedback) that becomes steady and stops solving
// (fluid.skip_when_steady): checkpoints while it still solves and once it no longer does.
void resumed_steady_run_equals_the_uninterrupted_run(int ranks) {
  constexpr long K1 = 10, K2 = 70, L = 80;
  const std::string tag = ranks == 1 ? "serial" : std::to_string(ranks) + "-ranks";
  SceneSpec scene = small_scene("fluid-checkpoint-one-way-" + tag, 2e-4);
  scene.extra = "[coupling]\ntwo_way = false\n\n[fluid]\nskip_when_steady = true\n";
  Drive a;
  a.run_dir = fresh_run_dir(scene.name);
  a.scene_file = write_scene(scene, a.run_dir);
  a.ranks = ranks;
  a.last = L;
  a.dt = scene.dt;
  a.output_every = 20;
  a.checkpoints = {K1, K2};
  const Published pa = drive(a);
  ASSERT_TRUE(pa.complete) << pa.failure << "\n" << pa.command.output;
  ASSERT_EQ(pa.diagnostics.at(K1 + 1).at("fluid_solved"), 1) << "still solving after the first checkpoint";
  ASSERT_EQ(pa.diagnostics.at(K2).at("fluid_solved"), 0) << "steady at the second checkpoint";
  ASSERT_EQ(pa.diagnostics.at(K2).at(hemo::kCheckpointDiagnostic), double(K2));
  EXPECT_EQ(pa.diagnostics.at(K2 + 1).count(hemo::kCheckpointDiagnostic), 0u)
      << "a republished step does not acknowledge the earlier checkpoint again";

  for (const long K : {K1, K2}) {
    const Published pb = resume_copy(a, scene.name, K);
    ASSERT_TRUE(pb.complete) << pb.failure << "\n" << pb.command.output;
    const Difference diff = compare_states(pa, pb, K);
    const auto differing = differing_diagnostics(pa, pb, K);
    std::printf(
        "fluid checkpoint (%s, one-way, steady skip): resumed from step %ld (%s), steps %ld..%ld: max |du| = "
        "%.3e m/s, max |dG| = %.3e 1/s; %zu of the diagnostics differ; fluid_solves at the end %.0f vs %.0f\n",
        tag.c_str(), K, K == K1 ? "still solving" : "steady", K, L, diff.velocity, diff.gradient, differing.size(),
        pb.diagnostics.at(L).at("fluid_solves"), pa.diagnostics.at(L).at("fluid_solves"));
    EXPECT_EQ(diff.steps, L - K + 1);
    EXPECT_EQ(diff.velocity, 0.0);
    EXPECT_EQ(diff.gradient, 0.0);
    EXPECT_EQ(diff.time, 0.0);
    for (const auto& line : differing) ADD_FAILURE() << line;
  }
}

// metrics.csv rows of one node, but the wall-clock ones (the ranks' too) and the bytes (*_B: heartbeats and resends
// vary from run to run): "step,time,node,name" -> value text.
std::map<std::string, std::string> node_rows(const std::string& run_dir, const std::string& node, int& repeats) {
  std::ifstream in(run_dir + "/metrics.csv");
  std::map<std::string, std::string> out;
  repeats = 0;
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    const auto value_at = line.rfind(',');
    const std::string key = line.substr(0, value_at);
    if (key.find("," + node + ",") == std::string::npos) continue;
    auto ends_with = [&](const std::string& tail) {
      return key.size() >= tail.size() && key.compare(key.size() - tail.size(), tail.size(), tail) == 0;
    };
    // Every rank's timings too (rank<r>_compute_s, ...).
    if (ends_with("compute_s") || ends_with("wait_s") ||
        key.find(",phase_") != std::string::npos || key.find(",checkpoint_step") != std::string::npos ||
        key.compare(key.size() - 2, 2, "_B") == 0)
      continue;
    if (out.count(key)) ++repeats;
    out[key] = line.substr(value_at + 1);
  }
  return out;
}

// Through the coordinator, with hemocosim-prescribed-particles (the moving blob of
// FluidContinuity): `hemocosim run --stop-after-step 5` and `hemocosim resume` against the run
// in one go. The fluid state the particle node received last and every fluid metric are the
// same to the last digit, each step's metrics written once.
void coordinator_resume_equals_one_go(int ranks) {
  const std::string tag = ranks == 1 ? "serial" : std::to_string(ranks) + "-ranks";
  SceneSpec s = small_scene("fluid-resume-" + tag, 1e-4);
  s.steps = 10;
  s.every_steps = 2;
  s.particle_command = bin("hemocosim-prescribed-particles") +
                       " --mode blob --phi 0.1 --blob-phi 0.3 --blob-sigma-um 12 --blob-x-um 15 "
                       "--blob-speed-m-s 0.05 --record state.csv";
  const std::string ranks_cli = ranks > 1 ? "--np-fluid " + std::to_string(ranks) : "";
  const auto whole = run_scene(s, ranks_cli);
  ASSERT_EQ(whole.command.exit_code, 0) << whole.command.output;
  s.name += "-parts";
  const auto parts = run_scene(s, ranks_cli + " --stop-after-step 5");
  ASSERT_EQ(parts.command.exit_code, 0) << parts.command.output;
  EXPECT_NE(parts.command.output.find("its last checkpoint is step 5"), std::string::npos) << parts.command.output;
  const auto resumed = run(bin("hemocosim") + " resume " + parts.dir);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_NE(resumed.output.find("resumes from step 5"), std::string::npos) << resumed.output;

  const auto a = read_state(whole.dir + "/state.csv"), b = read_state(parts.dir + "/state.csv");
  ASSERT_EQ(a.size(), b.size());
  double du = 0, dg = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) du = std::max(du, std::abs(a[i].u[k] - b[i].u[k]));
    for (int k = 0; k < 9; ++k) dg = std::max(dg, std::abs(a[i].grad[k] - b[i].grad[k]));
  }
  int repeats_a = 0, repeats_b = 0;
  const auto rows_a = node_rows(whole.dir, "fluid", repeats_a), rows_b = node_rows(parts.dir, "fluid", repeats_b);
  long differing = 0;
  for (const auto& [key, value] : rows_a) {
    const auto it = rows_b.find(key);
    if (it == rows_b.end() || it->second != value) {
      ++differing;
      ADD_FAILURE() << key << ": " << value << " in one go, " << (it == rows_b.end() ? "none" : it->second)
                    << " resumed";
    }
  }
  std::printf(
      "hemocosim run --stop-after-step 5 + resume (%s) vs one go, 10 steps: max |du| = %.3e, max |dG| = %.3e "
      "at the end; %zu fluid metrics, %ld differ, %d written twice\n",
      tag.c_str(), du, dg, rows_a.size(), differing, repeats_b);
  EXPECT_EQ(du, 0.0);
  EXPECT_EQ(dg, 0.0);
  EXPECT_EQ(rows_a.size(), rows_b.size());
  EXPECT_EQ(repeats_a, 0);
  EXPECT_EQ(repeats_b, 0) << "each step's fluid metrics once";
}

// fluid.solve_every = n (fluid-node/fluidStep.H): the moving blob with its drag and source
// scaled by 1 + (step mod 4), so that a block's mean feedback is not its latest.
hemo::particle_feedback_t pulsing_blob(const hemo::mesh_t& mesh, long step, double time_s) {
  hemo::particle_feedback_t fb = moving_blob(mesh, step, time_s);
  const double f = 1.0 + static_cast<double>(step % 4);
  for (double& k : fb.drag_coefficient) k *= f;
  for (double& v : fb.source_explicit) v *= f;
  return fb;
}

// sum_c S_z V_c of the feedback of step `step` (what a fluid step that applies it sees as
// source_force_z_N).
double source_z(const hemo::mesh_t& mesh, long step, double dt) {
  const auto fb = pulsing_blob(mesh, step, static_cast<double>(step) * dt);
  double sum = 0;
  for (std::size_t c = 0; c < fb.drag_coefficient.size(); ++c) sum += hemo::source_of(fb, c)[2] * mesh.cell_volumes[c];
  return sum;
}

struct SolveEveryRun {
  SceneSpec scene;
  Drive drive;
  Published published;
};

SolveEveryRun solve_every_run(const std::string& name, int n, long last, std::set<long> checkpoints, int ranks = 1) {
  SolveEveryRun r;
  r.scene = small_scene(name, 1e-4);
  r.scene.extra = "[fluid]\nsolve_every = " + std::to_string(n) + "\n";
  r.drive.run_dir = fresh_run_dir(name);
  r.drive.scene_file = write_scene(r.scene, r.drive.run_dir);
  r.drive.ranks = ranks;
  r.drive.last = last;
  r.drive.dt = r.scene.dt;
  r.drive.output_every = 2;
  r.drive.checkpoints = std::move(checkpoints);
  r.drive.feedback = pulsing_blob;
  r.published = drive(r.drive);
  return r;
}

}  // namespace

// fluid.solve_every = 3, two-way, 10 steps: the fluid solves at steps 3, 6 and 9 only, each a
// step of 3 intervals; the steps in between publish the last solved state bit for bit with their
// own time. Each solve applies the mean of its block's three feedbacks: its source_force_z_N is
// the mean of sum S_z V over the feedbacks of steps m-3..m-1 (computed here from the
// prescription, not the latest's), and its applied_source_*, the mean exchange at U_seen, is the
// mean of the received_source_* the node reported for the block's steps: the fluid gets the
// momentum the particles handed over, over the block. Its momentum budget closes with the
// fluid step's dt.
TEST(FluidSolveEvery, SolvesEveryNthStepOnTheBlocksMeanFeedback) {
  constexpr int n = 3;
  constexpr long L = 10;
  const SolveEveryRun r = solve_every_run("fluid-solve-every-3", n, L, {});
  const Published& p = r.published;
  ASSERT_TRUE(p.complete) << p.failure << "\n" << p.command.output;
  ASSERT_TRUE(p.mesh);
  const double dt = r.scene.dt;
  long last_solve = 0;
  double worst_applied = 0, worst_source = 0, worst_budget = 0, latest_gap = 0;
  for (long k = 1; k <= L; ++k) {
    const auto& d = p.diagnostics.at(k);
    const bool solves = k % n == 0;
    EXPECT_EQ(d.at("fluid_solved"), solves ? 1.0 : 0.0) << "step " << k;
    EXPECT_EQ(d.at("fluid_solves"), double(k / n)) << "step " << k;
    EXPECT_NEAR(p.states.at(k).time_s, static_cast<double>(k) * dt, 1e-9 * dt) << "step " << k;
    if (!solves) {
      EXPECT_EQ(p.states.at(k).velocity, p.states.at(last_solve).velocity) << "step " << k << " republishes";
      EXPECT_EQ(p.states.at(k).velocity_gradient, p.states.at(last_solve).velocity_gradient) << "step " << k;
      EXPECT_EQ(d.at("applied_source_z_N"), 0.0) << "step " << k;
      continue;
    }
    EXPECT_NE(p.states.at(k).velocity, p.states.at(last_solve).velocity) << "step " << k << " solves";
    EXPECT_DOUBLE_EQ(d.at("fluid_step_s"), n * dt);
    // The node's own report of each interval's exchange, against what its step applied
    // (relative to the largest component: y is round-off of a near-zero sum).
    double mean[3] = {0, 0, 0}, scale = 0;
    const char* axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      for (long m = k - n + 1; m <= k; ++m)
        mean[a] += p.diagnostics.at(m).at(std::string("received_source_") + axes[a] + "_N") / n;
      scale = std::max(scale, std::abs(mean[a]));
    }
    for (int a = 0; a < 3; ++a)
      worst_applied =
          std::max(worst_applied, std::abs(d.at(std::string("applied_source_") + axes[a] + "_N") - mean[a]) / scale);
    latest_gap = std::max(latest_gap, std::abs(d.at("received_source_z_N") - mean[2]) / std::abs(mean[2]));
    // The source in the momentum equation, against the prescription's feedbacks of the block
    // (the node received feedback k-1 with order k).
    double source = 0;
    for (long m = k - n; m <= k - 1; ++m) source += source_z(*p.mesh, m, dt) / n;
    worst_source = std::max(worst_source, std::abs(d.at("source_force_z_N") - source) / std::abs(source));
    const double forces = std::max(std::abs(d.at("driving_force_z_N")), std::abs(d.at("source_force_z_N")));
    worst_budget = std::max(worst_budget, std::abs(d.at("momentum_budget_residual_z_N")) / forces);
    last_solve = k;
  }
  std::printf(
      "fluid.solve_every = %d (4/3/4, dt = 1e-4 s, %ld steps): applied_source vs the block's mean received_source: "
      "max rel %.3e (the latest interval's differs by %.3e); source_force_z vs the block's mean prescribed source: "
      "max rel %.3e; momentum budget residual / largest force %.3e\n",
      n, L, worst_applied, latest_gap, worst_source, worst_budget);
  EXPECT_LT(worst_applied, 1e-12);
  EXPECT_LT(worst_source, 1e-12);
  EXPECT_LT(worst_budget, 1e-6);
  EXPECT_GT(latest_gap, 0.05) << "the test's feedback must make the mean differ from the latest";
}

namespace {

// A checkpoint inside a fluid step (step 4 of the block 4..6) and one at its end (step 6):
// resumed from either, the run publishes the uninterrupted one's states and diagnostics bit for
// bit (the block's collected feedback is in the checkpoint). On 2 ranks from step 4 only.
void solve_every_resumed_equals_uninterrupted(int ranks, const std::vector<long>& from) {
  constexpr int n = 3;
  constexpr long L = 10;
  const std::string tag = ranks == 1 ? "" : "-" + std::to_string(ranks) + "-ranks";
  const SolveEveryRun r = solve_every_run("fluid-solve-every-checkpoint" + tag, n, L, {4, 6}, ranks);
  const Published& pa = r.published;
  ASSERT_TRUE(pa.complete) << pa.failure << "\n" << pa.command.output;
  for (const long K : from) {
    const Published pb = resume_copy(r.drive, r.scene.name, K);
    ASSERT_TRUE(pb.complete) << pb.failure << "\n" << pb.command.output;
    const Difference diff = compare_states(pa, pb, K);
    const auto differing = differing_diagnostics(pa, pb, K);
    std::printf(
        "fluid.solve_every = %d (%d rank%s) resumed from step %ld (%s a fluid step), steps %ld..%ld: max |du| = "
        "%.3e m/s, max |dG| = %.3e 1/s; %zu of the diagnostics differ\n",
        n, ranks, ranks > 1 ? "s" : "", K, K % n ? "inside" : "at the end of", K, L, diff.velocity, diff.gradient,
        differing.size());
    EXPECT_EQ(diff.steps, L - K + 1);
    EXPECT_EQ(diff.velocity, 0.0) << "bit for bit";
    EXPECT_EQ(diff.gradient, 0.0) << "bit for bit";
    EXPECT_EQ(diff.time, 0.0);
    EXPECT_EQ(pb.diagnostics.at(L).at("fluid_solves"), 3.0);
    for (const auto& line : differing) ADD_FAILURE() << line;
  }
}

}  // namespace

TEST(FluidSolveEvery, ResumedInsideAndAtTheEndOfAFluidStepEqualsTheUninterruptedRun) {
  solve_every_resumed_equals_uninterrupted(1, {4, 6});
}

TEST(FluidSolveEvery, ResumedInsideAFluidStepOnTwoRanksEqualsTheUninterruptedRun) {
  solve_every_resumed_equals_uninterrupted(2, {4});
}

TEST(FluidCheckpoint, StoppedAndResumedRunEqualsTheRunInOneGo) { coordinator_resume_equals_one_go(1); }

TEST(FluidCheckpoint, StoppedAndResumedRunEqualsTheRunInOneGoOnTwoRanks) { coordinator_resume_equals_one_go(2); }

TEST(FluidCheckpoint, ResumeFromAMissingCheckpointIsRefused) {
  const ShortRun r = short_run("fluid-checkpoint-missing", 1);
  ASSERT_TRUE(r.published.complete) << r.published.command.output;
  expect_refused_resume(r, r.drive.run_dir, 3, "no fluid checkpoint of step 3 in " + r.drive.run_dir);
}

TEST(FluidCheckpoint, ResumeFromACorruptCheckpointIsRefused) {
  const ShortRun r = short_run("fluid-checkpoint-corrupt", 1);
  ASSERT_TRUE(r.published.complete) << r.published.command.output;
  const std::string checkpoint = hemo::checkpoint_of(r.drive.run_dir, 2, "fluid");
  // A field cut short, as a full disk would leave it.
  const fs::path U = fs::path(checkpoint) / time_dirs(checkpoint).begin()->second / "U";
  const std::string text = read_text(U);
  std::ofstream(U, std::ios::binary | std::ios::trunc) << text.substr(0, text.size() / 2);
  expect_refused_resume(r, r.drive.run_dir, 2, "cannot resume from " + checkpoint + ": ");
  // The dictionary of the run's extras missing.
  fs::remove(fs::path(checkpoint) / "state");
  expect_refused_resume(r, r.drive.run_dir, 2, "cannot resume from " + checkpoint + ": ");
}

// One rank's part cut short: every rank stops, the master names the rank and the cause.
TEST(FluidCheckpoint, ResumeFromACheckpointCorruptOnOneRankIsRefused) {
  const ShortRun r = short_run("fluid-checkpoint-corrupt-2-ranks", 2);
  ASSERT_TRUE(r.published.complete) << r.published.command.output;
  const std::string checkpoint = hemo::checkpoint_of(r.drive.run_dir, 2, "fluid");
  const fs::path rank1 = fs::path(checkpoint) / "processor1";
  const fs::path U = rank1 / time_dirs(rank1.string()).begin()->second / "U";
  const std::string text = read_text(U);
  std::ofstream(U, std::ios::binary | std::ios::trunc) << text.substr(0, text.size() / 2);
  expect_refused_resume(r, r.drive.run_dir, 2, "cannot resume from " + checkpoint + ": rank 1: ");
}

// A checkpoint of another rank count is redistributed by the launcher with OpenFOAM's own tools
// (reconstructPar, decomposePar; fluid-node/launcher.cpp) and the node goes on from it: a 2-rank
// checkpoint resumed serially, and a serial one on 2 ranks, publish the state of the resumed step
// and the steps after as the run that wrote it did, to the round-off of a decomposed solve (the
// state's values arrive unchanged; its gradient and the later steps sum in another order).
// Bound: 1e-9 of the largest velocity (FluidParallel's serial-against-2-rank agreement of a moving
// blob is 3e-7 of u_max over a whole run). The case follows the new count, and the scratch case
// is gone once read.
TEST(FluidCheckpoint, ACheckpointOfAnotherRankCountIsRedistributedAndGoesOn) {
  for (const auto& [from, to] : {std::pair<int, int>{2, 1}, {1, 2}}) {
    const ShortRun written = short_run("fluid-checkpoint-" + std::to_string(from) + "-ranks-to-" + std::to_string(to), from);
    ASSERT_TRUE(written.published.complete) << written.published.command.output;
    Drive d = written.drive;
    d.ranks = to;
    d.first = 2;
    d.checkpoints = {};
    const Published resumed = drive(d);
    ASSERT_TRUE(resumed.complete) << resumed.command.output;
    EXPECT_NE(resumed.command.output.find("redistributed onto " + std::to_string(to)), std::string::npos)
        << resumed.command.output;
    const Difference diff = compare_states(written.published, resumed, 2);
    std::printf("%d-rank checkpoint resumed on %d: steps 2-4, max |du| = %.3e of %.3e, max |dG| = %.3e\n", from, to,
                diff.velocity, diff.velocity_scale, diff.gradient);
    EXPECT_EQ(diff.steps, 3);
    EXPECT_EQ(diff.time, 0.0);
    EXPECT_GT(diff.velocity_scale, 0);
    EXPECT_LT(diff.velocity, 1e-9 * diff.velocity_scale);
    const std::string case_dir = d.run_dir + "/fluid";
    EXPECT_EQ(fs::is_directory(case_dir + "/processor1"), to == 2) << case_dir;
    EXPECT_FALSE(fs::exists(d.run_dir + "/fluid-redistributed"));
  }
}

// Without the launcher's redistribution (the solver started by itself), a checkpoint of another
// rank count is refused by the node, in one line, before anything is removed.
TEST(FluidCheckpoint, ACheckpointOfAnotherRankCountNotRedistributedIsRefused) {
  const ShortRun two = short_run("fluid-checkpoint-2-ranks-unredistributed", 2);
  ASSERT_TRUE(two.published.complete) << two.published.command.output;
  ShortRun serial = two;
  serial.drive.ranks = 1;
  serial.drive.program = "hemocosim-fluid-solver";
  expect_refused_resume(serial, two.drive.run_dir, 2,
                        "it was written by 2 fluid ranks, this run has 1, and its fields were not redistributed");
}

TEST(FluidCheckpoint, ResumedSteadyOneWayRunEqualsTheUninterruptedRun) {
  resumed_steady_run_equals_the_uninterrupted_run(1);
}

TEST(FluidCheckpoint, ResumedRunEqualsTheUninterruptedRunSerial) { resumed_equals_uninterrupted(1); }

TEST(FluidCheckpoint, ResumedRunEqualsTheUninterruptedRunOnTwoRanks) { resumed_equals_uninterrupted(2); }
