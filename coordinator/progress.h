// Progress of a long command on one line: step, physical time, rate, ETA.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <unistd.h>

namespace hemo {

class Progress {
 public:
  // total_steps: 0 when not known in advance (adaptive intervals); the ETA then comes from the
  // physical time covered.
  Progress(long total_steps, double end_time_s)
      : total_(total_steps), end_time_(end_time_s), tty_(isatty(STDERR_FILENO)) {}

  void update(long step, double time_s, const std::string& extra = "", bool last = false) {
    const double elapsed = seconds();
    last = last || step == total_;
    if (!last && elapsed - last_print_ < (tty_ ? 0.2 : 5.0)) return;
    last_print_ = elapsed;
    const double rate = step / std::max(elapsed, 1e-9);
    const double eta = elapsed * std::max(end_time_ - time_s, 0.0) / std::max(time_s, 1e-300);
    const std::string of = total_ > 0 ? "/" + std::to_string(total_) : "";
    std::fprintf(stderr, "%sstep %ld%s  t = %.4g s  %.3g steps/s  elapsed %.0f s  ETA %.0f s  %s%s",
                 tty_ ? "\r\033[K" : "", step, of.c_str(), time_s, rate, elapsed, eta, extra.c_str(),
                 (tty_ && !last) ? "" : "\n");
    std::fflush(stderr);
  }
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  long total_;
  double end_time_;
  bool tty_;
  double last_print_ = -1e9;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace hemo
