#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {
namespace {

SparseModel randomNavigation(std::uint32_t side, std::uint64_t seed, double discount) {
  Rng rng = makeRng(seed, "sweep_model");
  const StateId goal = side * side - 1;
  GridDynamics dyn = makeRandomGridDynamics(side, side, RandomGridOptions(), {0, goal}, rng);
  return makeNavigationGridModel(dyn, {goal}, NavigationReward(), discount).toSparse();
}

/// Plain Gauss-Seidel sweeps over the CSR model, `depth` sweeps per direction (the pass
/// structure of the pipelined solver), from the reward-horizon start.
std::vector<double> referenceSweeps(const SparseModel& m, std::size_t sweeps, std::size_t depth) {
  std::vector<double> v(m.getS(), 0.0);
  for (StateId s = 0; s < m.getS(); ++s) {
    if (m.isTerminal(s)) continue;
    double best = m.getExpectedReward(s, 0);
    for (ActionId a = 1; a < m.getA(); ++a) best = std::max(best, m.getExpectedReward(s, a));
    v[s] = initialValue(InitialValues::kRewardHorizon, best, m.getDiscount());
  }
  for (std::size_t it = 0; it < sweeps; ++it) {
    const bool forward = (it / depth) % 2 == 0;
    for (std::size_t i = 0; i < m.getS(); ++i) {
      const StateId s = static_cast<StateId>(forward ? i : m.getS() - 1 - i);
      if (!m.isTerminal(s)) v[s] = bellmanBackup(m, v, s);
    }
  }
  return v;
}

TEST(SweepModel, LayoutHoldsSuccessorUnionDiscountedProbabilitiesAndPaddedLanes) {
  // 3 states, 2 actions, gamma 0.5; state 2 terminal.
  // (0, a0): 0.5 -> 0, 0.5 -> 1; (0, a1): 1.0 -> 2 (terminal: dropped), reward 4.
  SparseModelBuilder b(3, 2, 0.5);
  b.addTransition(0, 0, 0, 0.5);
  b.addTransition(0, 0, 1, 0.5);
  b.addTransition(0, 1, 2, 1.0, 4.0);
  b.addTransition(1, 0, 0, 1.0);
  b.addTransition(1, 1, 1, 1.0);
  b.addReward(1, 1, -1.0);
  b.setTerminal(2);
  SparseModel m = b.build();
  SweepModel sw(m);
  EXPECT_EQ(sw.getS(), 3u);
  EXPECT_EQ(sw.actionLanes(), 4u);
  EXPECT_EQ(sw.successorsPerState(), 2u);
  EXPECT_EQ(sw.bandwidth(), 1u);
  const std::size_t K = 2, L = 4;
  EXPECT_EQ(sw.successorIndices()[0], 0u);
  EXPECT_EQ(sw.successorIndices()[1], 1u);
  EXPECT_DOUBLE_EQ(sw.probabilityBlocks()[0 * L + 0], 0.25);  // gamma * T(0, a0, 0)
  EXPECT_DOUBLE_EQ(sw.probabilityBlocks()[1 * L + 0], 0.25);  // gamma * T(0, a0, 1)
  EXPECT_DOUBLE_EQ(sw.probabilityBlocks()[0 * L + 1], 0.0);   // a1 only reaches terminal 2
  EXPECT_DOUBLE_EQ(sw.rewardRows()[1], 4.0);
  EXPECT_TRUE(std::isinf(sw.rewardRows()[2]) && sw.rewardRows()[2] < 0);  // padding lane
  // State 1 reaches 0 and itself; terminal state 2 has an all-zero row.
  EXPECT_EQ(sw.successorIndices()[1 * K + 0], 0u);
  EXPECT_EQ(sw.successorIndices()[1 * K + 1], 1u);
  for (std::size_t i = 0; i < K * L; ++i) EXPECT_EQ(sw.probabilityBlocks()[2 * K * L + i], 0.0);
  // Hand solution: V(0) = max(0.25 V0 + 0.25 V1, 4) = 4 (V's are at most 4/(1-.5) ... ),
  // V(1) = max(0.5 V0, -1 + 0.5 V1) = 2.
  SolverOptions o;
  o.epsilon = 1e-12;
  Solution s = valueIteration(sw, o);
  ASSERT_TRUE(s.converged);
  EXPECT_NEAR(s.values[0], 4.0, 1e-10);
  EXPECT_NEAR(s.values[1], 2.0, 1e-10);
  EXPECT_EQ(s.values[2], 0.0);
  EXPECT_EQ(s.policy[0], 1u);
  EXPECT_EQ(s.policy[1], 0u);
}

TEST(SweepModel, PipelinedSweepsEqualSequentialGaussSeidelSweeps) {
  // 40x40: bandwidth 40, so four sweeps run per pass over the model.
  SparseModel m = randomNavigation(40, 1, 0.95);
  SweepModel sw(m);
  for (std::size_t sweeps : {1u, 3u, 4u, 9u, 16u}) {
    SolverOptions o;
    o.epsilon = 1e-300;
    o.max_iterations = sweeps;
    Solution s = valueIteration(sw, o);
    EXPECT_EQ(s.iterations, sweeps);
    // A capped solve finishes the last partial pass sweep by sweep, in the pass's direction.
    std::vector<double> ref(m.getS(), 0.0);
    const std::size_t full = sweeps / 4 * 4;
    ref = referenceSweeps(m, full, 4);
    const bool forward = (full / 4) % 2 == 0;
    for (std::size_t k = full; k < sweeps; ++k) {
      // Each remaining single sweep is its own pass, alternating from `forward`.
      const bool fwd = ((k - full) % 2 == 0) == forward;
      for (std::size_t i = 0; i < m.getS(); ++i) {
        const StateId st = static_cast<StateId>(fwd ? i : m.getS() - 1 - i);
        if (!m.isTerminal(st)) ref[st] = bellmanBackup(m, ref, st);
      }
    }
    double worst = 0.0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      worst = std::max(worst, std::fabs(ref[i] - s.values[i]));
    }
    EXPECT_LT(worst, 1e-11) << sweeps << " sweeps";
  }
}

