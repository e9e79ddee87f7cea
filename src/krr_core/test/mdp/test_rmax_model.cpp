#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/rmax_model.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {
namespace {

// Chain 0 - 1 - 2 (goal); actions 0 = left, 1 = right; -1 per move, +10 at the goal.
RMaxTask chainTask() {
  NavigationReward r;
  r.step_cost = 1.0;
  r.rmax = 10.0;
  return makeNavigationRMaxTask(3, 2, {2}, {}, r);
}

TEST(RMaxModel, UnknownPairsLeadToTheOptimisticState) {
  RMaxModel m(chainTask(), 0.9, 3, 10.0);
  EXPECT_EQ(m.getS(), 4u);
  EXPECT_EQ(m.optimisticState(), 3u);
  EXPECT_TRUE(m.isTerminal(3));
  EXPECT_TRUE(m.isTerminal(2));
  EXPECT_FALSE(m.isKnown(0, 1));
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 1, 3), 1.0);
  EXPECT_DOUBLE_EQ(m.getExpectedReward(0, 1), 10.0);  // terminal bonus Rmax
  RMaxModel self(chainTask(), 0.9, 3, 10.0, Optimism::kSelfLoop);
  EXPECT_DOUBLE_EQ(self.getExpectedReward(0, 1), 100.0);  // Rmax / (1 - 0.9)
  // Every value is optimistic: V = Rmax everywhere before anything is known.
  Solution s = valueIterationView(m, SolverOptions());
  EXPECT_NEAR(s.values[0], 10.0, 1e-6);
}

