#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/reach_probability.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {
namespace {

// Gambler's ruin on 0..4: from i, up w.p. 0.6, down w.p. 0.4; 0 = failure (terminal),
// 4 = target. With r = q/p = 2/3: P(reach 4 | i) = (1 - r^i) / (1 - r^4), 1 - r^4 = 65/81:
// i=1: (1/3)(81/65) = 27/65, i=2: (5/9)(81/65) = 45/65, i=3: (19/27)(81/65) = 57/65.
SparseModel ruin() {
  SparseModelBuilder b(5, 1, 1.0);
  for (StateId i = 1; i < 4; ++i) {
    b.addTransition(i, 0, i + 1, 0.6);
    b.addTransition(i, 0, i - 1, 0.4);
  }
  b.setTerminal(0);
  b.setTerminal(4);
  return b.build();
}

TEST(ReachProbability, GamblersRuinMatchesClosedForm) {
  SparseModel m = ruin();
  std::vector<ActionId> pi(5, 0);
  std::vector<double> p = reachProbability(m, pi, {4});
  EXPECT_NEAR(p[0], 0.0, 1e-12);
  EXPECT_NEAR(p[1], 27.0 / 65.0, 1e-12);
  EXPECT_NEAR(p[2], 45.0 / 65.0, 1e-12);
  EXPECT_NEAR(p[3], 57.0 / 65.0, 1e-12);
  EXPECT_NEAR(p[4], 1.0, 1e-12);
}

TEST(ReachProbability, FiniteHorizonMatchesHandCount) {
  SparseModel m = ruin();
  std::vector<ActionId> pi(5, 0);
  // From 3: N=1 -> 0.6. N=2 -> still 0.6 (3->2->? needs two more ups). N=3 -> 0.6 + 0.4 *
  // 0.6 * 0.6 = 0.744. From 2 with N=2: up twice, 0.36. From 1 with N=2: 0.
  EXPECT_NEAR(reachProbability(m, pi, {4}, 1)[3], 0.6, 1e-12);
  EXPECT_NEAR(reachProbability(m, pi, {4}, 2)[3], 0.6, 1e-12);
  EXPECT_NEAR(reachProbability(m, pi, {4}, 3)[3], 0.744, 1e-12);
  EXPECT_NEAR(reachProbability(m, pi, {4}, 2)[2], 0.36, 1e-12);
  EXPECT_NEAR(reachProbability(m, pi, {4}, 2)[1], 0.0, 1e-12);
  // A long horizon converges to the absorbing-chain answer.
  EXPECT_NEAR(reachProbability(m, pi, {4}, 2000)[2], 45.0 / 65.0, 1e-12);
}

TEST(ReachProbability, StatesThatCannotReachTheTargetGetZero) {
  // 0 -> 1 (loop forever, never reaching 2); 2 is the target.
  SparseModelBuilder b(3, 1, 1.0);
  b.addTransition(0, 0, 1, 1.0);
  b.addTransition(1, 0, 1, 1.0);
  b.addTransition(2, 0, 2, 1.0);
  SparseModel m = b.build();
  std::vector<double> p = reachProbability(m, {0, 0, 0}, {2});
  EXPECT_EQ(p[0], 0.0);
  EXPECT_EQ(p[1], 0.0);
  EXPECT_EQ(p[2], 1.0);
}

// Half-width of the 99.9% binomial confidence interval (z = 3.29) of an estimate from n runs,
// with a floor of 1/n for probabilities close to 0 or 1.
double ci999(double p, std::size_t n) {
  return 3.29 * std::sqrt(p * (1.0 - p) / static_cast<double>(n)) + 1.0 / static_cast<double>(n);
}

TEST(ReachProbability, ExactValueLiesInMonteCarloConfidenceInterval) {
  Rng gen = makeRng(5, "reach_grid");
  RandomGridOptions ro;
  ro.trap_areas = 3;
  ro.trap_size = 3;
  ro.p_trap = 0.15;
  GridDynamics dyn = makeRandomGridDynamics(10, 10, ro, {0, 99}, gen);
  SparseModel m = makeNavigationGridModel(dyn, {99}, NavigationReward(), 0.95).toSparse();
  Solution sol = valueIteration(m, SolverOptions());
  const std::size_t n = 20000;
  for (std::size_t horizon : {std::size_t(25), std::size_t(60), kInfiniteHorizon}) {
    std::vector<double> exact = reachProbability(m, sol.policy, {99}, horizon);
    Rng rng = makeRng(5, "reach_mc", horizon);
    const double mc = monteCarloReachProbability(m, sol.policy, {99}, 0, horizon, n, rng);
    EXPECT_NEAR(mc, exact[0], ci999(exact[0], n)) << "horizon " << horizon;
    EXPECT_GT(exact[0], 0.05);
    EXPECT_LT(exact[0], 0.999);
  }
}

TEST(ReachProbability, InvalidInputsThrowConfigError) {
  SparseModel m = ruin();
  EXPECT_THROW(reachProbability(m, {0, 0}, {4}), ConfigError);
  EXPECT_THROW(reachProbability(m, std::vector<ActionId>(5, 0), {9}), ConfigError);
  EXPECT_THROW(reachProbability(m, std::vector<ActionId>(5, 3), {4}), ConfigError);
  Rng rng = makeRng(1, "x");
  EXPECT_THROW(monteCarloReachProbability(m, std::vector<ActionId>(5, 0), {4}, 7, 10, 10, rng),
               ConfigError);
}

}  // namespace
}  // namespace mdp
}  // namespace krr
