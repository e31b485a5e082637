// SPDX-License-Identifier: GPL-3.0-or-later
#include "hosts.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <set>
#include <sstream>

namespace hemo {

namespace {
std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t") - b + 1);
}

// Host names and IPv4 addresses only: a name goes into ssh's and mpirun's arguments, and
// anything else (spaces, quotes, options) would be a mistake or an injection.
bool valid_host(const std::string& h) {
  if (h.empty() || h.size() > 253 || h.front() == '-') return false;
  return std::all_of(h.begin(), h.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_';
  });
}
}  // namespace

std::vector<HostSlots> parse_host_list(const std::string& text) {
  std::vector<HostSlots> hosts;
  if (trim(text).empty()) return hosts;
  std::set<std::string> seen;
  std::istringstream in(text);
  for (std::string entry; std::getline(in, entry, ',');) {
    entry = trim(entry);
    if (entry.empty()) throw std::invalid_argument(fmt::format("\"{}\": an empty entry (hosts are a,b:2,c:2)", text));
    HostSlots h;
    const auto colon = entry.find(':');
    h.host = trim(entry.substr(0, colon));
    if (colon != std::string::npos) {
      const std::string n = trim(entry.substr(colon + 1));
      const bool digits = !n.empty() && n.size() <= 4 && std::all_of(n.begin(), n.end(), ::isdigit);
      h.slots = digits ? std::stoi(n) : 0;
      if (h.slots < 1)
        throw std::invalid_argument(
            fmt::format("\"{}\": the ranks after ':' must be a whole number from 1 to 4096", entry));
    }
    if (!valid_host(h.host))
      throw std::invalid_argument(fmt::format("\"{}\": not a host name (letters, digits, '.', '-', '_')", h.host));
    if (!seen.insert(h.host).second)
      throw std::invalid_argument(fmt::format("\"{}\" is named twice; give its ranks once as {}:N", h.host, h.host));
    hosts.push_back(h);
  }
  if (total_slots(hosts) > 4096) throw std::invalid_argument(fmt::format("\"{}\": more than 4096 ranks", text));
  return hosts;
}

std::string host_list_text(const std::vector<HostSlots>& hosts) {
  std::string s;
  for (const auto& h : hosts) s += fmt::format("{}{}:{}", s.empty() ? "" : ",", h.host, h.slots);
  return s;
}

std::string read_host_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(fmt::format("cannot read the host file {}", path));
  std::vector<HostSlots> hosts;
  int number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    std::istringstream words(line.substr(0, line.find('#')));
    std::string host;
    if (!(words >> host)) continue;
    int slots = 1;
    for (std::string w; words >> w;) {
      const bool is_slots = w.rfind("slots=", 0) == 0;
      const std::string n = is_slots ? w.substr(6) : "";
      if (!is_slots || n.empty() || n.size() > 4 || !std::all_of(n.begin(), n.end(), ::isdigit) || std::stoi(n) < 1)
        throw std::invalid_argument(
            fmt::format("{}:{}: \"{}\": a line is `host` or `host slots=N` (N from 1 to 4096)", path, number, w));
      slots = std::stoi(n);
    }
    const auto it = std::find_if(hosts.begin(), hosts.end(), [&](const HostSlots& h) { return h.host == host; });
    if (it != hosts.end())
      it->slots += slots;
    else
      hosts.push_back({host, slots});
  }
  if (hosts.empty()) throw std::invalid_argument(fmt::format("the host file {} names no host", path));
  const std::string list = host_list_text(hosts);
  try {
    parse_host_list(list);  // the same rules as a list: names, counts
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{}: {}", path, e.what()));
  }
  return list;
}

int total_slots(const std::vector<HostSlots>& hosts) {
  int n = 0;
  for (const auto& h : hosts) n += h.slots;
  return n;
}

