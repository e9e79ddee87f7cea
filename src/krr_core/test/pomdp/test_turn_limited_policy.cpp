// Tests of TurnLimitedPolicy: which vectors a turn may use, text round trip, bad files.
#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/turn_limited_policy.h"

namespace krr {
namespace pomdp {
namespace {

TEST(TurnLimitedPolicy, VectorsServeUpToTheirStage) {
  TurnLimitedPolicy p(2, 3);
  p.add(Eigen::Vector2d(10, 10), 0, 1);  // best, but only until turn 1
  p.add(Eigen::Vector2d(5, 5), 1, 2);
  p.add(Eigen::Vector2d(0, 1), 2, 3);    // usable at every turn
  const Eigen::Vector2d b(0.5, 0.5);
  EXPECT_EQ(p.bestAction(b, 0), 0u);
  EXPECT_EQ(p.bestAction(b, 1), 0u);
  EXPECT_EQ(p.bestAction(b, 2), 1u);
  EXPECT_EQ(p.bestAction(b, 3), 2u);
  EXPECT_EQ(p.bestAction(b, 99), 2u);   // beyond the limit counts as the limit
  EXPECT_DOUBLE_EQ(p.value(b, 2), 5.0);
  EXPECT_THROW(p.add(Eigen::Vector2d(0, 0), 0, 4), ConfigError);
  EXPECT_THROW(p.add(Eigen::Vector3d(0, 0, 0), 0, 1), ConfigError);
  EXPECT_THROW(p.bestIndex(Eigen::Vector3d(1, 0, 0), 0), ConfigError);
  TurnLimitedPolicy noEnd(2, 3);
  noEnd.add(Eigen::Vector2d(1, 1), 0, 1);
  EXPECT_THROW(noEnd.bestIndex(b, 2), ConfigError);
}

TEST(TurnLimitedPolicy, ManyBeliefsAtOnceMatchOneByOne) {
  // Random vectors over several stages, ties included: values() of a batch and bestIndex()
  // (one product per stage group) agree with the definition, max over usable vectors, lowest
  // index on ties.
  std::srand(7);
  const std::size_t S = 6;
  TurnLimitedPolicy p(S, 4);
  std::vector<Eigen::VectorXd> alphas;
  std::vector<int> stages;
  for (int i = 0; i < 40; ++i) {
    Eigen::VectorXd a = Eigen::VectorXd::Random(static_cast<Eigen::Index>(S));
    if (i % 7 == 3) a = alphas[static_cast<std::size_t>(i - 3)];  // exact duplicates: ties
    const int stage = i % 5;
    p.add(a, static_cast<std::size_t>(i), stage);
    alphas.push_back(a);
    stages.push_back(stage);
  }
  Eigen::MatrixXd beliefs = Eigen::MatrixXd::Random(static_cast<Eigen::Index>(S), 25).cwiseAbs();
  for (Eigen::Index c = 0; c < beliefs.cols(); ++c) beliefs.col(c) /= beliefs.col(c).sum();
  for (int t = 0; t <= 5; ++t) {
    const Eigen::VectorXd v = p.values(beliefs, t);
    for (Eigen::Index c = 0; c < beliefs.cols(); ++c) {
      const Eigen::VectorXd b = beliefs.col(c);
      std::size_t best = alphas.size();
      double bv = 0;
      for (std::size_t i = 0; i < alphas.size(); ++i) {
        if (stages[i] < std::min(t, 4)) continue;
        const double x = alphas[i].dot(b);
        if (best == alphas.size() || x > bv) best = i, bv = x;
      }
      EXPECT_EQ(p.bestIndex(b, t), best) << "turn " << t << ", belief " << c;
      EXPECT_NEAR(v(c), bv, 1e-12);
      EXPECT_NEAR(p.value(b, t), bv, 1e-12);
    }
  }
  EXPECT_THROW(p.values(Eigen::MatrixXd::Zero(3, 2), 0), ConfigError);
}

TEST(TurnLimitedPolicy, TextRoundTripIsExact) {
  TurnLimitedPolicy p(3, 20);
  p.add(Eigen::Vector3d(0.1, -1.0 / 3.0, 1e-300), 4, 0);
  p.add(Eigen::Vector3d(-80, 80, 0), 40, 20);
  const TurnLimitedPolicy q = TurnLimitedPolicy::fromText(p.toText());
  ASSERT_EQ(q.size(), 2u);
  EXPECT_EQ(q.turnLimit(), 20);
  EXPECT_EQ(q.stage(1), 20);
  EXPECT_EQ(q.action(0), 4u);
  EXPECT_EQ(q.alpha(0), p.alpha(0));
  EXPECT_EQ(q.toText(), p.toText());
}

TEST(TurnLimitedPolicy, PlansContinueOneTurnLaterAndRoundTrip) {
  // Vector 0 (stage 0) asks; after observation 1 it continues with vector 1 (stage 1), after
  // observation 0 with the serve plan 2 (stage 2 = the limit); observation 2 has none.
  TurnLimitedPolicy p(2, 2);
  p.add(Eigen::Vector2d(1, 2), 0, 0);
  p.add(Eigen::Vector2d(3, 4), 0, 1);
  p.add(Eigen::Vector2d(5, 6), 1, 2);
  EXPECT_FALSE(p.hasPlans());
  EXPECT_EQ(p.next(0, 0), -1);
  EXPECT_EQ(p.toText().rfind("krr-turn-limited-policy 1\n", 0), 0u);  // no plans: version 1
  p.setPlans(3, {2, 1, -1, 2, 2, -1, -1, -1, -1});
  ASSERT_TRUE(p.hasPlans());
  EXPECT_EQ(p.numObservations(), 3u);
  EXPECT_EQ(p.next(0, 0), 2);
  EXPECT_EQ(p.next(0, 1), 1);
  EXPECT_EQ(p.next(0, 2), -1);
  EXPECT_EQ(p.next(0, 7), -1);  // an observation beyond the plans' has no continuation
  const TurnLimitedPolicy q = TurnLimitedPolicy::fromText(p.toText(), "p.txt");
  ASSERT_TRUE(q.hasPlans());
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t o = 0; o < 3; ++o) EXPECT_EQ(q.next(i, o), p.next(i, o));
  EXPECT_EQ(q.toText(), p.toText());
  // Refused, and nothing is changed: a wrong size, an index out of range, a continuation not
  // usable one turn later (vector 1 of stage 1 continuing with itself).
  TurnLimitedPolicy r = q;
  EXPECT_THROW(r.setPlans(3, {2, 1}), ConfigError);
  EXPECT_THROW(r.setPlans(0, {}), ConfigError);
  EXPECT_THROW(r.setPlans(1, {3, -1, -1}), ConfigError);
  EXPECT_THROW(r.setPlans(1, {-2, -1, -1}), ConfigError);
  EXPECT_THROW(r.setPlans(1, {-1, 1, -1}), ConfigError);
  EXPECT_EQ(r.toText(), q.toText());
}

TEST(TurnLimitedPolicy, MalformedPlansNameTheSpot) {
  const std::string head =
      "krr-turn-limited-policy 2\nstates 1\nturn_limit 1\nvectors 2\n0 0 1\n1 1 2\n";
  EXPECT_EQ(TurnLimitedPolicy::fromText(head + "plans 1\n2\n0\n").next(0, 0), 1);
  try {
    TurnLimitedPolicy::fromText(head + "plans 1\n3\n0\n", "p.txt");
    FAIL() << "a continuation beyond the vectors must be refused";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.location().line, 8);
    EXPECT_EQ(e.location().column, 1);
  }
  EXPECT_THROW(TurnLimitedPolicy::fromText(head + "plans 1\n2\n"), ParseError);       // short
  EXPECT_THROW(TurnLimitedPolicy::fromText(head + "plans 0\n"), ParseError);           // no obs
  EXPECT_THROW(TurnLimitedPolicy::fromText(head + "plans 1\n-1\n0\n"), ParseError);  // sign
  EXPECT_THROW(TurnLimitedPolicy::fromText(head), ParseError);                        // missing
  // A declared observation count the file cannot hold allocates nothing before it fails.
  EXPECT_THROW(TurnLimitedPolicy::fromText(head + "plans 1000000\n1\n"), ParseError);
  EXPECT_THROW(TurnLimitedPolicy::fromText(
                   "krr-turn-limited-policy 3\nstates 1\nturn_limit 1\nvectors 0\n"),
               ParseError);
}

TEST(TurnLimitedPolicy, MalformedTextNamesTheSpot) {
  const std::string head = "krr-turn-limited-policy 1\nstates 2\nturn_limit 3\nvectors 1\n";
  try {
    TurnLimitedPolicy::fromText(head + "4 0 1 2\n", "p.txt");
    FAIL() << "a stage beyond the limit must be refused";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.location().line, 5);
    EXPECT_EQ(e.location().column, 1);
  }
  EXPECT_THROW(TurnLimitedPolicy::fromText(head + "1 0 1 x\n"), ParseError);
  EXPECT_THROW(TurnLimitedPolicy::fromText(head + "1 0 1\n"), ParseError);
  EXPECT_THROW(TurnLimitedPolicy::fromText(head + "1 0 1 2 3\n"), ParseError);
  EXPECT_THROW(TurnLimitedPolicy::fromText("krr-alpha-policy 1\n"), ParseError);
  // A declared size the file cannot hold is refused before any allocation.
  EXPECT_THROW(TurnLimitedPolicy::fromText(
                   "krr-turn-limited-policy 1\nstates 999999999999\nturn_limit 3\nvectors 1\n"),
               ParseError);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
