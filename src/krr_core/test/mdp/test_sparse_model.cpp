#include <gtest/gtest.h>

#include <map>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/mdp/sparse_model.h"

namespace krr {
namespace mdp {
namespace {

SparseModel twoStateModel() {
  SparseModelBuilder b(3, 2, 0.9);
  b.addTransition(0, 0, 1, 0.25, 4.0);  // R(0,0) folds 0.25 * 4 = 1
  b.addTransition(0, 0, 0, 0.75);
  b.addTransition(0, 1, 2, 0.5);
  b.addTransition(0, 1, 2, 0.5);  // duplicates accumulate to 1
  b.addReward(0, 1, -2.0);
  b.addTransition(1, 0, 0, 1.0);
  b.addTransition(1, 1, 1, 1.0);
  b.setTerminal(2);
  return b.build();
}

TEST(SparseModel, BuilderPacksRowsFoldsRewardsAndAddsTerminalSelfLoops) {
  SparseModel m = twoStateModel();
  EXPECT_EQ(m.getS(), 3u);
  EXPECT_EQ(m.getA(), 2u);
  EXPECT_DOUBLE_EQ(m.getDiscount(), 0.9);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 0, 1), 0.25);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 0, 0), 0.75);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 0, 2), 0.0);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 1, 2), 1.0);
  EXPECT_EQ(m.successors(0, 1).size(), 1u);  // merged duplicate
  EXPECT_DOUBLE_EQ(m.getExpectedReward(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(m.getExpectedReward(0, 1), -2.0);
  EXPECT_TRUE(m.isTerminal(2));
  EXPECT_FALSE(m.isTerminal(0));
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(2, 1, 2), 1.0);  // self-loop
  // Rows are sorted by next state.
  auto r = m.successors(0, 0);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r.state(0), 0u);
  EXPECT_EQ(r.state(1), 1u);
  double sum = 0.0;
  for (Outcome o : r) sum += o.probability;
  EXPECT_DOUBLE_EQ(sum, 1.0);
}

TEST(SparseModel, SampleFollowsTheDistribution) {
  SparseModel m = twoStateModel();
  Rng rng = makeRng(7, "sparse_model");
  const int n = 40000;
  int ones = 0;
  for (int i = 0; i < n; ++i) {
    auto sr = m.sampleSR(0, 0, rng);
    EXPECT_DOUBLE_EQ(sr.second, 1.0);
    ones += sr.first == 1;
  }
  // p = 0.25, sd = sqrt(0.25*0.75/n) = 0.00217; 5 sd tolerance.
  EXPECT_NEAR(ones / static_cast<double>(n), 0.25, 5 * 0.00217);
  auto t = m.sampleSR(2, 0, rng);
  EXPECT_EQ(t.first, 2u);
  EXPECT_DOUBLE_EQ(t.second, 0.0);
}

TEST(SparseModel, RowNotSummingToOneNamesPairAndSum) {
  SparseModelBuilder b(2, 1, 0.9);
  b.addTransition(0, 0, 1, 0.5);
  b.addTransition(0, 0, 0, 0.4);
  b.addTransition(1, 0, 1, 1.0);
  try {
    b.build();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("s=0, a=0"), std::string::npos) << w;
    EXPECT_NE(w.find("0.9"), std::string::npos) << w;
  }
}

TEST(SparseModel, InvalidInputsThrowConfigError) {
  EXPECT_THROW(SparseModelBuilder(0, 1, 0.9), ConfigError);
  EXPECT_THROW(SparseModelBuilder(2, 1, 1.5), ConfigError);
  SparseModelBuilder b(2, 1, 0.9);
  EXPECT_THROW(b.addTransition(0, 0, 2, 0.5), ConfigError);   // next state out of range
  EXPECT_THROW(b.addTransition(2, 0, 0, 0.5), ConfigError);   // state out of range
  EXPECT_THROW(b.addTransition(0, 1, 0, 0.5), ConfigError);   // action out of range
  EXPECT_THROW(b.addTransition(0, 0, 0, 1.5), ConfigError);   // probability > 1
  EXPECT_THROW(b.addTransition(0, 0, 0, -0.1), ConfigError);  // probability < 0
  // A non-terminal state without transitions has a row summing to 0.
  SparseModelBuilder c(2, 1, 0.9);
  c.addTransition(0, 0, 1, 1.0);
  EXPECT_THROW(c.build(), ConfigError);
  // Direct CSR construction is validated too.
  EXPECT_THROW(SparseModel(1, 1, 0.9, {0, 1}, {0}, {0.5}, {0.0}, {0}), ConfigError);
  EXPECT_THROW(SparseModel(1, 1, 0.9, {0, 1}, {3}, {1.0}, {0.0}, {0}), ConfigError);
  EXPECT_THROW(SparseModel(2, 1, 0.9, {0, 2, 3}, {1, 0, 1}, {0.5, 0.5, 1.0}, {0.0, 0.0}, {0, 0}),
               ConfigError);  // unsorted row
  EXPECT_NO_THROW(SparseModel(1, 1, 0.9, {0, 1}, {0}, {1.0}, {0.0}, {0}));
}

}  // namespace
}  // namespace mdp
}  // namespace krr
