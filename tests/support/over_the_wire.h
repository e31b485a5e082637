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
  EXPECT_EQ(received.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  return received;
}

}  // namespace hemo::test
