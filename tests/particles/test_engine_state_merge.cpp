// A checkpoint written on one rank count and restored on another: the ranks' states made one,
// and each new rank's share of it by sub-domain (engine_state_merge.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include <engine_state_merge.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>

using namespace hemo::particles;

namespace {
// A rank's state of `tags` atoms at z = tag, each with `tag % 3` contacts of 2 values each
// (partner tag + 100, values tag and -tag) and a 4-wide rotation row.
EngineState rank_state(const std::vector<std::int64_t>& tags) {
  EngineState s;
  s.ranks = 2;
  s.particles = 6;
  s.tag_capacity = 6;
  s.dem_step = 42;
  s.contact_values = 2;
  for (const auto t : tags) {
    const double z = static_cast<double>(t);
    s.tag.push_back(t);
    s.type.push_back(1);
    s.mask.push_back(1);
    s.image.push_back(0);
    s.x.insert(s.x.end(), {0.0, 0.0, z});
    s.v.insert(s.v.end(), {z, z, z});
    s.rotation.insert(s.rotation.end(), {z, 1, 2, 3});
    s.partner_count.push_back(t % 3);
    for (std::int64_t p = 0; p < t % 3; ++p) {
      s.partner.push_back(t + 100);
      s.contact_history.insert(s.contact_history.end(), {z, -z});
    }
  }
  return s;
}
}  // namespace

TEST(EngineStateMerge, EveryAtomLandsOnExactlyOneNewRankWithItsContactsAndValues) {
  const EngineState all = merged({rank_state({4, 1, 5}), rank_state({2, 6, 3})});
  ASSERT_EQ(all.tag, (std::vector<std::int64_t>{4, 1, 5, 2, 6, 3}));
  ASSERT_EQ(all.partner.size(), 1u + 1 + 2 + 2 + 0 + 0);

  // Three new ranks: z < 2.5, [2.5, 4.5), >= 4.5.
  const double cuts[] = {-1e300, 2.5, 4.5, 1e300};
  std::vector<std::int64_t> seen;
  for (int r = 0; r < 3; ++r) {
    const EngineState own =
        atoms_in(all, [&](double, double, double z) { return z >= cuts[r] && z < cuts[r + 1]; });
    ASSERT_EQ(own.x.size(), 3 * own.tag.size());
    ASSERT_EQ(own.rotation.size(), 4 * own.tag.size());
    ASSERT_EQ(own.partner_count.size(), own.tag.size());
    std::size_t p = 0;
    for (std::size_t k = 0; k < own.tag.size(); ++k) {
      const std::int64_t t = own.tag[k];
      const double z = static_cast<double>(t);
      seen.push_back(t);
      EXPECT_GE(z, cuts[r]);
      EXPECT_LT(z, cuts[r + 1]);
      EXPECT_EQ(own.x[3 * k + 2], z);
      EXPECT_EQ(own.v[3 * k], z);
      EXPECT_EQ(own.rotation[4 * k], z);
      ASSERT_EQ(own.partner_count[k], t % 3);
      for (std::int64_t c = 0; c < t % 3; ++c, ++p) {
        EXPECT_EQ(own.partner[p], t + 100);
        EXPECT_EQ(own.contact_history[2 * p], z);
        EXPECT_EQ(own.contact_history[2 * p + 1], -z);
      }
    }
    EXPECT_EQ(own.partner.size(), p);
    EXPECT_EQ(own.dem_step, 42);
  }
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(seen, (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6}));
}

TEST(EngineStateMerge, RanksThatDisagreeOrDamagedContactsAreRefused) {
  EngineState late = rank_state({2});
  late.dem_step = 43;
  EXPECT_THROW(merged({rank_state({1}), late}), std::invalid_argument);
  EngineState damaged = rank_state({2, 5});
  damaged.partner.pop_back();
  EXPECT_THROW(atoms_in(damaged, [](double, double, double) { return true; }), std::invalid_argument);
}
