// BeliefEntropySurvey (Table II): random beliefs, the policy's action, entropy of the beliefs
// under which it delivers; deterministic per (seed, sample) whatever the threads.
#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/experiments/belief_entropy_survey.h"
#include "krr_core/dialog/dialog_session.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/dialog/certified_dialog_solver.h"

namespace {

using namespace krr;
using namespace krr::dialog;
using namespace krr::experiments;

DialogPomdp tinyDialog() {
  DialogSpec spec;
  spec.items = {"coke", "soda"};
  spec.rooms = {"room1", "room2"};
  spec.persons = {"ann", "ben"};
  return DialogPomdp(spec);
}

/// A policy that asks question a before the turn limit (and, as it must, serves at the limit).
pomdp::TurnLimitedPolicy always(const DialogPomdp& d, std::size_t a) {
  const int limit = d.spec().turnLimit;
  pomdp::TurnLimitedPolicy p(d.model().getS(), limit);
  p.add(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(d.model().getS())), a, limit - 1);
  p.add(Eigen::VectorXd::Constant(static_cast<Eigen::Index>(d.model().getS()), -1000.0),
        d.serveAction(0), limit);
  return p;
}

/// Serve the mode when it has at least 0.9, else ask: a threshold policy as alpha vectors
/// (serves usable at every turn, the question before the limit). Serving is worth 80 in
/// tinyDialog (T^D = 1), so decideAction's lookahead never prefers a question to its serves.
pomdp::TurnLimitedPolicy threshold(const DialogPomdp& d) {
  const auto S = static_cast<Eigen::Index>(d.model().getS());
  const int limit = d.spec().turnLimit;
  pomdp::TurnLimitedPolicy p(d.model().getS(), limit);
  p.add(Eigen::VectorXd::Zero(S), d.askItem(), limit - 1);
  for (std::size_t s = 0; s < d.numRequests(); ++s) {
    Eigen::VectorXd a = Eigen::VectorXd::Constant(S, -9.0);  // value 10 b(s) - 9 (1 - b(s))
    a(static_cast<Eigen::Index>(s)) = 1.0;
    p.add(a, d.serveAction(s), limit);
  }
  return p;
}

/// The tiny dialog with room2 hard to reach and wrong deliveries penalised, so that asking
/// pays off at diffuse beliefs; solved with a small trial budget.
DialogPomdp penalisedTinyDialog() {
  DialogSpec spec;
  spec.items = {"coke", "soda"};
  spec.rooms = {"room1", "room2"};
  spec.persons = {"ann", "ben"};
  spec.delivery = deliveryMatrix(2, Eigen::Vector2d(1.0, 0.6), 2);
  spec.serveCost = 60.0 * (Eigen::MatrixXd::Ones(8, 8) - Eigen::MatrixXd::Identity(8, 8));
  spec.turnLimit = 6;
  return DialogPomdp(spec);
}

TEST(BeliefEntropySurvey, BeliefsAreDistributionsOverRequests) {
  const auto d = tinyDialog();
  const auto pol = always(d, d.askItem());
  BeliefEntropySurvey survey(d, pol, BeliefSamplerOptions(), 3);
  double minEntropy = 1e9, maxEntropy = 0;
  for (std::size_t i = 0; i < 200; ++i) {
    const pomdp::Belief b = survey.belief(i);
    ASSERT_EQ(b.size(), 9);
    EXPECT_NEAR(b.sum(), 1.0, 1e-12);
    EXPECT_GE(b.minCoeff(), 0.0);
    EXPECT_EQ(b(8), 0.0);  // no terminal mass
    const EntropySample s = survey.sample(i);
    EXPECT_FALSE(s.serve);
    EXPECT_NEAR(s.entropy, pomdp::entropy(b), 1e-12);
    EXPECT_NEAR(s.entropy_bits, s.entropy / std::log(2.0), 1e-12);
    EXPECT_DOUBLE_EQ(s.max_probability, b.maxCoeff());
    minEntropy = std::min(minEntropy, s.entropy);
    maxEntropy = std::max(maxEntropy, s.entropy);
  }
  // The sampler covers nearly certain and diffuse beliefs.
  EXPECT_LT(minEntropy, 0.05);
  EXPECT_GT(maxEntropy, 1.0);
}

