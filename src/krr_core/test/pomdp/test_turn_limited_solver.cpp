// Tests of TurnLimitedSolver: exact finite-horizon values (hand-computed and by enumeration),
// agreement with the generic point-based solver on the model with a turn counter in the
// state, and the policy earning the lower bound it is certified with.
#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_core/pomdp/turn_counter_model.h"
#include "krr_core/pomdp/turn_limited_solver.h"
#include "turn_limited_test_support.h"

namespace krr {
namespace pomdp {
using dialog::DialogPomdp, dialog::DialogSpec, dialog::deliveryMatrix, dialog::ownOfficePrior;
namespace {

/// The paper's 30-request dialog with a penalty for wrong deliveries: asking pays off, so the
/// solver has real work to do (without it, serving an always-reachable room is optimal at once).
DialogPomdp penalisedDialog(int turnLimit = 20) {
  DialogSpec spec;
  spec.prior = ownOfficePrior(3, 5, {0, 1}, 0.8);
  Eigen::VectorXd reach(5);
  reach << 1.0, 0.4, 0.6, 1.0, 0.25;
  spec.delivery = deliveryMatrix(3, reach, 2);
  const auto n = static_cast<Eigen::Index>(spec.delivery.rows());
  spec.serveCost = 60.0 * (Eigen::MatrixXd::Ones(n, n) - Eigen::MatrixXd::Identity(n, n));
  spec.turnLimit = turnLimit;
  return DialogPomdp(spec);
}

TurnLimitedSolverOptions tight(double precision = 1e-7) {
  TurnLimitedSolverOptions o;
  o.precision = precision;
  o.timeout = 30.0;
  return o;
}

TEST(TurnLimitedSolver, OneShotTigerHandComputedValues) {
  const Model m = test::oneShotTiger(1.0);
  // No question allowed: open a door blindly, 0.5 (10) + 0.5 (-100) = -45.
  TurnLimitedSolver s0(m, m.initialBelief(), 0, tight());
  EXPECT_TRUE(s0.solve());
  EXPECT_NEAR(s0.report().lower, -45.0, 1e-9);
  EXPECT_NEAR(s0.report().upper, -45.0, 1e-9);
  // One listen, then open the door opposite to the sound: -1 + 0.85 (10) + 0.15 (-100) = -7.5.
  TurnLimitedSolver s1(m, m.initialBelief(), 1, tight());
  EXPECT_TRUE(s1.solve());
  EXPECT_NEAR(s1.report().lower, -7.5, 1e-6);
  EXPECT_NEAR(s1.report().upper, -7.5, 1e-6);
  // The policy listens first, then opens: at the limit only ending actions remain.
  const TurnLimitedPolicy p = s1.policy();
  EXPECT_EQ(p.bestAction(m.initialBelief(), 0), 0u);
  Belief heardLeft = updateBelief(m, m.initialBelief(), 0, 0);
  EXPECT_EQ(p.bestAction(heardLeft, 1), 2u);  // tiger probably left: open right
}

TEST(TurnLimitedSolver, MatchesEnumerationOnTigerAndDialog) {
  for (double g : {1.0, 0.95}) {
    const Model m = test::oneShotTiger(g);
    for (int limit : {2, 3, 5, 7}) {
      const double exact = test::exactTurnLimitedValue(m, m.initialBelief(), 0, limit);
      TurnLimitedSolver s(m, m.initialBelief(), limit, tight());
      ASSERT_TRUE(s.solve()) << "limit " << limit;
      EXPECT_LE(s.report().lower, exact + 1e-9) << "limit " << limit << " discount " << g;
      EXPECT_GE(s.report().upper, exact - 1e-9);
      EXPECT_NEAR(s.report().lower, exact, 1e-6);
    }
  }
  // A small dialog (2 items x 2 rooms x 1 person), two questions at most.
  DialogSpec spec;
  spec.items = {"coke", "soda"};
  spec.rooms = {"room1", "room2"};
  spec.persons = {"bob"};
  Eigen::VectorXd reach(2);
  reach << 1.0, 0.5;
  spec.delivery = deliveryMatrix(2, reach, 1);
  spec.discount = 0.99;
  DialogPomdp d(spec);
  for (int limit : {1, 2}) {
    const double exact = test::exactTurnLimitedValue(d.model(), d.model().initialBelief(), 0, limit);
    TurnLimitedSolver s(d.model(), d.model().initialBelief(), limit, tight());
    ASSERT_TRUE(s.solve());
    EXPECT_NEAR(s.report().lower, exact, 1e-6) << "limit " << limit;
    EXPECT_GE(s.report().upper, exact - 1e-9);
  }
}

TEST(TurnLimitedSolver, AgreesWithGenericSolverOnTurnCounterModel) {
  // The same problem with the turn count in the state, solved by the infinite-horizon solver.
  DialogSpec spec;
  spec.items = {"coke", "coffee", "soda"};
  spec.rooms = {"room1", "room2"};
  spec.persons = {"alice", "bob"};
  spec.prior = ownOfficePrior(3, 2, {0, 1}, 0.8);
  Eigen::VectorXd reach(2);
  reach << 1.0, 0.4;
  spec.delivery = deliveryMatrix(3, reach, 2);
  spec.discount = 0.95;
  DialogPomdp d(spec);
  const int limit = 3;
  TurnLimitedSolver ours(d.model(), d.model().initialBelief(), limit, tight(1e-6));
  ASSERT_TRUE(ours.solve());
  const Model counted = withTurnCounter(d.model(), d.model().initialBelief(), limit);
  SolverOptions go;
  go.precision = 1e-6;
  go.timeout = 60.0;
  PointBasedSolver generic(counted, counted.initialBelief(), go);
  ASSERT_TRUE(generic.solve());
  EXPECT_NEAR(ours.report().lower, generic.report().lower, 2e-6);
  EXPECT_LE(ours.report().lower, generic.report().upper + 1e-9);
  EXPECT_LE(generic.report().lower, ours.report().upper + 1e-9);
}

// The greedy policy of the lower bound, executed in simulated dialogs, earns at least the
// bound certified at (b0, 0), also when the solver stopped early.
TEST(TurnLimitedSolver, PolicyEarnsItsCertifiedLowerBound) {
  const DialogPomdp d = penalisedDialog();
  const DialogSpec& spec = d.spec();
  const Model& m = d.model();
  for (std::size_t budget : {5, 40, 150}) {
    TurnLimitedSolverOptions o = tight(1e-9);
    o.maxTrials = budget;
    TurnLimitedSolver s(m, m.initialBelief(), spec.turnLimit, o);
    s.solve();
    const TurnLimitedPolicy p = s.policy();
    const double certified = s.report().lower;
    EXPECT_EQ(s.report().trials, budget);  // not trivial: the bounds do not meet early
    EXPECT_NEAR(p.value(m.initialBelief(), 0), certified, 1e-9);
    const std::size_t episodes = 6000;
    double sum = 0.0, sq = 0.0;
    for (std::size_t e = 0; e < episodes; ++e) {
      Rng rng = makeRng(7, "policy-check", e);
      double u = uniform01(rng);
      std::size_t state = 0;
      while (state + 1 < d.numRequests() && u >= spec.prior(static_cast<Eigen::Index>(state)))
        u -= spec.prior(static_cast<Eigen::Index>(state++));
      Belief b = m.initialBelief();
      double ret = 0.0, disc = 1.0;
      for (int t = 0;; ++t) {
        const std::size_t a = p.bestAction(b, t);
        ret += disc * m.getExpectedReward(state, a);
        if (d.isServe(a)) break;
        ASSERT_LT(t, spec.turnLimit) << "the policy asked beyond the turn limit";
        const auto sor = m.sampleSOR(state, a, rng);
        b = updateBelief(m, b, a, std::get<1>(sor));
        disc *= m.getDiscount();
      }
      sum += ret;
      sq += ret * ret;
    }
    const double mean = sum / episodes;
    const double se = std::sqrt((sq / episodes - mean * mean) / episodes);
    EXPECT_GE(mean, certified - 4.0 * se) << "budget " << budget << ": simulated " << mean
                                          << " below the certified " << certified;
  }
}

TEST(TurnLimitedSolver, RejectsBadInput) {
  const Model m = test::oneShotTiger();
  EXPECT_THROW(TurnLimitedSolver(m, m.initialBelief(), -1), ConfigError);
  Belief bad = Belief::Constant(3, 0.5);
  EXPECT_THROW(TurnLimitedSolver(m, bad, 3), ConfigError);
  EXPECT_THROW(TurnLimitedSolver(m, Belief::Constant(2, 0.5), 3), ConfigError);
  TurnLimitedSolverOptions o;
  o.precision = 0.0;
  EXPECT_THROW(TurnLimitedSolver(m, m.initialBelief(), 3, o), ConfigError);
  // Without an action that ends the episode, the limit cannot be met.
  std::vector<Eigen::MatrixXd> t{Eigen::MatrixXd::Identity(2, 2)}, z{Eigen::MatrixXd::Ones(2, 1)};
  Model loop(t, z, Eigen::MatrixXd::Constant(2, 1, -1.0), 0.9);
  EXPECT_THROW(TurnLimitedSolver(loop, loop.initialBelief(), 3), ConfigError);
}

TEST(TurnLimitedSolver, ReproducibleUnderTrialBudget) {
  const DialogPomdp d = penalisedDialog();
  TurnLimitedSolverOptions o = tight(1e-9);
  o.maxTrials = 30;
  TurnLimitedSolver a(d.model(), d.model().initialBelief(), 20, o);
  TurnLimitedSolver b(d.model(), d.model().initialBelief(), 20, o);
  a.solve();
  b.solve();
  EXPECT_EQ(a.policy().toText(), b.policy().toText());
  EXPECT_EQ(a.report().trials, 30u);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
