// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_directory.h"

#include "checkpoint.h"
#include "hosts.h"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

namespace fs = std::filesystem;

namespace hemo {

namespace {
// run.toml is rewritten as a run starts (ranks, placement, transport, the relay's URL) while
// others may read it (the monitor, `hemocosim restart`, lcm-logger's user): written aside and
// renamed, so that a reader sees the old file or the new one, never a truncated one.
void write_info(const std::string& file, const toml::table& info) {
  const std::string tmp = file + ".tmp";
  std::ofstream(tmp) << info << "\n";
  fs::rename(tmp, file);
}
}  // namespace

std::pair<RunDirectory, RunContext> RunDirectory::create(const std::string& path, const std::string& scene_path,
                                                         int ttl) {
  if (fs::exists(path) && !fs::is_empty(path))
    throw std::runtime_error("run directory " + path + " exists and is not empty; choose another --out");
  fs::create_directories(path);
  RunDirectory dir;
  dir.path = fs::absolute(path).string();
  fs::copy_file(scene_path, dir.scene_copy(), fs::copy_options::overwrite_existing);

  std::random_device rd;
  std::mt19937_64 rng((std::uint64_t(rd()) << 32) ^ rd());
  RunContext ctx;
  ctx.run_id = fmt::format("hc{:08x}", static_cast<std::uint32_t>(rng()));
  // A multicast group and port of the run's own, loopback-only (ttl=0) unless hosts say otherwise:
  // two runs on one machine never read each other's traffic.
  const int a = static_cast<int>(1 + rng() % 254), b = static_cast<int>(1 + rng() % 254);
  ctx.lcm_url = bus_url(a, b, static_cast<int>(20000 + rng() % 40000), ttl);
  ctx.secret_file = dir.secret_file();
  ctx.secret.resize(32);
  for (auto& b : ctx.secret) b = static_cast<std::uint8_t>(rng());
  {
    std::ofstream out(ctx.secret_file, std::ios::binary);
    out.write(reinterpret_cast<const char*>(ctx.secret.data()), static_cast<std::streamsize>(ctx.secret.size()));
  }
  fs::permissions(ctx.secret_file, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);

  toml::table info{{"run_id", ctx.run_id}, {"lcm_url", ctx.lcm_url}, {"secret_file", ctx.secret_file}};
  write_info(dir.info_file(), info);
  return {dir, ctx};
}

std::pair<RunDirectory, RunContext> RunDirectory::open(const std::string& path) {
  RunDirectory dir;
  dir.path = fs::absolute(path).string();
  toml::table info;
  try {
    info = toml::parse_file(dir.info_file());
  } catch (const toml::parse_error& e) {
    throw std::runtime_error(fmt::format("{} is not a hemocosim run directory ({})", path, e.description()));
  }
  RunContext ctx;
  ctx.run_id = info["run_id"].value_or(std::string());
  ctx.lcm_url = info["lcm_url"].value_or(std::string());
  ctx.secret_file = info["secret_file"].value_or(std::string());
  if (ctx.run_id.empty() || ctx.lcm_url.empty()) throw std::runtime_error(dir.info_file() + " lacks run_id or lcm_url");
  ctx.load_secret();
  dir.fluid_ranks = info["fluid_ranks"].value_or(0);
  dir.particle_ranks = info["particle_ranks"].value_or(0);
  dir.fluid_command = info["fluid_command"].value_or(std::string());
  dir.particle_command = info["particle_command"].value_or(std::string());
  if (const auto* hosts = info["hosts"].as_table()) {
    auto& p = dir.placement;
    p.fluid = (*hosts)["fluid"].value_or(std::string());
    p.particles = (*hosts)["particles"].value_or(std::string());
    p.launcher = (*hosts)["launcher"].value_or(p.launcher);
    p.launch_command = (*hosts)["launch_command"].value_or(p.launch_command);
  }
  if (const auto* bus = info["bus"].as_table()) {
    auto& p = dir.placement;
    p.transport = (*bus)["transport"].value_or(p.transport);
    p.relay_address = (*bus)["relay_address"].value_or(p.relay_address);
    p.relay_port = (*bus)["relay_port"].value_or(p.relay_port);
    dir.transport_recorded = true;
  }
  return {dir, ctx};
}

void RunDirectory::record_ranks(int fluid, int particles) {
  fluid_ranks = fluid;
  particle_ranks = particles;
  toml::table info = toml::parse_file(info_file());
  info.insert_or_assign("fluid_ranks", fluid);
  info.insert_or_assign("particle_ranks", particles);
  write_info(info_file(), info);
}

void RunDirectory::record_placement(const HostPlacement& hosts) {
  placement = hosts;
  if (!hosts.across_hosts()) return;  // one host: run.toml as it always was
  toml::table info = toml::parse_file(info_file());
  info.insert_or_assign("hosts", toml::table{{"fluid", hosts.fluid},
                                             {"particles", hosts.particles},
                                             {"launcher", hosts.launcher},
                                             {"launch_command", hosts.launch_command}});
  write_info(info_file(), info);
}

void RunDirectory::record_transport(const HostPlacement& hosts) {
  placement.transport = hosts.transport;
  placement.relay_address = hosts.relay_address;
  placement.relay_port = hosts.relay_port;
  transport_recorded = true;
  toml::table info = toml::parse_file(info_file());
  info.insert_or_assign("bus", toml::table{{"transport", hosts.transport},
                                           {"relay_address", hosts.relay_address},
                                           {"relay_port", hosts.relay_port}});
  write_info(info_file(), info);
}

void RunDirectory::record_bus_url(const std::string& url) const {
  toml::table info = toml::parse_file(info_file());
  info.insert_or_assign("lcm_url", url);
  write_info(info_file(), info);
}

void RunDirectory::record_command(const std::string& node, const std::string& command) {
  (node == "fluid" ? fluid_command : particle_command) = command;
  toml::table info = toml::parse_file(info_file());
  info.insert_or_assign(node == "fluid" ? "fluid_command" : "particle_command", command);
  write_info(info_file(), info);
}

std::optional<long> RunDirectory::last_checkpoint() const { return last_complete_checkpoint(path); }

void RunDirectory::keep_only_checkpoint(long step) const {
  for (const long k : checkpoint_steps(path))
    if (k != step) fs::remove_all(checkpoint_folder(path, k));
}

void RunDirectory::drop_checkpoint(long step) const { fs::remove_all(checkpoint_folder(path, step)); }

void RunDirectory::drop_metrics_after(long step) const {
  std::ifstream in(metrics_file());
  if (!in) return;
  std::string header, line, kept;
  std::getline(in, header);
  while (std::getline(in, line))
    if (!line.empty() && std::stol(line.substr(0, line.find(','))) <= step) kept += line + "\n";
  in.close();
  std::ofstream(metrics_file()) << header << "\n" << kept;
}

}  // namespace hemo
