// Tests of DialogController (execution with the turn limit) and simulateDialogs.
#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/dialog_pomdp.h"

namespace krr {
namespace pomdp {
namespace {

DialogPomdp makeDialog(int turnLimit = 20) {
  DialogSpec spec;
  spec.prior = ownOfficePrior(3, 5, {0, 1}, 0.8);
  Eigen::VectorXd reach(5);
  reach << 0.95, 0.65, 0.75, 0.95, 0.5;
  spec.delivery = deliveryMatrix(3, reach, 2);
  spec.turnLimit = turnLimit;
  return DialogPomdp(spec);
}

/// A one-vector policy that always takes action a.
AlphaVectorPolicy constantPolicy(const DialogPomdp& d, std::size_t a) {
  AlphaVectorPolicy p(d.model().getS());
  p.add(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(d.model().getS())), a);
  return p;
}

TEST(DialogController, TurnLimitForcesServingTheMostLikelyRequest) {
  DialogPomdp d = makeDialog();
  AlphaVectorPolicy askForever = constantPolicy(d, d.askRoom());
  DialogController ctl(d, askForever);
  for (int t = 0; t < 20; ++t) {
    EXPECT_FALSE(ctl.atTurnLimit());
    const std::size_t a = ctl.nextAction();
    ASSERT_EQ(a, d.askRoom()) << "turn " << t;
    ctl.observe(a, d.obsRoom(2));  // the user keeps saying room3
  }
  EXPECT_EQ(ctl.turns(), 20);
  EXPECT_TRUE(ctl.atTurnLimit());
  const std::size_t forced = ctl.nextAction();
  ASSERT_TRUE(d.isServe(forced));
  // most likely request: room3 (heard 20 times); item uniform -> lowest index (coke);
  // person: prior 50/50 (neither has room3 as office) -> alice (lowest index)
  EXPECT_EQ(d.requestOfServe(forced), d.requestIndex(0, 2, 0));
  ctl.observe(forced, d.obsNone());
  EXPECT_TRUE(ctl.finished());
  EXPECT_THROW(ctl.nextAction(), ConfigError);
  EXPECT_THROW(ctl.observe(d.askRoom(), d.obsRoom(0)), ConfigError);
}

TEST(DialogController, ZeroTurnLimitServesImmediately) {
  DialogPomdp d = makeDialog(0);
  AlphaVectorPolicy askForever = constantPolicy(d, d.askItem());
  DialogController ctl(d, askForever);
  ASSERT_TRUE(d.isServe(ctl.nextAction()));
  // prior argmax: 0.8/6 for own-office requests, first is <coke, room1, alice>
  EXPECT_EQ(d.requestOfServe(ctl.nextAction()), d.requestIndex(0, 0, 0));
}

TEST(DialogController, BeliefMarginalsAndEntropy) {
  DialogPomdp d = makeDialog();
  AlphaVectorPolicy p = constantPolicy(d, d.askItem());
  DialogController ctl(d, p);
  // prior entropy: 6 requests with 0.8/6 and 24 with 0.05/6 (nats)
  const double hi = 0.8 / 6, lo = 0.05 / 6;
  EXPECT_NEAR(ctl.entropy(), -6 * hi * std::log(hi) - 24 * lo * std::log(lo), 1e-12);
  EXPECT_NEAR(ctl.entropy(EntropyUnit::kBits), ctl.entropy() / std::log(2.0), 1e-12);
  // "coffee" heard: P(coffee) = (1/3 * 0.8) / (1/3 * 0.8 + 2/3 * 0.1) = 0.8
  ctl.observe(d.askItem(), d.obsItem(1));
  auto mg = ctl.marginals();
  EXPECT_NEAR(mg[0](1), 0.8, 1e-12);
  EXPECT_NEAR(mg[1](0), 0.425, 1e-12);  // rooms untouched by an item answer
  EXPECT_EQ(ctl.turns(), 1);
  ctl.reset();
  EXPECT_EQ(ctl.turns(), 0);
  EXPECT_NEAR(ctl.marginals()[0](1), 1.0 / 3, 1e-12);
  // a policy for another model is rejected
  AlphaVectorPolicy wrong(5);
  EXPECT_THROW(DialogController(d, wrong), ConfigError);
}

TEST(DialogController, SimulationMatchesExpectedRewardOfServingAtOnce) {
  DialogPomdp d = makeDialog();
  const std::size_t target = d.requestIndex(0, 0, 0);
  AlphaVectorPolicy serve = constantPolicy(d, d.serveAction(target));
  // fulfilled probability = sum_s prior(s) T^D(s, target); reward 160 T - 80 in expectation
  const auto& spec = d.spec();
  const double pFul = spec.prior.dot(spec.delivery.col(target));
  const DialogStats st = simulateDialogs(d, serve, 20000, 11);
  EXPECT_EQ(st.meanQuestions, 0.0);
  EXPECT_NEAR(st.meanReturn, 160 * pFul - 80, 4 * st.ci95 / 1.96);  // 4 standard errors
  EXPECT_NEAR(st.fulfilledRate, pFul, 4 * std::sqrt(pFul * (1 - pFul) / 20000));
  EXPECT_NEAR(st.correctRate, spec.prior(target), 0.01);
  // always asking hits the limit every time: 20 questions then a forced serve
  AlphaVectorPolicy ask = constantPolicy(d, d.confirmItem(0));
  const DialogStats st2 = simulateDialogs(d, ask, 200, 11);
  EXPECT_EQ(st2.meanQuestions, 20.0);
  EXPECT_EQ(st2.forcedRate, 1.0);
  EXPECT_NEAR(st2.meanQaCost, 30.0, 1e-9);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