TEST(RMaxModel, PairBecomesKnownAfterMSamplesAndFreezes) {
  RMaxModel m(chainTask(), 0.9, 3, 10.0);
  EXPECT_EQ(m.observe(1, 1, 2), RMaxModel::Update::kNone);
  EXPECT_EQ(m.observe(1, 1, 1), RMaxModel::Update::kNone);
  EXPECT_FALSE(m.isKnown(1, 1));
  EXPECT_EQ(m.observe(1, 1, 2), RMaxModel::Update::kNewlyKnown);
  ASSERT_TRUE(m.isKnown(1, 1));
  EXPECT_EQ(m.numKnown(), 1u);
  // Empirical: 2/3 to the goal, 1/3 stay. Reward = -1 + (2/3) * 10.
  EXPECT_NEAR(m.getTransitionProbability(1, 1, 2), 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(m.getTransitionProbability(1, 1, 1), 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(m.getExpectedReward(1, 1), -1.0 + 20.0 / 3.0, 1e-12);
  // Frozen (R-Max): more samples do not change the known distribution.
  EXPECT_EQ(m.observe(1, 1, 1), RMaxModel::Update::kNone);
  EXPECT_NEAR(m.getTransitionProbability(1, 1, 2), 2.0 / 3.0, 1e-15);
  EXPECT_EQ(m.counts().count(1, 1), 4u);
  // The write-back list has the pair and its distribution.
  std::vector<KnownPair> k = m.knownPairs();
  ASSERT_EQ(k.size(), 1u);
  EXPECT_EQ(k[0].state, 1u);
  EXPECT_EQ(k[0].action, 1u);
  EXPECT_EQ(k[0].samples, 4u);
  EXPECT_FALSE(k[0].from_prior);
  ASSERT_EQ(k[0].distribution.size(), 2u);
  EXPECT_EQ(m.predecessors(2), std::vector<StateId>{1});
  EXPECT_EQ(m.takeChanged(), std::vector<StateId>{1});
  EXPECT_TRUE(m.takeChanged().empty());
  // The exported model is a valid SparseModel with the same numbers.
  SparseModel sm = m.toSparse();
  EXPECT_NEAR(sm.getTransitionProbability(1, 1, 2), 2.0 / 3.0, 1e-15);
  EXPECT_DOUBLE_EQ(sm.getTransitionProbability(0, 0, 3), 1.0);
}

TEST(RMaxModel, RefineKnownKeepsFollowingTheSamples) {
  RMaxModel m(chainTask(), 0.9, 2, 10.0, Optimism::kTerminalBonus, true);
  m.observe(0, 1, 1);
  EXPECT_EQ(m.observe(0, 1, 1), RMaxModel::Update::kNewlyKnown);
  EXPECT_EQ(m.observe(0, 1, 0), RMaxModel::Update::kRefined);
  EXPECT_NEAR(m.getTransitionProbability(0, 1, 1), 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(m.getTransitionProbability(0, 1, 0), 1.0 / 3.0, 1e-15);
}

TEST(RMaxModel, PriorMakesAPairKnownFromTheStartUntilOwnDataReplacesIt) {
  RMaxModel m(chainTask(), 0.9, 2, 10.0);
  m.setPrior(1, 1, {{2, 0.75}, {1, 0.25}});
  EXPECT_TRUE(m.isKnown(1, 1));
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(1, 1, 2), 0.75);
  EXPECT_NEAR(m.getExpectedReward(1, 1), -1.0 + 7.5, 1e-12);
  ASSERT_EQ(m.knownPairs().size(), 1u);
  EXPECT_TRUE(m.knownPairs()[0].from_prior);
  EXPECT_EQ(m.observe(1, 1, 2), RMaxModel::Update::kNone);
  EXPECT_EQ(m.observe(1, 1, 2), RMaxModel::Update::kRefined);  // M own samples
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(1, 1, 2), 1.0);
  EXPECT_FALSE(m.knownPairs()[0].from_prior);
  // known = false records the prior but keeps the pair optimistic.
  m.setPrior(0, 1, {{1, 1.0}}, false);
  EXPECT_FALSE(m.isKnown(0, 1));
  EXPECT_EQ(m.prior(0, 1).size(), 1u);
}

TEST(RMaxModel, InvalidPriorsAndParametersThrowConfigError) {
  RMaxModel m(chainTask(), 0.9, 2, 10.0);
  EXPECT_THROW(m.setPrior(0, 1, {{1, 0.5}, {0, 0.4}}), ConfigError);  // sums to 0.9
  EXPECT_THROW(m.setPrior(0, 1, {{7, 1.0}}), ConfigError);            // state out of range
  EXPECT_THROW(m.setPrior(0, 1, {{1, 1.5}, {0, -0.5}}), ConfigError);
  EXPECT_THROW(m.setPrior(2, 0, {{1, 1.0}}), ConfigError);  // terminal
  EXPECT_THROW(m.setPrior(0, 2, {{1, 1.0}}), ConfigError);  // action out of range
  EXPECT_THROW(m.observe(0, 0, 3), ConfigError);  // the optimistic state is not observable
  EXPECT_THROW(RMaxModel(chainTask(), 0.9, 0, 10.0), ConfigError);
  EXPECT_THROW(RMaxModel(chainTask(), 0.9, 2, 0.0), ConfigError);
  EXPECT_THROW(RMaxModel(chainTask(), 1.0, 2, 10.0, Optimism::kSelfLoop), ConfigError);
  RMaxTask bad = chainTask();
  bad.arrival_reward.pop_back();
  EXPECT_THROW(RMaxModel(bad, 0.9, 2, 10.0), ConfigError);
}

TEST(RMaxModel, RowsGrowBeyondTheirInitialCapacity) {
  RMaxTask t = makeNavigationRMaxTask(8, 1, {}, {}, NavigationReward());
  RMaxModel m(t, 0.9, 8, 40.0);
  for (StateId s1 = 0; s1 < 8; ++s1) m.observe(0, 0, s1);
  ASSERT_TRUE(m.isKnown(0, 0));
  EXPECT_EQ(m.successors(0, 0).size(), 8u);
  for (StateId s1 = 0; s1 < 8; ++s1) EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 0, s1), 0.125);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(1, 0, 8), 1.0);  // others unchanged
}

}  // namespace
}  // namespace mdp
}  // namespace krr
