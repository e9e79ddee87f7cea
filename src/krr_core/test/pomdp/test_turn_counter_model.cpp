// Tests of withTurnCounter: sizes, moves between turns, the forbidden question at the limit.
#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/turn_counter_model.h"
#include "turn_limited_test_support.h"

namespace krr {
namespace pomdp {
namespace {

TEST(TurnCounterModel, CountsTurnsAndForbidsQuestionsAtTheLimit) {
  const Model m = test::oneShotTiger(0.95);
  const Model c = withTurnCounter(m, m.initialBelief(), 2);
  ASSERT_EQ(c.getS(), 9u);
  EXPECT_EQ(c.stateNames()[4], "tiger-right_t1");
  EXPECT_DOUBLE_EQ(c.getTransitionProbability(0, 0, 3), 1.0);  // listen: turn 0 -> 1
  EXPECT_DOUBLE_EQ(c.getTransitionProbability(3, 1, 5), 1.0);  // open: done at the same turn
  EXPECT_DOUBLE_EQ(c.getTransitionProbability(6, 0, 8), 1.0);  // listen at the limit ends
  EXPECT_LT(c.getExpectedReward(6, 0), -100.0);                // ... worse than any door
  EXPECT_TRUE(c.isTerminal(8));
  EXPECT_DOUBLE_EQ(c.initialBelief()(0), 0.5);
  EXPECT_DOUBLE_EQ(c.initialBelief()(3), 0.0);
  EXPECT_THROW(withTurnCounter(m, m.initialBelief(), -1), ConfigError);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
