// Tests of exact belief tracking and belief statistics.
#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/examples/tiger.h"

namespace krr {
namespace pomdp {
using examples::makeTiger;
namespace {

TEST(Belief, TigerUpdateByHand) {
  Model m = makeTiger();
  const std::size_t listen = 0, hearLeft = 0;
  Belief b = m.initialBelief();
  // P(hear-left | uniform) = 0.5 * 0.85 + 0.5 * 0.15 = 0.5
  EXPECT_DOUBLE_EQ(observationProbability(m, b, listen, hearLeft), 0.5);
  // b'(left) = 0.85 * 0.5 / 0.5 = 0.85
  b = updateBelief(m, b, listen, hearLeft);
  EXPECT_NEAR(b(0), 0.85, 1e-15);
  EXPECT_NEAR(b(1), 0.15, 1e-15);
  // second hear-left: 0.85^2 / (0.85^2 + 0.15^2) = 0.7225 / 0.745 = 0.969799...
  b = updateBelief(m, b, listen, hearLeft);
  EXPECT_NEAR(b(0), 0.7225 / 0.745, 1e-14);
  // opening a door resets to uniform whatever was heard
  Belief c = updateBelief(m, b, 1, 1);
  EXPECT_NEAR(c(0), 0.5, 1e-15);
}

TEST(Belief, ZeroProbabilityObservationIsReported) {
  Model m = makeTiger(0.95, 1.0);  // perfect hearing
  Belief sure(2);
  sure << 1.0, 0.0;
  Belief out(2);
  out << 7, 7;
  double p = -1;
  EXPECT_FALSE(tryUpdateBelief(m, sure, 0, 1, out, &p));
  EXPECT_EQ(p, 0.0);
  EXPECT_EQ(out(0), 7.0);  // untouched
  EXPECT_THROW(updateBelief(m, sure, 0, 1), IncoherentError);
  EXPECT_THROW(updateBelief(m, sure, 5, 0), ConfigError);  // bad action index
}

TEST(Belief, EntropyInNatsAndBits) {
  Belief u(4);
  u << 0.25, 0.25, 0.25, 0.25;
  EXPECT_NEAR(entropy(u), std::log(4.0), 1e-15);
  EXPECT_NEAR(entropy(u, EntropyUnit::kBits), 2.0, 1e-15);
  Belief d(3);
  d << 1.0, 0.0, 0.0;
  EXPECT_EQ(entropy(d), 0.0);
  // -(0.9 ln 0.9 + 0.1 ln 0.1) = 0.325083
  Belief e(2);
  e << 0.9, 0.1;
  EXPECT_NEAR(entropy(e), 0.3250829733914482, 1e-15);
}

TEST(Belief, MarginalsAndArgmax) {
  Belief b(4);
  b << 0.1, 0.2, 0.3, 0.4;
  Eigen::VectorXd mg = marginal(b, {0, 1, 0, -1}, 2);  // state 3 excluded (terminal)
  EXPECT_NEAR(mg(0), 0.4, 1e-15);
  EXPECT_NEAR(mg(1), 0.2, 1e-15);
  EXPECT_EQ(argmaxState(b), 3u);
  EXPECT_THROW(marginal(b, {0, 1}, 2), ConfigError);
  EXPECT_THROW(marginal(b, {0, 1, 5, 0}, 2), ConfigError);
  Model m = makeTiger();
  Belief t(2);
  t << 0.25, 0.75;
  // open-left: 0.25 * -100 + 0.75 * 10 = -17.5
  EXPECT_DOUBLE_EQ(expectedReward(m, t, 1), -17.5);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
