// Unit tests of the particle feedback validation.
// SPDX-License-Identifier: GPL-3.0-or-later
#include <gtest/gtest.h>

#include "cell_fields.h"
#include "feedback_check.h"
#include "over_the_wire.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

namespace {

hemo::particle_feedback_t good(int n) {
  hemo::particle_feedback_t fb;
  fb.envelope.step = 7;
  fb.mesh_hash = "abc";
  hemo::resize_cells(fb, n);
  std::fill(fb.solid_fraction.begin(), fb.solid_fraction.end(), 0.2);
  for (int c = 0; c < n; ++c) {
    double* s = hemo::source_of(fb, c);
    s[0] = 1, s[1] = 2, s[2] = 3;
  }
  std::fill(fb.drag_coefficient.begin(), fb.drag_coefficient.end(), 1e3);
  return fb;
}

TEST(FeedbackCheck, AcceptsAGoodMessage) { EXPECT_EQ(hemo::feedback_problem(good(5), "abc", 5), ""); }

TEST(FeedbackCheck, NamesEachCauseOnOneLine) {
  auto expect = [](const hemo::particle_feedback_t& fb, int n, const std::string& words) {
    const std::string p = hemo::feedback_problem(fb, "abc", n);
    EXPECT_NE(p.find(words), std::string::npos) << p;
    EXPECT_EQ(p.find('\n'), std::string::npos) << p;
    EXPECT_NE(p.find("step 7"), std::string::npos) << p;
  };
  auto fb = good(5);
  fb.mesh_hash = "xyz";
  expect(fb, 5, "for mesh 'xyz'");
  expect(good(4), 5, "has 4 cells, the fluid mesh 5");
  fb = good(5);
  fb.drag_coefficient.pop_back();
  expect(fb, 5, "cells");
  fb = good(5);
  fb.solid_fraction[3] = 1.0;
  expect(fb, 5, "cell 3 has solid fraction 1");
  expect(fb, 5, "more volume than it has");  // a physical overfill says what it means
  fb = good(5);
  fb.solid_fraction[1] = std::numeric_limits<double>::quiet_NaN();
  expect(fb, 5, "cell 1 has solid fraction nan");
  EXPECT_EQ(hemo::feedback_problem(fb, "abc", 5).find("more volume"), std::string::npos);  // NaN: not a packing
  fb = good(5);
  fb.solid_fraction[2] = -0.1;
  expect(fb, 5, "cell 2 has solid fraction -0.1");
  fb = good(5);
  fb.drag_coefficient[4] = -1;
  expect(fb, 5, "cell 4 has drag coefficient -1");
  fb = good(5);
  hemo::source_of(fb, 0)[2] = std::numeric_limits<double>::infinity();
  expect(fb, 5, "cell 0 has a non-finite explicit source");
}

TEST(FeedbackCheck, RejectsAForgedSourceLength) {
  EXPECT_EQ(hemo::feedback_problem(hemo::test::over_the_wire(good(5)), "abc", 5), "");
  // n_cells fits the mesh but the explicit source holds one value too few or a cell too many:
  // it decodes fine and must not reach the solver.
  auto fb = good(5);
  fb.n_source_values = 14;
  fb.source_explicit.resize(14);
  EXPECT_EQ(hemo::feedback_problem(hemo::test::over_the_wire(fb), "abc", 5),
            "particle feedback: explicit source has 14 values, not 3 per cell of 5 cells (step 7)");
  fb = good(5);
  fb.n_source_values = 18;
  fb.source_explicit.resize(18);
  EXPECT_EQ(hemo::feedback_problem(hemo::test::over_the_wire(fb), "abc", 5),
            "particle feedback: explicit source has 18 values, not 3 per cell of 5 cells (step 7)");
  // A length field that disagrees with its own array (built in process, never encoded).
  fb = good(5);
  fb.n_source_values = 5;
  EXPECT_EQ(hemo::feedback_problem(fb, "abc", 5),
            "particle feedback: explicit source has 5 values, not 3 per cell of 5 cells (step 7)");
}

}  // namespace
