// The coordinator's desk for restart / swap requests (coordinator/control_desk.h): a request is
// taken once however often it is repeated, answered again on every repeat once answered, and a
// malformed one is refused without reaching the lockstep.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "control_desk.h"
#include "test_helpers.h"

#include <hemo/step_order_t.hpp>

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <thread>

using namespace hemo;

namespace {
// Takes requests for `seconds`, as the coordinator does once per step.
std::vector<ControlRequest> take_for(ControlDesk& desk, double seconds) {
  std::vector<ControlRequest> taken;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (auto r = desk.take()) taken.push_back(*r);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return taken;
}
}  // namespace

TEST(ControlDesk, RequestIsTakenOnceAndItsAnswerReachesTheRequester) {
  auto ctx = test::make_context("desk");
  ControlDesk desk(ctx);
  const ControlRequest asked{42, "swap", "particles", "/opt/other-particles --fast"};
  auto answer = std::async(std::launch::async, [&] { return ask_coordinator(ctx, asked, 20); });
  // The requester publishes again every second until answered: 2.5 s brings repeats.
  const auto taken = take_for(desk, 2.5);
  ASSERT_EQ(taken.size(), 1u);
  EXPECT_EQ(taken[0].id, 42);
  EXPECT_EQ(taken[0].action, "swap");
  EXPECT_EQ(taken[0].node, "particles");
  EXPECT_EQ(taken[0].command, "/opt/other-particles --fast");
  desk.answer(taken[0], true, "particles node swapped at step 7");
  EXPECT_TRUE(take_for(desk, 1.5).empty()) << "a repeat is answered, not taken again";
  const auto a = answer.get();
  EXPECT_EQ(a.action, "done");
  EXPECT_EQ(a.request_id, 42);
  EXPECT_EQ(a.detail, "particles node swapped at step 7");
}

TEST(ControlDesk, RequestForAnUnknownNodeOrASwapWithoutCommandIsRefused) {
  auto ctx = test::make_context("desk-bad");
  ControlDesk desk(ctx);
  auto no_node = std::async(std::launch::async, [&] { return ask_coordinator(ctx, {1, "restart", "plasma", ""}, 20); });
  auto no_command = std::async(std::launch::async, [&] { return ask_coordinator(ctx, {2, "swap", "fluid", ""}, 20); });
  EXPECT_TRUE(take_for(desk, 2.5).empty());
  const auto a = no_node.get(), b = no_command.get();
  EXPECT_EQ(a.action, "refused");
  EXPECT_NE(a.detail.find("no node named 'plasma'"), std::string::npos) << a.detail;
  EXPECT_EQ(b.action, "refused");
  EXPECT_NE(b.detail.find("needs the command"), std::string::npos) << b.detail;
}

TEST(ControlDesk, NobodyAnsweringIsAnErrorAfterTheTimeout) {
  auto ctx = test::make_context("desk-none");
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(ask_coordinator(ctx, {3, "restart", "fluid", ""}, 1.5), std::runtime_error);
  EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.5);
}

// Bytes with the run's tag on the CONTROL channel that are not a control message (here a step
// order) are ignored: they neither stop the coordinator nor count as a request.
TEST(ControlDesk, SignedBytesThatAreNoRequestAreIgnored) {
  auto ctx = test::make_context("desk-junk");
  ControlDesk desk(ctx);
  Bus other(ctx, "other", {channel::control});
  step_order_t junk{};
  junk.time_s = 1;
  other.publish(channel::control, junk, 0);
  std::vector<ControlRequest> taken;
  EXPECT_NO_THROW(taken = take_for(desk, 1.0));
  EXPECT_TRUE(taken.empty());
}
