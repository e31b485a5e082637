// hemocosim restart / hemocosim swap: a request to the coordinator of a running run.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "commands.h"
#include "control_desk.h"
#include "run_directory.h"
#include "scene.h"

#include <fmt/format.h>

#include <random>

namespace hemo {

int control_command(const std::string& action, const ControlOptions& opt) {
  auto [dir, ctx] = RunDirectory::open(opt.run_dir);
  // Sealed as the run's own messages are (bus.encrypt): a swap's request names its command.
  ctx.encrypt = load_scene(dir.scene_copy()).bus.encrypt;
  if (!RunLock::held(dir.path))
    throw std::runtime_error(
        fmt::format("no coordinator is running {} (`hemocosim resume {}` goes on with it)", dir.path, dir.path));
  std::random_device rd;
  const ControlRequest request{static_cast<std::int64_t>((std::uint64_t(rd()) << 31) ^ rd()), action, opt.node,
                               opt.with};
  const auto answer = ask_coordinator(ctx, request, opt.timeout_s);
  if (answer.action != "done") throw std::runtime_error(fmt::format("the coordinator refused: {}", answer.detail));
  fmt::print(stderr, "hemocosim: {}\n", answer.detail);
  return 0;
}

}  // namespace hemo
