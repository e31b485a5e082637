// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_directory.h"

#include "bus_crypto.h"
#include "checkpoint.h"
#include "geometry.h"
#include "hosts.h"
#include "run_files.h"
#include "scene.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <toml++/toml.h>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace fs = std::filesystem;

namespace hemo {

namespace {
// run.toml is rewritten as a run starts (ranks, placement, transport, the relay's URL) while
// others may read it (the monitor, `hemocosim restart`, lcm-logger's user): written aside and
// renamed, so that a reader sees the old file or the new one, never a truncated one, and a full
// disk or a crash leaves the old one (write_file_atomically).
void write_info(const std::string& file, const toml::table& info) {
  std::ostringstream text;
  text << info << "\n";
  write_file_atomically(file, text.str());
}

toml::table read_info(const std::string& file) {
  try {
    return toml::parse_file(file);
  } catch (const toml::parse_error& e) {
    throw std::runtime_error(fmt::format("{} is not a hemocosim run.toml ({})", file, e.description()));
  }
}

// A choice run.toml recorded by name (hosts.launcher, hosts.transport): kept as it was when
// absent, refused in one line when the file names no such choice (a tampered or foreign file).
template <class E>
void read_recorded_choice(const toml::table& table, const char* key, E& out, const std::string& file) {
  const std::string name = table[key].value_or(name_of(out));
  if (!choice_named(name, out))
    throw std::runtime_error(fmt::format("{}: {} '{}' is none of {}", file, ChoiceTable<E>::key, name,
                                         fmt::join(choice_names<E>(), ", ")));
}

// What a run's signature of its commands covers: the run and the command of each node ("" for
// the built-in one).
std::string commands_text(const RunContext& ctx, const Scene& scene) {
  return fmt::format("hemocosim run commands\nrun_id={}\nfluid_command={}\nparticle_command={}\n", ctx.run_id,
                     scene.run.fluid_command, scene.run.particle_command);
}

// The checkpoint's files (fluid/..., particles/...) by path relative to its step folder.
std::map<std::string, fs::path> checkpoint_files(const std::string& folder) {
  std::map<std::string, fs::path> files;
  for (const char* role : {"fluid", "particles"}) {
    const fs::path root = fs::path(folder) / role;
    if (!fs::is_directory(root)) continue;
    for (const auto& e : fs::recursive_directory_iterator(root))
      if (e.is_regular_file() || e.is_symlink()) files[fs::relative(e.path(), folder).string()] = e.path();
  }
  return files;
}

// A run directory is created under umask 077: it, its secret and what the coordinator writes
// into it are the user's only.
struct PrivateUmask {
  mode_t before = ::umask(077);
  ~PrivateUmask() { ::umask(before); }
};
}  // namespace

void RunDirectory::keep_surface(const Scene& scene) const {
  const fs::path surface(scene.vessel.surface_file);
  if (surface.empty() || !surface.is_relative() || !surface_vessel(scene.vessel)) return;
  const fs::path copy = fs::path(path) / surface;
  fs::create_directories(copy.parent_path());
  fs::copy_file(scene.vessel.surface_path, copy, fs::copy_options::overwrite_existing);
}

std::pair<RunDirectory, RunContext> RunDirectory::create(const std::string& path, const std::string& scene_path,
                                                         int ttl) {
  const PrivateUmask umask_077;
  std::error_code ec;
  if (fs::exists(fs::symlink_status(path, ec))) {
    // An empty directory given as --out must be the user's own and closed to others: someone who
    // may write into it could change run.toml or the scene copy between this run and its resume.
    check_own_directory(path, "run directory");
    if (!fs::is_empty(path))
      throw std::runtime_error("run directory " + path + " exists and is not empty; choose another --out");
    fs::permissions(path, fs::perms::owner_all, fs::perm_options::replace);
  } else {
    fs::create_directories(path);
  }
  RunDirectory dir;
  dir.path = fs::absolute(path).string();
  fs::copy_file(scene_path, dir.scene_copy(), fs::copy_options::overwrite_existing);
  const auto draw = random_bytes(8 + 32);
  auto word = [&draw](int i) {
    std::uint32_t v = 0;
    for (int k = 0; k < 2; ++k) v = v << 8 | draw[static_cast<std::size_t>(2 * i + k)];
    return v;
  };
  RunContext ctx;
  ctx.run_id = fmt::format("hc{:02x}{:02x}{:02x}{:02x}", draw[0], draw[1], draw[2], draw[3]);
  // A multicast group and port of the run's own, loopback-only (ttl=0) unless hosts say otherwise:
  // two runs on one machine never read each other's traffic.
  const int a = static_cast<int>(1 + word(0) % 254), b = static_cast<int>(1 + word(1) % 254);
  ctx.lcm_url = bus_url(a, b, static_cast<int>(20000 + (word(2) << 16 | word(3)) % 40000), ttl);
  ctx.secret_file = dir.secret_file();
  ctx.secret.assign(draw.begin() + 8, draw.end());
  create_private_file(ctx.secret_file, ctx.secret);

  toml::table info{{"run_id", ctx.run_id}, {"lcm_url", ctx.lcm_url}, {"secret_file", ctx.secret_file}};
  write_info(dir.info_file(), info);
  return {dir, ctx};
}

std::pair<RunDirectory, RunContext> RunDirectory::open(const std::string& path) {
  RunDirectory dir;
  dir.path = fs::absolute(path).string();
  check_own_directory(dir.path, "run directory");
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
    read_recorded_choice(*hosts, "launcher", p.launcher, dir.info_file());
    p.launch_command = (*hosts)["launch_command"].value_or(p.launch_command);
  }
  if (const auto* bus = info["bus"].as_table()) {
    auto& p = dir.placement;
    read_recorded_choice(*bus, "transport", p.transport, dir.info_file());
    p.relay_address = (*bus)["relay_address"].value_or(p.relay_address);
    p.relay_port = (*bus)["relay_port"].value_or(p.relay_port);
    dir.transport_recorded = true;
  }
  return {dir, ctx};
}