TEST(SweepModel, ConvergedValuesMatchPolicyIterationAndFloatLayoutIsClose) {
  SparseModel m = randomNavigation(30, 2, 0.95);
  SolverOptions o;
  o.epsilon = 1e-9;
  Solution pi = policyIteration(m, o);
  Solution d = valueIteration(SweepModel(m), o);
  Solution f = valueIteration(SweepModelF(m), o);
  Solution csr = valueIteration(m, o);  // builds the layout itself
  ASSERT_TRUE(pi.converged && d.converged && f.converged && csr.converged);
  for (StateId s = 0; s < m.getS(); ++s) {
    EXPECT_NEAR(d.values[s], pi.values[s], 1e-8);
    EXPECT_EQ(csr.values[s], d.values[s]);
    EXPECT_NEAR(f.values[s], pi.values[s], 1e-4);  // float rounding of the probabilities
  }
  // Greedy policies agree wherever the best action is not (nearly) tied.
  std::size_t differ = 0;
  for (StateId s = 0; s < m.getS(); ++s) differ += d.policy[s] != pi.policy[s] ? 1 : 0;
  EXPECT_LT(differ, m.getS() / 50 + 1);
  // Warm start from the solution: one sweep.
  Solution warm = valueIteration(SweepModel(m), o, &d.values);
  EXPECT_EQ(warm.iterations, 1u);
  EXPECT_TRUE(warm.converged);
}

TEST(SweepModel, ModelsOutsideTheLayoutAreRejectedAndStillSolvedByCsr) {
  // One state reaching 9 distinct non-terminal states: more than kMaxSuccessors.
  SparseModelBuilder b(10, 1, 0.9);
  for (StateId s = 0; s < 10; ++s) {
    for (StateId t = 0; t < 10; ++t) {
      if (s == 0 && t > 0) b.addTransition(s, 0, t, 1.0 / 9.0);
    }
    if (s > 0) b.addTransition(s, 0, s, 1.0);
    b.addReward(s, 0, s == 0 ? 1.0 : 0.5);
  }
  SparseModel wide = b.build();
  EXPECT_EQ(SweepModel::tryBuild(wide), nullptr);
  EXPECT_FALSE(SweepModel::suitable(wide));
  EXPECT_THROW(SweepModel{wide}, ConfigError);
  SolverOptions o;
  o.epsilon = 1e-10;
  Solution s = valueIteration(wide, o);
  ASSERT_TRUE(s.converged);
  EXPECT_NEAR(s.values[1], 0.5 / 0.1, 1e-8);
  EXPECT_NEAR(s.values[0], 1.0 + 0.9 * 5.0, 1e-8);
  // Nine actions: more lanes than the layout has.
  SparseModelBuilder c(1, 9, 0.9);
  for (ActionId a = 0; a < 9; ++a) c.addTransition(0, a, 0, 1.0);
  EXPECT_THROW(SweepModel{c.build()}, ConfigError);
}

}  // namespace
}  // namespace mdp
}  // namespace krr
