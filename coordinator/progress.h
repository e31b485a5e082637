// Progress of a long command on one line: step, physical time, rate, ETA.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <chrono>
#include <cstdio>
#include <string>
#include <unistd.h>

namespace hemo {

class Progress {
 public:
  // Steps first_step + 1 .. total_steps are to come (first_step > 0: a resumed run).
  Progress(long total_steps, double dt_s, long first_step = 0)
      : total_(total_steps), first_(first_step), dt_(dt_s), tty_(isatty(STDERR_FILENO)) {}

  void update(long step, const std::string& extra = "") {
    const double elapsed = seconds();
    const bool last = step == total_;
    if (!last && elapsed - last_print_ < (tty_ ? 0.2 : 5.0)) return;
    last_print_ = elapsed;
    const double rate = (step - first_) / std::max(elapsed, 1e-9);
    const double eta = (total_ - step) / std::max(rate, 1e-12);
    std::fprintf(stderr, "%sstep %ld/%ld  t = %.4g s  %.3g steps/s  elapsed %.0f s  ETA %.0f s  %s%s",
                 tty_ ? "\r\033[K" : "", step, total_, step * dt_, rate, elapsed, eta, extra.c_str(),
                 (tty_ && !last) ? "" : "\n");
    std::fflush(stderr);
  }
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  long total_;
  long first_;
  double dt_;
  bool tty_;
  double last_print_ = -1e9;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace hemo