void RunDirectory::record_ranks(int fluid, int particles) {
  fluid_ranks = fluid;
  particle_ranks = particles;
  toml::table info = read_info(info_file());
  info.insert_or_assign("fluid_ranks", fluid);
  info.insert_or_assign("particle_ranks", particles);
  write_info(info_file(), info);
}

void RunDirectory::record_placement(const HostPlacement& hosts) {
  placement = hosts;
  if (!hosts.across_hosts()) return;  // one host: run.toml as it always was
  toml::table info = read_info(info_file());
  info.insert_or_assign("hosts", toml::table{{"fluid", hosts.fluid},
                                             {"particles", hosts.particles},
                                             {"launcher", name_of(hosts.launcher)},
                                             {"launch_command", hosts.launch_command}});
  write_info(info_file(), info);
}

void RunDirectory::record_transport(const HostPlacement& hosts) {
  placement.transport = hosts.transport;
  placement.relay_address = hosts.relay_address;
  placement.relay_port = hosts.relay_port;
  transport_recorded = true;
  toml::table info = read_info(info_file());
  info.insert_or_assign("bus", toml::table{{"transport", name_of(hosts.transport)},
                                           {"relay_address", hosts.relay_address},
                                           {"relay_port", hosts.relay_port}});
  write_info(info_file(), info);
}

void RunDirectory::record_bus_url(const std::string& url) const {
  toml::table info = read_info(info_file());
  info.insert_or_assign("lcm_url", url);
  write_info(info_file(), info);
}

void RunDirectory::record_command(const std::string& node, const std::string& command) {
  (node == "fluid" ? fluid_command : particle_command) = command;
  toml::table info = read_info(info_file());
  info.insert_or_assign(node == "fluid" ? "fluid_command" : "particle_command", command);
  write_info(info_file(), info);
}

void RunDirectory::sign_commands(const RunContext& ctx, const Scene& scene) {
  toml::table info = read_info(info_file());
  info.insert_or_assign("commands_hmac", hmac_hex(ctx.secret, commands_text(ctx, scene)));
  write_info(info_file(), info);
}

