// The coordinator's ledger of which rank of a node reported which step, and which rank is
// silent (coordinator/rank_reports.h), on a clock held by the test.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "rank_reports.h"

#include <gtest/gtest.h>

using namespace hemo;

// A step is done only when every rank reported it, whatever the order the reports come in.
TEST(RankReports, AStepIsDoneOnlyWhenEveryRankReportedIt) {
  RankReports reports(3, 0.0);
  EXPECT_EQ(reports.done_step(), -1);
  EXPECT_TRUE(reports.reported(2, 0, 0.1));
  EXPECT_TRUE(reports.reported(0, 0, 0.2));
  EXPECT_EQ(reports.done_step(), -1);
  EXPECT_EQ(reports.missing(0), std::vector<int>{1});
  EXPECT_TRUE(reports.reported(1, 0, 0.3));
  EXPECT_EQ(reports.done_step(), 0);
  EXPECT_TRUE(reports.reported(0, 1, 0.4));
  EXPECT_TRUE(reports.reported(1, 1, 0.4));
  EXPECT_EQ(reports.done_step(), 0);
  EXPECT_EQ(reports.missing(1), std::vector<int>{2});
  // A resend of a report already taken, or an older one, counts once; a rank the node does not have is not taken.
  EXPECT_FALSE(reports.reported(1, 1, 0.5));
  EXPECT_FALSE(reports.reported(1, 0, 0.5));
  EXPECT_FALSE(reports.reported(3, 1, 0.5));
  EXPECT_FALSE(reports.reported(-1, 1, 0.5));
  EXPECT_TRUE(reports.reported(2, 1, 0.6));
  EXPECT_EQ(reports.done_step(), 1);
  EXPECT_TRUE(reports.missing(1).empty());
}

// The hello's count replaces the launch's: fewer ranks, and a step is done without the others.
TEST(RankReports, TheHellosRankCountReplacesTheLaunchs) {
  RankReports reports(2, 0.0);
  EXPECT_TRUE(reports.reported(0, 0, 0.1));
  EXPECT_EQ(reports.done_step(), -1);
  reports.set_ranks(1, 0.2);
  EXPECT_EQ(reports.ranks(), 1);
  EXPECT_EQ(reports.done_step(), 0);
  reports.set_ranks(2, 0.3);
  EXPECT_EQ(reports.done_step(), -1);
  EXPECT_EQ(reports.missing(0), std::vector<int>{1});
}

// A rank >= 1 has the start-up allowance until first heard, then the node timeout; rank 0's
// silence is its node's (its heartbeat), not judged here. The first silent rank is named.
TEST(RankReports, ARankSilentForLongerThanItMayBeIsNamed) {
  RankReports reports(3, 10.0);
  EXPECT_FALSE(reports.silent(14.0, 1.0, 5.0));  // both starting up: 4 s of 5
  const auto unstarted = reports.silent(15.5, 1.0, 5.0);
  ASSERT_TRUE(unstarted);
  EXPECT_EQ(unstarted->rank, 1);
  EXPECT_FALSE(unstarted->started);

  reports.heard(1, 15.0);
  reports.heard(2, 15.0);
  EXPECT_FALSE(reports.silent(15.9, 1.0, 5.0));
  reports.heard(1, 15.8);
  EXPECT_TRUE(reports.reported(2, 0, 15.9));  // a report is heard too
  EXPECT_FALSE(reports.silent(16.7, 1.0, 5.0));
  const auto stopped = reports.silent(16.95, 1.0, 5.0);
  ASSERT_TRUE(stopped);
  EXPECT_EQ(stopped->rank, 1);
  EXPECT_TRUE(stopped->started);
  EXPECT_NEAR(stopped->for_s, 1.15, 1e-12);

  // The coordinator's own pause of 2 s is no rank's silence.
  reports.forgive(2.0, 17.0);
  EXPECT_FALSE(reports.silent(17.0, 1.0, 5.0));
}

TEST(RankReports, RanksAreNamedInOneList) {
  EXPECT_EQ(rank_list_words({1}, 2), "rank 1 of 2");
  EXPECT_EQ(rank_list_words({0, 1, 3}, 4), "ranks 0, 1, 3 of 4");
}