TEST(BeliefEntropySurvey, RecordsTheEntropyOfBeliefsUnderWhichThePolicyDelivers) {
  const auto d = tinyDialog();
  const auto pol = threshold(d);
  BeliefEntropySurvey survey(d, pol, BeliefSamplerOptions(), 4);
  std::size_t serves = 0;
  for (const EntropySample& s : survey.run(0, 300, 1)) {
    if (!s.serve) {
      EXPECT_LT(s.max_probability, 0.9 + 1e-9);
      continue;
    }
    ++serves;
    EXPECT_GE(s.max_probability, 0.9 - 1e-9);
    EXPECT_EQ(survey.belief(s.index).maxCoeff(), survey.belief(s.index)(static_cast<Eigen::Index>(s.request)));
    const std::string row = survey.csvRow(s);
    EXPECT_NE(row.find(",serve_" + d.requestName(s.request) + ","), std::string::npos) << row;
    EXPECT_NE(row.find("," + d.spec().rooms[d.requestParts(s.request)[1]] + ","), std::string::npos);
  }
  EXPECT_GT(serves, 20u);
  EXPECT_LT(serves, 280u);
}

TEST(BeliefEntropySurvey, SuggestsTheRobotsActionAtTheStartOfADialog) {
  const auto d = penalisedTinyDialog();
  dialog::CertifiedSolverOptions o;
  o.maxTrials = 60;
  dialog::CertifiedDialogSolver solver(d, Eigen::VectorXd(), 0, o);
  solver.solve();
  const pomdp::TurnLimitedPolicy pol = solver.policy();
  BeliefEntropySurvey survey(d, pol, BeliefSamplerOptions(), 5);
  double serveEntropy = 0, askEntropy = 0;
  std::size_t serves = 0, asks = 0;
  for (const EntropySample& s : survey.run(0, 300, 2)) {
    // The robot's decision rule with no question asked yet (lookahead included).
    const pomdp::Belief b = survey.belief(s.index);
    EXPECT_EQ(s.action, decideAction(d, pol, b, 0)) << s.index;
    EXPECT_EQ(s.serve, d.isServe(s.action));
    if (s.serve) {
      EXPECT_EQ(d.serveAction(s.request), s.action);
      serveEntropy += s.entropy;
      ++serves;
    } else {
      askEntropy += s.entropy;
      ++asks;
    }
  }
  // The policy delivers at certain beliefs and asks at diffuse ones.
  ASSERT_GT(serves, 10u);
  ASSERT_GT(asks, 10u);
  EXPECT_LT(serveEntropy / static_cast<double>(serves), askEntropy / static_cast<double>(asks));
}

TEST(BeliefEntropySurvey, SamplesDependOnlyOnSeedAndIndex) {
  const auto d = tinyDialog();
  const auto pol = threshold(d);
  BeliefEntropySurvey a(d, pol, BeliefSamplerOptions(), 8);
  const auto one = a.run(0, 100, 1), four = a.run(0, 100, 4), tail = a.run(60, 10, 3);
  for (std::size_t i = 0; i < 100; ++i) {
    EXPECT_EQ(a.csvRow(one[i]), a.csvRow(four[i]));
    EXPECT_EQ(one[i].index, i);
  }
  for (std::size_t i = 0; i < 10; ++i) EXPECT_EQ(a.csvRow(tail[i]), a.csvRow(one[60 + i]));
  BeliefEntropySurvey b(d, pol, BeliefSamplerOptions(), 9);
  EXPECT_NE(a.csvRow(one[0]), b.csvRow(b.sample(0)));
  EXPECT_EQ(BeliefEntropySurvey::csvHeader().substr(0, 6), "trial,");
}

TEST(BeliefEntropySurvey, RejectsBadOptions) {
  const auto d = tinyDialog();
  const auto pol = threshold(d);
  BeliefSamplerOptions o;
  o.alpha_min = 0;
  EXPECT_THROW(BeliefEntropySurvey(d, pol, o, 1), ConfigError);
  o = BeliefSamplerOptions();
  o.alpha_max = o.alpha_min / 2;
  EXPECT_THROW(BeliefEntropySurvey(d, pol, o, 1), ConfigError);
  EXPECT_THROW(BeliefEntropySurvey(d, pomdp::TurnLimitedPolicy(4, d.spec().turnLimit),
                                   BeliefSamplerOptions(), 1),
               ConfigError);
}

}  // namespace
