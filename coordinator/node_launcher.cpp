// SPDX-License-Identifier: GPL-3.0-or-later
#include "node_launcher.h"

#include "node_process.h"

namespace hemo {

namespace {
class ProcessHandle : public NodeHandle {
 public:
  ProcessHandle(const std::string& node, const std::vector<std::string>& argv, const std::string& log_path)
      : process_(node, argv, log_path) {}
  bool running() override { return process_.running(); }
  std::string how_it_ended() const override { return process_.how_it_ended(); }
  void terminate() override { process_.terminate(); }
  pid_t pid() const override { return process_.pid(); }
  std::string log_path() const override { return process_.log_path(); }
  std::string last_log_line() const override { return process_.last_log_line(); }
  double peak_memory_mib() const override { return process_.peak_memory_mib(); }

 private:
  NodeProcess process_;
};
}  // namespace

std::unique_ptr<NodeHandle> ProcessLauncher::launch(const std::string& node, const std::vector<std::string>& argv,
                                                    const std::string& log_path) {
  return std::make_unique<ProcessHandle>(node, argv, log_path);
}

}  // namespace hemo