bool RunDirectory::commands_signed(const RunContext& ctx, const Scene& scene) const {
  if (scene.run.fluid_command.empty() && scene.run.particle_command.empty()) return true;  // the built-in nodes
  const toml::table info = read_info(info_file());
  const auto recorded = info["commands_hmac"].value_or(std::string());
  return !recorded.empty() && recorded == hmac_hex(ctx.secret, commands_text(ctx, scene));
}

std::optional<long> RunDirectory::last_checkpoint() const { return last_complete_checkpoint(path); }

void RunDirectory::seal_checkpoint(long step) const {
  const std::string folder = checkpoint_folder(path, step);
  std::string sums;
  for (const auto& [name, file] : checkpoint_files(folder)) sums += sha256_file(file.string()) + "  " + name + "\n";
  write_file_atomically(folder + "/" + kCheckpointManifest, sums);
}

void RunDirectory::verify_checkpoint(long step) const {
  const std::string folder = checkpoint_folder(path, step);
  std::ifstream in(folder + "/" + kCheckpointManifest);
  std::map<std::string, std::string> sealed;
  for (std::string line; std::getline(in, line);)
    if (line.size() > 66) sealed[line.substr(66)] = line.substr(0, 64);
  auto refuse = [&](const std::string& name, const char* how) {
    return std::runtime_error(
        fmt::format("the checkpoint of step {} in {} does not match its {}: {} {}; refusing to resume from it", step,
                    path, kCheckpointManifest, name, how));
  };
  if (sealed.empty()) throw refuse(kCheckpointManifest, "is empty or unreadable");
  const auto files = checkpoint_files(folder);
  for (const auto& [name, file] : files) {
    const auto it = sealed.find(name);
    if (it == sealed.end()) throw refuse(name, "was added");
    if (sha256_file(file.string()) != it->second) throw refuse(name, "was changed");
  }
  for (const auto& [name, sum] : sealed)
    if (!files.count(name)) throw refuse(name, "is missing");
}

bool RunDirectory::out_of_space() const {
  try {
    return free_bytes(path) < (1u << 20);
  } catch (const std::exception&) {
    return false;
  }
}

std::uintmax_t RunDirectory::checkpoint_bytes(long step) const {
  std::uintmax_t bytes = 0;
  for (const auto& [name, file] : checkpoint_files(checkpoint_folder(path, step)))
    if (fs::is_regular_file(file)) bytes += fs::file_size(file);
  return bytes;
}

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
  long skipped = 0;
  while (std::getline(in, line)) {
    // A row: its step, then four more fields. Anything else (a crash's or full disk's remains).
    const auto comma = line.find(',');
    const bool row = comma > 0 && comma != std::string::npos && line.find_first_not_of("0123456789") == comma &&
                     std::count(line.begin(), line.end(), ',') == 4 && comma <= 18;
    if (!row) {
      skipped += !line.empty();
      continue;
    }
    if (std::stol(line.substr(0, comma)) <= step) kept += line + "\n";
  }
  in.close();
  if (skipped > 0)
    fmt::print(stderr, "hemocosim: warning: {}: dropped {} malformed line{}\n", metrics_file(), skipped,
               skipped > 1 ? "s" : "");
  write_file_atomically(metrics_file(), header + "\n" + kept);
}

RunLock::RunLock(const std::string& run_dir) {
  const std::string file = run_dir + "/lock";
  fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd_ < 0) throw std::runtime_error(io_error("open", file, errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK)
      throw std::runtime_error(
          fmt::format("{} is in use: another hemocosim coordinator runs it (its lock {})", run_dir, file));
    throw std::runtime_error(io_error("lock", file, err));
  }
}

RunLock::~RunLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the flock
}

bool RunLock::held(const std::string& run_dir) {
  const std::string file = run_dir + "/lock";
  const int fd = ::open(file.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return false;  // never run since locks came in, or not a run directory
  const bool free = ::flock(fd, LOCK_SH | LOCK_NB) == 0;
  ::close(fd);
  return !free;
}

}  // namespace hemo
