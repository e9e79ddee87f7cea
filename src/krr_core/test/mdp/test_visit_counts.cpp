#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/visit_counts.h"

namespace krr {
namespace mdp {
namespace {

TEST(VisitCounts, CountsAreSparseSortedAndGiveEmpiricalDistributions) {
  VisitCounts c(5, 2);
  c.add(1, 0, 4);
  c.add(1, 0, 2);
  c.add(1, 0, 4);
  c.add(1, 0, 3, 5);
  EXPECT_EQ(c.count(1, 0), 8u);
  EXPECT_EQ(c.count(1, 0, 4), 2u);
  EXPECT_EQ(c.count(1, 0, 0), 0u);
  EXPECT_EQ(c.count(1, 1), 0u);
  ASSERT_EQ(c.outcomes(1, 0).size(), 3u);
  EXPECT_EQ(c.outcomes(1, 0)[0].state, 2u);
  EXPECT_EQ(c.outcomes(1, 0)[1].state, 3u);
  EXPECT_EQ(c.outcomes(1, 0)[2].state, 4u);
  Distribution d = c.empirical(1, 0);
  ASSERT_EQ(d.size(), 3u);
  EXPECT_DOUBLE_EQ(d[0].probability, 1.0 / 8);  // state 2
  EXPECT_DOUBLE_EQ(d[1].probability, 5.0 / 8);  // state 3
  EXPECT_DOUBLE_EQ(d[2].probability, 2.0 / 8);  // state 4
  EXPECT_TRUE(c.empirical(0, 0).empty());
}

TEST(VisitCounts, MergeAddsAndResetClears) {
  VisitCounts a(3, 1), b(3, 1);
  a.add(0, 0, 1, 2);
  b.add(0, 0, 1, 3);
  b.add(0, 0, 2, 1);
  a.merge(b);
  EXPECT_EQ(a.count(0, 0), 6u);
  EXPECT_EQ(a.count(0, 0, 1), 5u);
  EXPECT_EQ(a.count(0, 0, 2), 1u);
  a.reset();
  EXPECT_EQ(a.count(0, 0), 0u);
  EXPECT_TRUE(a.outcomes(0, 0).empty());
  VisitCounts other(4, 1);
  EXPECT_THROW(a.merge(other), ConfigError);
  EXPECT_THROW(a.add(3, 0, 0), ConfigError);
  EXPECT_THROW(a.add(0, 1, 0), ConfigError);
  EXPECT_THROW(VisitCounts(0, 1), ConfigError);
}

}  // namespace
}  // namespace mdp
}  // namespace krr
