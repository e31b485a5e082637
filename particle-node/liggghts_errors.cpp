// SPDX-License-Identifier: GPL-3.0-or-later
#include "liggghts_errors.h"

#include <mpi.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <stdexcept>

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

// What the kept screens received: the line being written and the last ERROR line.
struct Screen {
  std::mutex mutex;
  std::string partial;
  std::string last_error;
};

Screen& screen() {
  static Screen* s = new Screen;  // never destroyed: MPI_Abort may read it during exit
  return *s;
}

ssize_t keep(void* /*cookie*/, const char* data, size_t size) {
  Screen& s = screen();
  std::lock_guard<std::mutex> lock(s.mutex);
  for (size_t k = 0; k < size; ++k) {
    if (data[k] != '\n') {
      if (s.partial.size() < 4096) s.partial += data[k];  // a line, not a memory leak
      continue;
    }
    if (s.partial.rfind("ERROR", 0) == 0) s.last_error = s.partial;
    s.partial.clear();
  }
  return static_cast<ssize_t>(size);
}

int keep_on_close(void* /*cookie*/) { return 0; }

void report(Guard& g, const std::string& line) {
  g.armed = false;
  const std::string why =
      line.empty() ? "the DEM engine (LIGGGHTS) ended the process without an error message" : "LIGGGHTS: " + line;
  if (g.report) g.report(why);
  const std::string said = "hemocosim-particles: error: " + why + "\n";
  (void)!::write(STDERR_FILENO, said.data(), said.size());
}

void on_exit() {
  Guard& g = guard();
  if (!g.armed || !g.report) return;
  report(g, last_liggghts_error(g.logs));
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

std::FILE* kept_liggghts_screen() {
  std::FILE* f = ::fopencookie(nullptr, "w", cookie_io_functions_t{nullptr, keep, nullptr, keep_on_close});
  if (f == nullptr) throw std::runtime_error("cannot open a kept screen for LIGGGHTS");
  std::setvbuf(f, nullptr, _IOLBF, 0);  // each line as it ends: MPI_Abort follows Error::one's at once
  return f;
}

std::string last_screen_error() {
  Screen& s = screen();
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.last_error;
}

}  // namespace hemo::particles

// Error::one's way out (and the node's own abort_job, which disarms first): say why, then abort.
extern "C" int MPI_Abort(MPI_Comm comm, int errorcode) {
  auto& g = hemo::particles::guard();
  if (g.armed) {
    std::string line = hemo::particles::last_screen_error();
    if (line.empty()) line = hemo::particles::last_liggghts_error(g.logs);
    hemo::particles::report(g, line);
  }
  return PMPI_Abort(comm, errorcode);
}
