// SPDX-License-Identifier: GPL-3.0-or-later
#include "liggghts_errors.h"

#include <cstdlib>
#include <fstream>
#include <mutex>

namespace hemo::particles {

namespace {

struct Guard {
  std::vector<std::string> logs;
  std::function<void(const std::string&)> report;
  bool armed = false;
};

Guard& guard() {
  static Guard* g = new Guard;  // never destroyed: the handler may run during exit
  return *g;
}

void on_exit() {
  Guard& g = guard();
  if (!g.armed || !g.report) return;
  g.armed = false;
  std::string line = last_liggghts_error(g.logs);
  g.report(line.empty() ? "the DEM engine (LIGGGHTS) ended the process without an error message" : "LIGGGHTS: " + line);
}

}  // namespace

std::string last_liggghts_error(const std::vector<std::string>& logs) {
  for (const auto& path : logs) {
    std::ifstream in(path);
    std::string line, last;
    while (std::getline(in, line))
      if (line.rfind("ERROR", 0) == 0) last = line;
    if (!last.empty()) return last;
  }
  return {};
}

void report_liggghts_exit(std::vector<std::string> logs, std::function<void(const std::string&)> report) {
  static std::once_flag once;
  std::call_once(once, [] { std::atexit(on_exit); });
  Guard& g = guard();
  g.logs = std::move(logs);
  g.report = std::move(report);
  g.armed = true;
}

void disarm_liggghts_exit() { guard().armed = false; }

}  // namespace hemo::particles
