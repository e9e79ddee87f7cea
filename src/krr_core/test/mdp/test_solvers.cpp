#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {
namespace {

// 1x4 corridor as a SparseModel: actions 0 = left, 1 = right (deterministic, walls keep the
// robot in place), -1 per move, +10 on entering goal 3, gamma = 0.9.
// Hand solution: V(2) = -1 + 10 = 9, V(1) = -1 + 0.9*9 = 7.1, V(0) = -1 + 0.9*7.1 = 5.39.
SparseModel corridor() {
  SparseModelBuilder b(4, 2, 0.9);
  for (StateId s = 0; s < 3; ++s) {
    b.addReward(s, 0, -1.0);
    b.addReward(s, 1, -1.0);
    b.addTransition(s, 0, s == 0 ? 0 : s - 1, 1.0);
    b.addTransition(s, 1, s + 1, 1.0, s + 1 == 3 ? 10.0 : 0.0);
  }
  b.setTerminal(3);
  return b.build();
}

// Two states A=0, B=1; action 0 = stay (deterministic), 1 = switch (succeeds w.p. 0.8, else
// stays). R(A,stay)=1, R(B,stay)=2, R(.,switch)=0, gamma = 0.9.
// Hand solution: staying in B forever is worth 2/(1-0.9) = 20. In A, switching gives
// V(A) = 0.9 (0.8*20 + 0.2 V(A)) -> V(A) = 14.4 / 0.82 = 17.5609756...; staying would give
// 1 + 0.9*17.56 = 16.80 < 17.56, and switching in B gives 0.9 (0.8*17.56 + 0.2*20) = 16.24
// < 20, so pi = (switch, stay).
SparseModel twoState() {
  SparseModelBuilder b(2, 2, 0.9);
  b.addTransition(0, 0, 0, 1.0);
  b.addReward(0, 0, 1.0);
  b.addTransition(0, 1, 1, 0.8);
  b.addTransition(0, 1, 0, 0.2);
  b.addTransition(1, 0, 1, 1.0);
  b.addReward(1, 0, 2.0);
  b.addTransition(1, 1, 0, 0.8);
  b.addTransition(1, 1, 1, 0.2);
  return b.build();
}

SolverOptions tight() {
  SolverOptions o;
  o.epsilon = 1e-10;
  return o;
}

TEST(Solvers, ValueIterationMatchesHandSolvedCorridor) {
  Solution v = valueIteration(corridor(), tight());
  ASSERT_TRUE(v.converged);
  EXPECT_NEAR(v.values[0], 5.39, 1e-9);
  EXPECT_NEAR(v.values[1], 7.1, 1e-9);
  EXPECT_NEAR(v.values[2], 9.0, 1e-9);
  EXPECT_EQ(v.values[3], 0.0);
  EXPECT_EQ(v.policy[0], 1u);
  EXPECT_EQ(v.policy[1], 1u);
  EXPECT_EQ(v.policy[2], 1u);
}

TEST(Solvers, PolicyIterationMatchesHandSolvedTwoStateMdp) {
  SparseModel m = twoState();
  Solution p = policyIteration(m, tight());
  ASSERT_TRUE(p.converged);
  EXPECT_NEAR(p.values[0], 14.4 / 0.82, 1e-9);
  EXPECT_NEAR(p.values[1], 20.0, 1e-9);
  EXPECT_EQ(p.policy[0], 1u);
  EXPECT_EQ(p.policy[1], 0u);
  EXPECT_LT(p.residual, 1e-9);
  Solution v = valueIteration(m, tight());
  EXPECT_NEAR(v.values[0], 14.4 / 0.82, 1e-9);
  EXPECT_NEAR(v.values[1], 20.0, 1e-9);
  EXPECT_EQ(v.policy, p.policy);
}

TEST(Solvers, ValueAndPolicyIterationAgreeOnRandomNavigationGrid) {
  Rng rng = makeRng(3, "vi_pi");
  GridDynamics dyn = makeRandomGridDynamics(12, 10, RandomGridOptions(), {0, 119}, rng);
  SparseModel m = makeNavigationGridModel(dyn, {119}, NavigationReward(), 0.95).toSparse();
  Solution v = valueIteration(m, tight());
  Solution p = policyIteration(m, tight());
  ASSERT_TRUE(v.converged);
  ASSERT_TRUE(p.converged);
  for (std::size_t s = 0; s < m.getS(); ++s) EXPECT_NEAR(v.values[s], p.values[s], 1e-9);
  // The VI greedy policy is optimal: its exact value equals V*.
  std::vector<double> vpi = evaluatePolicy(m, v.policy);
  for (std::size_t s = 0; s < m.getS(); ++s) EXPECT_NEAR(vpi[s], p.values[s], 1e-8);
}

TEST(Solvers, StoppingRuleGivesEpsilonOptimalValues) {
  SparseModel m = twoState();
  SolverOptions o;
  o.epsilon = 1e-3;
  Solution v = valueIteration(m, o);
  ASSERT_TRUE(v.converged);
  EXPECT_LT(v.residual, stoppingThreshold(1e-3, 0.9));
  // threshold = eps (1-g)/(2g) guarantees ||V - V*|| < eps / 2.
  EXPECT_NEAR(v.values[0], 14.4 / 0.82, 5e-4);
  EXPECT_NEAR(v.values[1], 20.0, 5e-4);
}

TEST(Solvers, WarmStartFromSolutionConvergesInOneSweep) {
  SparseModel m = corridor();
  Solution cold = valueIteration(m, tight());
  Solution warm = valueIteration(m, tight(), &cold.values);
  EXPECT_GT(cold.iterations, 1u);
  EXPECT_EQ(warm.iterations, 1u);
}

TEST(Solvers, RewardHorizonInitialValuesConvergeToTheSameValuesInFewerSweeps) {
  Rng rng = makeRng(4, "init");
  GridDynamics dyn = makeRandomGridDynamics(30, 30, RandomGridOptions(), {0, 899}, rng);
  GridModel g = makeNavigationGridModel(dyn, {899}, NavigationReward(), 0.95);
  SparseModel m = g.toSparse();
  SolverOptions zero = tight(), horizon = tight();
  zero.initial = InitialValues::kZero;
  horizon.initial = InitialValues::kRewardHorizon;
  for (int layout = 0; layout < 2; ++layout) {
    Solution a = layout == 0 ? valueIteration(m, zero) : valueIteration(g, zero);
    Solution b = layout == 0 ? valueIteration(m, horizon) : valueIteration(g, horizon);
    ASSERT_TRUE(a.converged && b.converged);
    for (std::size_t s = 0; s < m.getS(); ++s) EXPECT_NEAR(a.values[s], b.values[s], 1e-10);
    // Far from the goal V = -1/(1-0.95) = -20 already holds at the start.
    EXPECT_LT(b.iterations, a.iterations) << "layout " << layout;
  }
  // The generic (view) solver uses the same rule.
  Solution v = valueIterationView(m, horizon);
  Solution z = valueIterationView(m, zero);
  EXPECT_LT(v.iterations, z.iterations);
  EXPECT_NEAR(v.values[0], z.values[0], 1e-10);
}

TEST(Solvers, InvalidOptionsThrowConfigError) {
  SparseModel m = corridor();
  SolverOptions o;
  o.epsilon = 0.0;
  EXPECT_THROW(valueIteration(m, o), ConfigError);
  o.epsilon = 1e-3;
  o.max_iterations = 0;
  EXPECT_THROW(valueIteration(m, o), ConfigError);
  std::vector<double> wrong(3, 0.0);
  EXPECT_THROW(valueIteration(m, SolverOptions(), &wrong), ConfigError);
  std::vector<ActionId> bad_policy(4, 5);
  EXPECT_THROW(evaluatePolicy(m, bad_policy), ConfigError);
}

TEST(Solvers, SingularPolicyEvaluationThrows) {
  // gamma = 1 and a policy that loops forever: I - P is singular.
  SparseModelBuilder b(2, 1, 1.0);
  b.addTransition(0, 0, 0, 1.0);
  b.addTransition(1, 0, 1, 1.0);
  SparseModel m = b.build();
  EXPECT_THROW(evaluatePolicy(m, {0, 0}), ConfigError);
}

}  // namespace
}  // namespace mdp
}  // namespace krr
