// SPDX-License-Identifier: GPL-3.0-or-later
#include "fake_nodes.h"

#include "checkpoint.h"
#include "node_port.h"
#include "rank_report.h"

#include <hemo/step_done_t.hpp>
#include <hemo/step_order_t.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <memory>
#include <thread>

namespace hemo::test {

namespace {
double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

std::string argument(const std::vector<std::string>& argv, const std::string& option) {
  const auto it = std::find(argv.begin(), argv.end(), option);
  return it != argv.end() && it + 1 != argv.end() ? *(it + 1) : std::string();
}

class FakeNode : public NodeHandle {
 public:
  FakeNode(FakeLauncher& owner, std::string node, int launch, const std::vector<std::string>& argv,
           std::string log_path)
      : owner_(owner), node_(std::move(node)), launch_(launch), log_path_(std::move(log_path)) {
    // Joins the bus from its command line, as a node program does.
    ctx_.run_id = argument(argv, "--run-id");
    ctx_.lcm_url = argument(argv, "--lcm-url");
    ctx_.secret_file = argument(argv, "--secret-file");
    ctx_.load_secret();
    run_dir_ = argument(argv, "--run-dir");
    const std::string resume = argument(argv, "--resume-step");
    step_ = resume.empty() ? 0 : std::stol(resume);
    const std::string ranks = argument(argv, "--ranks");
    ranks_ = ranks.empty() ? 1 : std::stoi(ranks);
    thread_ = std::thread([this] { body(); });
  }
  ~FakeNode() override { terminate(); }

  bool running() override {
    std::lock_guard<std::mutex> lock(mutex_);
    return ended_.empty();
  }
  std::string how_it_ended() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return ended_;
  }
  void terminate() override {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    end("was killed by signal 15 (Terminated)", "");
  }
  pid_t pid() const override { return 4000000 + launch_; }
  std::string log_path() const override { return log_path_; }
  std::string last_log_line() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_line_;
  }
  double peak_memory_mib() const override { return 0; }

