// Progress of a long command on one line: step, physical time, rate, ETA.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

namespace hemo {

class Progress {
 public:
  // Steps after first_step are to come (first_step > 0: a resumed run) until the physical time
  // end_time_s; total_steps: their number, 0 when not known in advance (adaptive intervals).
  Progress(long total_steps, double end_time_s, long first_step = 0)
      : total_(total_steps), first_(first_step), end_time_(end_time_s), tty_(isatty(STDERR_FILENO)) {}

  // The physical time the steps start from (once: a restart keeps the first).
  void starts_at(double time_s) {
    if (first_time_ < 0) first_time_ = time_s;
  }
  // After each step; `last`: the run's last step (always printed).
  void update(long step, double time_s, const std::string& extra = "", bool last = false) {
    const double elapsed = seconds();
    if (!last && elapsed - last_print_ < (tty_ ? 0.2 : 5.0)) return;
    last_print_ = elapsed;
    const double rate = (step - first_) / std::max(elapsed, 1e-9);
    // The ETA from the physical time covered: intervals may change length.
    const double covered = time_s - std::max(first_time_, 0.0);
    const double eta = elapsed * std::max(end_time_ - time_s, 0.0) / std::max(covered, 1e-300);
    const std::string of = total_ > 0 ? "/" + std::to_string(total_) : "";
    std::fprintf(stderr, "%sstep %ld%s  t = %.4g s  %.3g steps/s  elapsed %.0f s  ETA %.0f s  %s%s",
                 tty_ ? "\r\033[K" : "", step, of.c_str(), time_s, rate, elapsed, eta, extra.c_str(),
                 (tty_ && !last) ? "" : "\n");
    std::fflush(stderr);
  }
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  long total_;
  long first_;
  double end_time_;
  double first_time_ = -1;
  bool tty_;
  double last_print_ = -1e9;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace hemo
