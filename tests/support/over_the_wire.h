// A message as its receiver sees it: encoded by the sender, decoded from the bytes.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace hemo::test {

template <class Message>
Message over_the_wire(const Message& sent) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(sent.getEncodedSize()));
  EXPECT_EQ(sent.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  Message received;
  // lcm-gen's decode() reads its hash through an out-parameter that GCC, once decode() is inlined
  // here, cannot see written before the read (it is: the read follows the length check). The
  // generated header is a SYSTEM include, but GCC 12 reports a middle-end warning of inlined code
  // unless every function of the inline stack is in a system header; this line is the one of ours.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
  const int decoded = received.decode(bytes.data(), 0, static_cast<int>(bytes.size()));
#pragma GCC diagnostic pop
  EXPECT_EQ(decoded, static_cast<int>(bytes.size()));
  return received;
}

}  // namespace hemo::test
