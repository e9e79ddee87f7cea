// Tests of pomdp::Model: validation, accessors, derived structure, sampling.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/pomdp/model.h"
#include "krr_core/examples/tiger.h"

namespace krr {
namespace pomdp {
using examples::makeTiger;
namespace {

std::string configError(std::vector<Eigen::MatrixXd> t, std::vector<Eigen::MatrixXd> z,
                        Eigen::MatrixXd r, double g) {
  try {
    Model m(t, z, r, g);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Model, TigerAccessors) {
  Model m = makeTiger();
  EXPECT_EQ(m.getS(), 2u);
  EXPECT_EQ(m.getA(), 3u);
  EXPECT_EQ(m.getO(), 2u);
  EXPECT_DOUBLE_EQ(m.getDiscount(), 0.95);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 0, 0), 1.0);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 1, 1), 0.5);
  EXPECT_DOUBLE_EQ(m.getObservationProbability(1, 0, 1), 0.85);
  EXPECT_DOUBLE_EQ(m.getExpectedReward(0, 1), -100.0);  // open-left with tiger left
  EXPECT_DOUBLE_EQ(m.getExpectedReward(1, 1), 10.0);
  EXPECT_TRUE(m.isIdentityTransition(0));
  EXPECT_FALSE(m.isIdentityTransition(1));
  EXPECT_FALSE(m.hasTerminalStates());
  EXPECT_EQ(m.possibleObservations(0).size(), 2u);
  EXPECT_EQ(m.actionIndex("open-right"), 2u);
  EXPECT_THROW(m.actionIndex("jump"), UnknownSymbolError);
}

TEST(Model, ValidationNamesActionStateAndSum) {
  Eigen::MatrixXd t(2, 2), z = Eigen::MatrixXd::Identity(2, 2), r = Eigen::MatrixXd::Zero(2, 1);
  t << 1, 0, 0.3, 0.6;
  EXPECT_EQ(configError({t}, {z}, r, 0.9),
            "POMDP model: transition row of action 0, state 1 sums to 0.9 (expected 1)");
  t << 1, 0, 0, 1;
  Eigen::MatrixXd zb(2, 2);
  zb << 0.5, 0.5, 0.7, 0.7;
  EXPECT_EQ(configError({t}, {zb}, r, 0.9),
            "POMDP model: observation row of action 0, next state 1 sums to 1.4 (expected 1)");
  Eigen::MatrixXd tn(2, 2);
  tn << 1.5, -0.5, 0, 1;
  EXPECT_NE(configError({tn}, {z}, r, 0.9).find("T(action 0, state 0, next 0) = 1.5"),
            std::string::npos);
  EXPECT_NE(configError({t}, {z}, r, 1.5).find("discount 1.5"), std::string::npos);
  EXPECT_NE(configError({t}, {z}, Eigen::MatrixXd::Zero(3, 1), 0.9).find("reward matrix"),
            std::string::npos);
  EXPECT_NE(configError({t}, {z, z}, r, 0.9).find("2 observation matrices for 1 actions"),
            std::string::npos);
}

// Issue 24: rewards must keep every bound finite; the limit is |R| <= Model::kMaxAbsReward.
TEST(Model, RewardsBeyondTheLimitAreRefused) {
  Eigen::MatrixXd t = Eigen::MatrixXd::Identity(2, 2), z = Eigen::MatrixXd::Identity(2, 2);
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(2, 1);
  r(1, 0) = -1e308;
  EXPECT_EQ(configError({t}, {z}, r, 0.95),
            "POMDP model: reward R(s1, a0) = -1e+308 is above the limit |R| <= 1e+12 "
            "that keeps the bounds finite");
  r(1, 0) = std::nextafter(Model::kMaxAbsReward, 1e300);
  EXPECT_NE(configError({t}, {z}, r, 0.95).find("above the limit"), std::string::npos);
  r(1, 0) = -Model::kMaxAbsReward;  // the limit itself is a valid model, finite bounds
  EXPECT_EQ(configError({t}, {z}, r, 0.95), "no error");
  r(1, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(configError({t}, {z}, r, 0.95).find("non-finite"), std::string::npos);
}

TEST(Model, DetectsTerminalStatesAndInitialBeliefChecks) {
  // state 1 is absorbing with zero reward under every action -> terminal
  Eigen::MatrixXd t(2, 2), z = Eigen::MatrixXd::Constant(2, 1, 1.0), r(2, 1);
  t << 0, 1, 0, 1;
  r << 5, 0;
  Model m({t}, {z}, r, 0.9);
  EXPECT_FALSE(m.isTerminal(0));
  EXPECT_TRUE(m.isTerminal(1));
  EXPECT_TRUE(m.hasTerminalStates());
  Belief bad(2);
  bad << 0.5, 0.6;
  EXPECT_THROW(m.setInitialBelief(bad), ConfigError);
  EXPECT_THROW(m.setNames({"a", "a"}, {"x"}, {"o"}), ConfigError);
}

TEST(Model, SampleSorFollowsTheModel) {
  Model m = makeTiger();
  Rng rng = makeRng(42, "model-test");
  const int n = 20000;
  int sameState = 0, correctHear = 0;
  for (int i = 0; i < n; ++i) {
    auto [s1, o, r] = m.sampleSOR(0, 0, rng);  // listen with the tiger on the left
    EXPECT_EQ(r, -1.0);
    sameState += s1 == 0;
    correctHear += o == 0;
  }
  EXPECT_EQ(sameState, n);
  // P(hear left) = 0.85; sd of the frequency = sqrt(.85*.15/n) = 0.0025; allow 4 sd
  EXPECT_NEAR(correctHear / double(n), 0.85, 0.01);
  int left = 0;
  for (int i = 0; i < n; ++i) left += std::get<0>(m.sampleSOR(0, 1, rng)) == 0;  // reset
  EXPECT_NEAR(left / double(n), 0.5, 0.015);  // sd 0.0035
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