int ranks_for_hosts(const std::vector<HostSlots>& hosts, int ranks, const std::string& what) {
  if (hosts.empty()) return ranks;
  const int slots = total_slots(hosts);
  if (ranks != 1 && ranks != slots)
    throw std::invalid_argument(fmt::format("{} = {} but the hosts {} give {} rank{}; give one or the other", what,
                                            ranks, host_list_text(hosts), slots, slots > 1 ? "s" : ""));
  return slots;
}

std::pair<std::string, std::string> split_allocation(const std::vector<std::string>& nodes, int fluid_ranks,
                                                     int particle_ranks) {
  if (nodes.empty()) throw std::invalid_argument("the Slurm allocation lists no nodes");
  const std::vector<HostSlots> fluid{{nodes.front(), fluid_ranks}};
  if (nodes.size() == 1) return {host_list_text(fluid), host_list_text({{nodes.front(), particle_ranks}})};
  std::vector<HostSlots> particles;
  const int n = static_cast<int>(nodes.size()) - 1;
  for (int i = 0; i < n && i < particle_ranks; ++i)
    particles.push_back({nodes[i + 1], particle_ranks / n + (i < particle_ranks % n ? 1 : 0)});
  return {host_list_text(fluid), host_list_text(particles)};
}

int bus_ttl(int configured, bool across_hosts) {
  if (configured >= 0) return configured;
  return across_hosts ? 1 : 0;
}

std::string bus_url(int group_a, int group_b, int port, int ttl) {
  return fmt::format("udpm://239.255.{}.{}:{}?ttl={}", group_a, group_b, port, ttl);
}

std::vector<std::string> expand_launch_command(const std::string& templ,
                                               const std::map<std::string, std::string>& values) {
  std::istringstream in(templ);
  std::vector<std::string> argv;
  bool has_command = false;
  for (std::string word; in >> word;) {
    std::string out;
    for (std::size_t i = 0; i < word.size();) {
      if (word[i] != '{') {
        out += word[i++];
        continue;
      }
      const auto close = word.find('}', i);
      if (close == std::string::npos)
        throw std::invalid_argument(fmt::format("launch command \"{}\": unclosed '{{' in \"{}\"", templ, word));
      const std::string name = word.substr(i + 1, close - i - 1);
      if (name != "host" && name != "command" && name != "node" && name != "run_dir")
        throw std::invalid_argument(fmt::format(
            "launch command \"{}\": unknown placeholder {{{}}} (known: {{host}} {{command}} {{node}} {{run_dir}})",
            templ, name));
      has_command |= name == "command";
      const auto it = values.find(name);
      out += it != values.end() ? it->second : "{" + name + "}";
      i = close + 1;
    }
    argv.push_back(out);
  }
  if (!has_command)
    throw std::invalid_argument(
        fmt::format("launch command \"{}\" lacks {{command}}, the node's command on the host", templ));
  return argv;
}

void check_launch_command(const std::string& templ) { expand_launch_command(templ, {}); }

std::string shell_quote(const std::string& word) {
  std::string q = "'";
  for (const char c : word) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string remote_node_command(const std::string& run_dir, const std::vector<std::string>& argv) {
  std::string node;
  for (const auto& a : argv) node += (node.empty() ? "" : " ") + shell_quote(a);
  // The node runs in the background with its stdin closed; a watcher holds the connection's
  // stdin (fd 3) and, once it closes, stops the node (TERM, then KILL after 5 s). The watcher is
  // ended when the node exits, so that the shell's exit status is the node's.
  return "cd " + shell_quote(run_dir) + " || exit 126; exec 3<&0 </dev/null; " + node +
         " & n=$!; (cat <&3 >/dev/null 2>&1; kill -TERM $n 2>/dev/null; sleep 5; kill -KILL $n 2>/dev/null)"
         " >/dev/null 2>&1 & w=$!; exec 3<&-; wait $n; s=$?; kill $w 2>/dev/null; exit $s";
}

std::string remote_check_command(const std::string& run_dir) {
  return "cat " + shell_quote(run_dir + "/" + kHostsCheckFile);
}

}  // namespace hemo