 private:
  // The first ending counts (a terminate after an exit changes nothing).
  void end(const std::string& how, const std::string& line) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!ended_.empty()) return;
    ended_ = how;
    if (!line.empty()) last_line_ = line;
  }

  // Listens for `seconds`, keeping the step orders that come; false once terminated.
  bool listen(Bus& bus, double seconds) {
    const double until = now() + seconds;
    do {
      if (stop_) return false;
      bus.poll(0.01, [&](const Received& msg) {
        if (msg.kind != channel::step || orders_.count(msg.envelope.step)) return;
        const auto order = msg.as<step_order_t>();
        orders_[msg.envelope.step] = order;
        owner_.ledger.add(
            {Event::ordered, node_, launch_, msg.envelope.step, 0, order.write_checkpoint != 0, order.stop != 0});
      });
    } while (now() < until);
    return !stop_;
  }

  void report(Bus& bus, bool ok, const std::string& error, double compute_s, bool checkpointed, bool gave_up = false) {
    step_done_t done;
    done.node = node_;
    done.ok = ok;
    done.error = error;
    done.compute_s = compute_s;
    done.wait_s = 0;
    if (checkpointed) {
      done.names.push_back(kCheckpointDiagnostic);
      done.values.push_back(static_cast<double>(step_));
    }
    if (gave_up) {  // as NodePort::fail after a wait for the coordinator ran out
      done.names.push_back(kCoordinatorSilentDiagnostic);
      done.values.push_back(20.0);
    }
    done.n_diagnostics = static_cast<std::int32_t>(done.names.size());
    // In the ledger before it is on the bus: an order that answers it comes after it there.
    owner_.ledger.add({Event::reported, node_, launch_, step_, 0, checkpointed, false});
    bus.publish(channel::step_done, done, step_, /*keep=*/true);
    bus.forget_before(step_ - 1);
  }

  // Ranks 1..N-1 report the step, `later_s` after rank 0; false once terminated.
  bool report_ranks(Bus& bus, double later_s) {
    if (reporters_.empty() || !listen(bus, later_s)) return !stop_;
    for (std::size_t i = 0; i < reporters_.size(); ++i) {
      owner_.ledger.add({Event::reported, node_, launch_, step_, static_cast<int>(i) + 1, false, false});
      reporters_[i]->report(step_, {{fmt::format("rank{}_sent_B", i + 1), 100.0 * double(i + 1)}});
      reporters_[i]->begin_step();
    }
    return true;
  }

  void body() {
    const double start_at = now() + owner_.start_delay_s(node_, launch_);
    while (now() < start_at)
      if (stop_)
        return;
      else
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    Bus bus(ctx_, node_, {channel::step, channel::resend});
    auto heartbeat = std::make_unique<Heartbeat>(ctx_, node_, 0.1);
    for (int r = 1; r < ranks_; ++r) reporters_.push_back(std::make_unique<RankReporter>(ctx_, node_, r));
    // Start-up (step 0, or the checkpoint resumed), with its set-up time as a node reports it.
    report(bus, true, "", owner_.compute_s(node_, step_), false);
    if (!report_ranks(bus, 0)) return;
    for (;;) {
      double asked = now();
      while (!orders_.count(step_ + 1)) {
        if (!listen(bus, 0.02)) return;
        if (now() - asked > ctx_.retry_s) {
          bus.request_resend(channel::step, step_ + 1);
          asked = now();
        }
      }
      const step_order_t order = orders_.at(++step_);
      if (order.stop) return end("exited with status 0", "");
      const Act act = owner_.script(node_, launch_, step_);
      const double compute_s = owner_.compute_s(node_, step_);
      if (!listen(bus, compute_s)) return;
      switch (act) {
        case Act::ok: {
          const bool checkpoint = order.write_checkpoint;
          if (checkpoint) {
            std::ofstream(begin_checkpoint(run_dir_, step_, node_) + "/state") << step_ << "\n";
            commit_checkpoint(run_dir_, step_, node_);
          }
          report(bus, true, "", compute_s, checkpoint);
          if (!report_ranks(bus, owner_.ranks_later_s(node_, step_))) return;
          break;
        }
        case Act::rank_stops:
          report(bus, true, "", compute_s, false);
          reporters_.pop_back();  // its heartbeats end with it
          if (!report_ranks(bus, 0)) return;
          break;
        case Act::fail: {
          const std::string error = fmt::format("fake {} diverged at step {}", node_, step_);
          for (int i = 0; i < 3; ++i) report(bus, false, error, compute_s, false);
          heartbeat.reset();
          reporters_.clear();
          return end("exited with status 1", error);
        }
        case Act::give_up: {
          const std::string error = fmt::format("{}: nothing heard from the coordinator for 20 s", node_);
          for (int i = 0; i < 3; ++i) report(bus, false, error, compute_s, false, /*gave_up=*/true);
          heartbeat.reset();
          reporters_.clear();
          return end("exited with status 1", error);
        }
        case Act::die_writing_checkpoint:
          std::ofstream(begin_checkpoint(run_dir_, step_, node_) + "/state") << "half\n";
          [[fallthrough]];
        case Act::die:
          heartbeat.reset();
          reporters_.clear();
          return end("was killed by signal 9 (Killed)", fmt::format("fake {}: step {}", node_, step_));
        case Act::freeze:
          heartbeat.reset();
          reporters_.clear();
          while (!stop_) std::this_thread::sleep_for(std::chrono::milliseconds(10));
          return;
      }
    }
  }

  FakeLauncher& owner_;
  std::string node_;
  int launch_;
  std::string log_path_, run_dir_;
  RunContext ctx_;
  long step_ = 0;
  int ranks_ = 1;
  std::vector<std::unique_ptr<RankReporter>> reporters_;  // ranks 1..N-1
  std::map<long, step_order_t> orders_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::string ended_, last_line_;
  std::thread thread_;
};
}  // namespace

std::unique_ptr<NodeHandle> FakeLauncher::launch(const std::string& node, const std::vector<std::string>& argv,
                                                 const std::string& log_path) {
  int launch = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& l : launches_) launch += l.node == node;
    const std::string resume = argument(argv, "--resume-step");
    launches_.push_back({node, launch, argv, resume.empty() ? 0 : std::stol(resume)});
  }
  return std::make_unique<FakeNode>(*this, node, launch, argv, log_path);
}

int FakeLauncher::launches_of(const std::string& node) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(
      std::count_if(launches_.begin(), launches_.end(), [&](const Launch& l) { return l.node == node; }));
}

}  // namespace hemo::test
