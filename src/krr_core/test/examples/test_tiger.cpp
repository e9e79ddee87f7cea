// Tests of the Tiger factory against the problem statement (Kaelbling et al. 1998).
#include <gtest/gtest.h>

#include "krr_core/examples/tiger.h"

namespace krr {
namespace examples {
namespace {

TEST(Tiger, StandardNumbers) {
  pomdp::Model m = makeTiger();
  const std::size_t listen = m.actionIndex("listen"), ol = m.actionIndex("open-left");
  const std::size_t left = m.stateIndex("tiger-left"), right = m.stateIndex("tiger-right");
  EXPECT_EQ(m.getExpectedReward(left, listen), -1.0);
  EXPECT_EQ(m.getExpectedReward(left, ol), -100.0);
  EXPECT_EQ(m.getExpectedReward(right, ol), 10.0);
  EXPECT_EQ(m.getObservationProbability(left, listen, m.observationIndex("tiger-left")), 0.85);
  EXPECT_EQ(m.getTransitionProbability(left, ol, right), 0.5);  // opening resets
  EXPECT_EQ(m.getObservationProbability(left, ol, 0), 0.5);     // and tells nothing
  EXPECT_EQ(m.getDiscount(), 0.95);
  EXPECT_EQ(makeTiger(0.75, 0.7).getObservationProbability(right, listen, 1), 0.7);
}

}  // namespace
}  // namespace examples
}  // namespace krr
