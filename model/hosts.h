// Runs across hosts (docs/hosts.md): where each node runs, how many MPI ranks on each host, how
// a node is started on its first host, and the bus URL that reaches the other hosts. Pure
// functions, so that placement, URL and launch-command rules are tested without engines.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace hemo {

// One host of a node's MPI job and the ranks Open MPI places on it.
struct HostSlots {
  std::string host;
  int slots = 1;
};

// "a", "b:2,c:2": comma-separated hosts, each with ":N" ranks (1 when left out). Throws
// std::invalid_argument with a one-line reason (empty entry, bad count, a host named twice).
std::vector<HostSlots> parse_host_list(const std::string& text);
// An Open MPI host file as a host list: lines `host [slots=N]` (1 slot when left out; a host on
// several lines adds them up), `#` comments, blank lines. Throws std::invalid_argument with the
// file, line and reason.
std::string read_host_file(const std::string& path);
// The list as Open MPI's `--host` takes it ("b:2,c:2"); empty for no hosts.
std::string host_list_text(const std::vector<HostSlots>& hosts);
int total_slots(const std::vector<HostSlots>& hosts);

// The ranks a node runs on, given its hosts and the ranks asked for elsewhere (run.*_ranks or
// --np-*; 1 is the default and yields to the hosts). Hosts decide; a different explicit number
// is refused (std::invalid_argument naming `what`, e.g. "run.particle_ranks").
int ranks_for_hosts(const std::vector<HostSlots>& hosts, int ranks, const std::string& what);

// The slurm launcher without hosts given: the allocation's nodes (in Slurm's order) shared out.
// On one node both nodes run there; on more, the fluid runs on the first and the particles on
// the others, their ranks spread in blocks as evenly as they go. {fluid, particles} as host
// lists ("n1:1", "n2:2,n3:1").
std::pair<std::string, std::string> split_allocation(const std::vector<std::string>& nodes, int fluid_ranks,
                                                     int particle_ranks);

// The multicast TTL of a run's bus: `configured` (>= 0) when given, else 0 on one host (the
// datagrams never leave it) and 1 across hosts (one subnet; routers do not forward them).
int bus_ttl(int configured, bool across_hosts);
std::string bus_url(int group_a, int group_b, int port, int ttl);

// The site's command that starts a node on a host (hosts.launch_command); placeholders:
//   {host}     the node's first host
//   {command}  the shell command to run there (one word: cd to the run directory, exec the node)
//   {node}     "fluid" or "particles"
//   {run_dir}  the run directory (the same path on every host)
inline constexpr const char* kDefaultLaunchCommand = "ssh -o BatchMode=yes {host} {command}";
// Splits the template at white space and fills in the placeholders (a placeholder's value stays
// one word). Throws std::invalid_argument for an unknown or unclosed placeholder, or a template
// without {command}.
std::vector<std::string> expand_launch_command(const std::string& templ,
                                               const std::map<std::string, std::string>& values);
// Checks a template without values (the scene's validation).
void check_launch_command(const std::string& templ);

// `word` quoted for a POSIX shell.
std::string shell_quote(const std::string& word);

// The shell command a launcher runs on the remote host: cd to the run directory, run argv, and
// end it when the connection ends (its stdin closes: the coordinator stopped it or died), so
// that no node outlives its coordinator on another host. Exits with the node's status.
std::string remote_node_command(const std::string& run_dir, const std::vector<std::string>& argv);

// The shell command that prints the run directory's host-check token (hosts_check_file) on a
// remote host: if it prints something else, that host does not share the run directory.
std::string remote_check_command(const std::string& run_dir);
inline constexpr const char* kHostsCheckFile = "hosts-check";

}  // namespace hemo
