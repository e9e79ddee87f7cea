#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {
namespace {

TEST(NavigationTask, RewardsFoldGoalBonusAndFailurePenalty) {
  // 3x1 grid, cell 1 has an obstacle? No: cell 2 is the goal. From cell 1, "right" reaches
  // the goal w.p. 0.7, is trapped w.p. 0.1 and stays w.p. 0.2.
  GridDynamics d(3, 1);
  d.p(1, kActRight, kStay) = 0.2;
  d.p(1, kActRight, kRight) = 0.7;
  d.p(1, kActRight, kFail) = 0.1;
  NavigationReward r;
  r.step_cost = 1.0;
  r.rmax = 40.0;
  GridModel g = makeNavigationGridModel(d, {2}, r, 0.9);
  // R = -1 + 0.7 * 40 - 0.1 * 40 = 23.
  EXPECT_NEAR(g.getExpectedReward(1, kActRight), 23.0, 1e-12);
  EXPECT_TRUE(g.isTerminal(2));
  // Same through the general helper on top of the transition model.
  SparseModel dyn = makeNavigationGridModel(d, {}, r, 0.9).toSparse();
  SparseModel t = makeNavigationTask(dyn, {2}, {g.failureState()}, r);
  EXPECT_NEAR(t.getExpectedReward(1, kActRight), 23.0, 1e-12);
  EXPECT_TRUE(t.isTerminal(2));
  EXPECT_TRUE(t.isTerminal(3));
  // V(1) = 23 + 0.9 * 0.2 * V(1) -> V(1) = 23 / 0.82.
  SolverOptions o;
  o.epsilon = 1e-10;
  EXPECT_NEAR(valueIteration(t, o).values[1], 23.0 / 0.82, 1e-9);
}

TEST(NavigationTask, MovesIntoObstaclesStayInPlace) {
  GridDynamics d(3, 1);
  d.blocked[1] = 1;
  d.p(0, kActRight, kStay) = 0.0;
  d.p(0, kActRight, kRight) = 1.0;
  GridModel g = makeNavigationGridModel(d, {2}, NavigationReward(), 0.9);
  EXPECT_DOUBLE_EQ(g.getTransitionProbability(0, kActRight, 0), 1.0);
  EXPECT_TRUE(g.isTerminal(1));  // obstacles are never entered
  EXPECT_FALSE(reachable(d, 0)[2]);
  EXPECT_THROW(makeNavigationGridModel(d, {1}, NavigationReward(), 0.9), ConfigError);
  EXPECT_THROW(makeNavigationGridModel(d, {7}, NavigationReward(), 0.9), ConfigError);
}

TEST(NavigationTask, RandomDynamicsAreValidAndKeepRequestedCellsFree) {
  Rng rng = makeRng(9, "nav");
  RandomGridOptions o;
  o.obstacle_density = 0.5;
  GridDynamics d = makeRandomGridDynamics(20, 20, o, {0, 399}, rng);
  EXPECT_NO_THROW(d.validate());
  EXPECT_EQ(d.blocked[0], 0);
  EXPECT_EQ(d.blocked[399], 0);
  o.p_intended = 0.95;  // with p_side 0.1 x 2 the probabilities exceed 1
  EXPECT_THROW(makeRandomGridDynamics(5, 5, o, {}, rng), ConfigError);
  NavigationReward bad;
  bad.rmax = 0.0;
  EXPECT_THROW(bad.validate(), ConfigError);
}

}  // namespace
}  // namespace mdp
}  // namespace krr
