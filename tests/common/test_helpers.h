// Small helpers shared by the common/ tests.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "bus.h"

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <string>

namespace hemo::test {

// A run context on a multicast group/port of its own so parallel tests never mix.
inline RunContext make_context(const std::string& tag) {
  std::random_device rd;
  RunContext ctx;
  ctx.run_id = tag + std::to_string(rd() % 1000000);
  ctx.lcm_url =
      "udpm://239.255.77." + std::to_string(1 + rd() % 250) + ":" + std::to_string(20000 + rd() % 40000) + "?ttl=0";
  ctx.secret.assign(32, 0);
  for (auto& b : ctx.secret) b = static_cast<std::uint8_t>(rd());
  ctx.timeout_s = 10;
  ctx.retry_s = 0.2;
  return ctx;
}

}  // namespace hemo::test
