// hemocosim check: validate a scene and say what it will run.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "commands.h"
#include "driving.h"
#include "feeder_develop.h"
#include "geometry.h"
#include "placement.h"
#include "resource_estimate.h"
#include "scene.h"
#include "units.h"
#include "vessel_ends.h"

#include <fmt/format.h>

#include <cmath>
#include <string>

namespace hemo {

int list_keys_command() {
  fmt::print("| key | default | allowed |\n|---|---|---|\n");
  for (const auto& k : scene_keys()) fmt::print("{}\n", k.table_row());
  return 0;
}

namespace {
// The disk and memory the scene will take (resource_estimate.h) against what this machine has:
// a warning above it, a refusal (false) above kAbsurdFactor times it.
bool print_resource_estimate(const Scene& s, long particles, const std::string& out_dir) {
  const ResourceEstimate e = estimate_resources(s, particles);
  const MachineRoom room = machine_room(out_dir);
  fmt::print(
      "  disk        ~{} in the run directory{}: particles.h5 {} ({} snapshots), fluid output {}, "
      "checkpoints {}, metrics.csv {}\n",
      bytes_text(e.disk_bytes()), s.time.adaptive_interval() ? " at least" : "", bytes_text(e.snapshots_bytes),
      e.outputs, bytes_text(e.fluid_output_bytes),
      e.checkpoint_bytes > 0 ? "2 x " + bytes_text(e.checkpoint_bytes) : "none", bytes_text(e.metrics_bytes));
  fmt::print("  memory      ~{} at peak: fluid {} x {}, particles {} x {} (per rank)\n", bytes_text(e.memory_bytes(s)),
             s.run.fluid_ranks, bytes_text(e.fluid_rank_bytes), s.run.particle_ranks,
             bytes_text(e.particle_rank_bytes));
  bool fits = true;
  auto judge = [&](const char* what, double needed, double has, const std::string& where) {
    if (has < 0 || needed <= has) return;
    const bool absurd = needed > kAbsurdFactor * has;
    fits &= !absurd;
    fmt::print("  {}     {} needs ~{} of {}, {} has {}{}\n", absurd ? "REFUSED" : "warning", s.run.name,
               bytes_text(needed), what, where, bytes_text(has),
               absurd
                   ? fmt::format(" (over {:g} times as much: fewer steps or particles, or output.every_steps larger)",
                                 kAbsurdFactor)
                   : "");
  };
  judge("disk", e.disk_bytes(), room.free_disk_bytes, room.disk_path);
  // Nodes on other hosts ([hosts]) take their memory there.
  if (!s.hosts.any()) judge("memory", e.memory_bytes(s), room.available_memory_bytes, "this host (MemAvailable)");
  return fits;
}
}  // namespace

int check_command(const std::string& scene_path, const std::string& out_dir) {
  if (scene_path.empty()) throw std::runtime_error("check needs a scene file (or --keys)");
  // Throws SceneError listing every problem, a run's too: the particles are placed here as the
  // particle node will place them at step 0 (SceneCheck::placement).
  const Scene s = load_scene(scene_path, SceneCheck::placement);
  // The counts the particle node places (model/placement.h).
  const long rbcs = particles::rbc_count(s), platelets = particles::platelet_count(s);
  fmt::print("{}: ok\n", scene_path);
  if (rbcs + platelets == 0 && s.run.particle_command.empty())
    fmt::print(
        "  particles   none: `hemocosim run` refuses it (the particle node has nothing to couple) unless "
        "run.particle_command names a stand-in\n");
  if (surface_vessel(s.vessel)) {
    const Surface surface = make_vessel_surface(s.vessel);
    const double cell = surface_cell_size(s);
    std::string regions;
    for (const auto& r : surface.region_names) regions += (regions.empty() ? "" : ", ") + r;
    fmt::print("  vessel      {}: a closed surface of {} triangles, {:.4g} um^3; regions {}; inlet d = {:.1f} um\n",
               s.vessel.shape, surface.triangles.size(), surface.volume() / (units::um * units::um * units::um),
               regions, s.vessel.diameter / units::um);
    fmt::print("  fluid mesh  snappyHexMesh, cubes of {:.3g} um snapped to the surface, made by the fluid node\n",
               cell / units::um);
  } else {
    fmt::print("  vessel      d = {:.1f} um, l = {:.1f} um, {} fluid cells\n", s.vessel.diameter / units::um,
               s.vessel.length / units::um, s.mesh.cells());
    if (const auto g = make_vessel_geometry(s.vessel); !g->uniform())
      fmt::print("  shape       {}: narrowest d = {:.1f} um; the DEM's wall a triangle mesh (vessel_wall.stl)\n",
                 s.vessel.shape, 2 * g->throat_radius() / units::um);
  }
  fmt::print("  driving     dP = {:.4g} Pa, wall shear rate {:.4g} 1/s\n", s.driving.pressure_drop,
             s.driving.wall_shear_rate);
  if (open_ends(s.vessel))
    fmt::print(
        "  ends        open: inlet {} {}, {} p = 0{}\n", s.vessel.inlet,
        vessel_inlet(s.vessel.inlet).carries_q
            ? fmt::format("at Q = {:.4g} m^3/s (the nominal tube's at that wall shear rate)", nominal_flow_rate(s))
            : std::string("at the feeder's own flow (the periodic tube's at dP)"),
        surface_vessel(s.vessel) ? "every outlet" : "outlet",
        fed_by_feeder(s.vessel) ? fmt::format("; a periodic feeder beside it ({} more fluid cells)",
                                              s.mesh.cells() / s.mesh.axial_cells * feeder_layout(s).layers)
                                : std::string());
  if (fed_by_feeder(s.vessel) && rbcs + platelets > 0)
    fmt::print(
        "  feeder      the same blood: the vessel starts with copies of its cells over its length, and each "
        "cell that crosses its end enters at the inlet (counts below: the vessel's nominal)\n");
  if (develops_feeder(s)) {
    const FeederLayout f = feeder_layout(s);
    fmt::print(
        "  developed   first the feeder alone, a periodic tube of {:.4g} x {:.4g} um, for {:g} s ({} steps, "
        "`hemocosim run` into RUN_DIR/{}); the run starts from its cells (vessel.feeder_develop_s)\n",
        2 * f.radius / units::um, f.period / units::um, s.vessel.feeder_develop, feeder_develop_steps(s),
        kFeederDevelopFolder);
  }
  fmt::print("  particles   {} RBCs, {} platelets{}\n", rbcs, platelets,
             rbcs + platelets == 0 ? std::string()
             : placement_checked(s)
                 ? fmt::format(", placed as the particle node will at step 0 (run.seed {})", s.run.seed)
                 : fmt::format(", not placed here (more than {}: the particle node places them at step 0)",
                               kMaxCheckedPlacement));
  if (s.time.adaptive_interval())
    fmt::print(
        "  time        {:.4g} s physical in coupling intervals of at most {:.3g} s, each the longest {:.3g} s / 2^j "
        "within {:g} drag relaxation times\n",
        s.time.end_time(), s.time.coupling_interval, s.time.coupling_interval, s.time.coupling_relaxation_times);
  else
    fmt::print("  time        {} coupling steps of {:.3g} s = {:.4g} s physical\n", s.time.coupling_steps,
               s.time.coupling_interval, s.time.end_time());
  fmt::print("  coupling    {} scheme{}\n", name_of(s.coupling_scheme),
             s.fluid.solve_every > 1
                 ? fmt::format("; the fluid solved every {} steps, one step of {:.3g} s on the feedback averaged over "
                               "them (fluid.solve_every)",
                               s.fluid.solve_every, s.fluid.solve_every * s.time.coupling_interval)
                 : std::string());
  fmt::print("  numerics    (readings the paper leaves open; docs/validation.md)\n");
  for (const auto& n : numerical_readings(s)) fmt::print("    {:<34} {:<20} {}\n", n.key, n.value, n.reading);
  if (const auto w = estimate_work(s); w.substeps > 0)
    fmt::print(
        "  work        at least {:.0f} DEM substeps per coupling interval (shortest contact {:.3g} s), "
        "~{:.3g} particle-steps in all\n",
        w.substeps, w.contact_time, w.particle_steps);
  if (s.hosts.tcp())
    fmt::print(
        "  bus         TCP through a relay the coordinator runs, at {}, {} (docs/hosts.md)\n",
        s.hosts.relay_address == "auto" ? "the address the nodes' hosts reach this one by" : s.hosts.relay_address,
        s.hosts.relay_port == 0 ? "any free port" : "port " + std::to_string(s.hosts.relay_port));
  else if (s.hosts.any())
    fmt::print("  bus         UDP multicast across hosts{}\n",
               s.run.bus_ttl >= 0 ? fmt::format(", TTL {}", s.run.bus_ttl) : std::string(", TTL 1"));
  // Commands are code the run executes as this user: said here, before it does.
  if (s.run.fluid_command.empty() && s.run.particle_command.empty())
    fmt::print("  commands    the built-in nodes (hemocosim-fluid, hemocosim-particles)\n");
  for (const auto& [key, command] :
       {std::pair{"run.fluid_command", s.run.fluid_command}, std::pair{"run.particle_command", s.run.particle_command}})
    if (!command.empty()) fmt::print("  commands    {} = `{}` runs as you\n", key, command);
  fmt::print("  output      a snapshot every {} steps; {}\n", s.output.every_steps,
             s.output.checkpoint_every_steps > 0
                 ? fmt::format("a checkpoint every {} steps (hemocosim resume)", s.output.checkpoint_every_steps)
                 : std::string("no checkpoints (output.checkpoint_every_steps = 0)"));
  if (!print_resource_estimate(s, rbcs + platelets, out_dir))
    throw std::runtime_error(fmt::format("{}: the run would not fit this machine by far (see above)", scene_path));
  return 0;
}

}  // namespace hemo
