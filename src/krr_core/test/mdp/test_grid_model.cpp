#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/grid_model.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {
namespace {

TEST(GridModel, OffGridMovesFoldIntoStayAndNeighboursAreImplicit) {
  GridModel m(3, 2, 0.9);
  EXPECT_EQ(m.getS(), 7u);
  EXPECT_EQ(m.failureState(), 6u);
  EXPECT_TRUE(m.isTerminal(m.failureState()));
  // Cell (0,0) = 0, action up: 0.6 up (off grid -> stay), 0.2 right, 0.1 down, 0.1 fail.
  m.setOutcomes(0, kActUp, {0.0, 0.6, 0.1, 0.0, 0.2, 0.1}, -1.0);
  EXPECT_DOUBLE_EQ(m.outcomeProbability(0, kActUp, kStay), 0.6);
  EXPECT_DOUBLE_EQ(m.outcomeProbability(0, kActUp, kUp), 0.0);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, kActUp, 0), 0.6);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, kActUp, 1), 0.2);
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, kActUp, 3), 0.1);  // (0,1) is below
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, kActUp, 6), 0.1);  // failure
  EXPECT_DOUBLE_EQ(m.getExpectedReward(0, kActUp), -1.0);
  // Untouched pairs stay in place.
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(4, kActLeft, 4), 1.0);
  SparseModel s = m.toSparse();
  EXPECT_EQ(s.getS(), 7u);
  EXPECT_DOUBLE_EQ(s.getTransitionProbability(0, kActUp, 6), 0.1);
  EXPECT_TRUE(s.isTerminal(6));
}

TEST(GridModel, InvalidOutcomesThrowConfigError) {
  GridModel m(2, 2, 0.9);
  EXPECT_THROW(m.setOutcomes(0, 0, {0.5, 0.4, 0, 0, 0, 0}, 0.0), ConfigError);  // sum 0.9
  EXPECT_THROW(m.setOutcomes(0, 0, {1.5, -0.5, 0, 0, 0, 0}, 0.0), ConfigError);
  EXPECT_THROW(m.setOutcomes(4, 0, {1, 0, 0, 0, 0, 0}, 0.0), ConfigError);  // cell
  EXPECT_THROW(m.setOutcomes(0, 4, {1, 0, 0, 0, 0, 0}, 0.0), ConfigError);  // action
  EXPECT_THROW(GridModel(0, 3, 0.9), ConfigError);
  EXPECT_THROW(GridModel(3, 3, -0.1), ConfigError);
}

// 1x4 corridor, "right" is deterministic, goal at cell 3, -1 per move, +10 on entering the
// goal, gamma = 0.9. By hand: V(2) = -1 + 10 = 9; V(1) = -1 + 0.9 * 9 = 7.1;
// V(0) = -1 + 0.9 * 7.1 = 5.39. The other actions stay in place at cost 1 (worse).
TEST(GridModel, CorridorValuesMatchHandSolution) {
  GridModel m(4, 1, 0.9);
  for (StateId c = 0; c < 3; ++c) {
    for (ActionId a = 0; a < 4; ++a) {
      if (a == kActRight) {
        m.setOutcomes(c, a, {0, 0, 0, 0, 1, 0}, c == 2 ? 9.0 : -1.0);
      } else {
        m.setOutcomes(c, a, {1, 0, 0, 0, 0, 0}, -1.0);
      }
    }
  }
  m.setTerminal(3);
  SolverOptions o;
  o.epsilon = 1e-10;
  Solution sol = valueIteration(m, o);
  ASSERT_TRUE(sol.converged);
  EXPECT_NEAR(sol.values[0], 5.39, 1e-9);
  EXPECT_NEAR(sol.values[1], 7.1, 1e-9);
  EXPECT_NEAR(sol.values[2], 9.0, 1e-9);
  EXPECT_EQ(sol.values[3], 0.0);
  for (StateId c = 0; c < 3; ++c) EXPECT_EQ(sol.policy[c], kActRight);
}

TEST(GridModel, GridValueIterationEqualsSparseValueIteration) {
  Rng rng = makeRng(11, "grid_vs_sparse");
  RandomGridOptions ro;
  ro.trap_areas = 2;
  ro.trap_size = 2;
  GridDynamics dyn = makeRandomGridDynamics(9, 7, ro, {0, 62}, rng);
  NavigationReward rw;
  GridModel g = makeNavigationGridModel(dyn, {62}, rw, 0.95);
  GridModelF gf = makeNavigationGridModelF(dyn, {62}, rw, 0.95);
  SparseModel s = g.toSparse();
  SolverOptions o;
  o.epsilon = 1e-10;
  Solution a = valueIteration(g, o), b = valueIteration(s, o), c = valueIteration(gf, o);
  ASSERT_TRUE(a.converged && b.converged && c.converged);
  ASSERT_EQ(a.values.size(), b.values.size());
  for (std::size_t i = 0; i < a.values.size(); ++i) {
    // Each is within epsilon/2 of V*, so they differ by at most epsilon.
    EXPECT_NEAR(a.values[i], b.values[i], 1e-10) << "state " << i;
    // Float storage rounds probabilities (relative 6e-8) and rewards: values agree to ~1e-5.
    EXPECT_NEAR(c.values[i], b.values[i], 1e-4) << "state " << i;
  }
  // Greedy policies agree wherever the best action is not a near-tie.
  for (StateId st = 0; st < s.getS(); ++st) {
    if (s.isTerminal(st)) continue;
    EXPECT_NEAR(qValue(s, b.values, st, a.policy[st]), b.values[st], 1e-8);
  }
}

TEST(GridModel, PipelinedSweepsOnLargeGridsMatchSparseValueIteration) {
  // 110 x 110 cells x 4 actions x 7 doubles = 2.7 MB > 2 MiB: several sweeps per memory pass.
  Rng rng = makeRng(12, "grid_pipeline");
  GridDynamics dyn = makeRandomGridDynamics(110, 110, RandomGridOptions(), {0, 12099}, rng);
  GridModel g = makeNavigationGridModel(dyn, {12099}, NavigationReward(), 0.9);
  SparseModel s = g.toSparse();
  SolverOptions o;
  o.epsilon = 1e-9;
  Solution a = valueIteration(g, o), b = valueIteration(s, o);
  ASSERT_TRUE(a.converged && b.converged);
  EXPECT_LT(a.residual, stoppingThreshold(o.epsilon, 0.9));
  double worst = 0.0;
  for (std::size_t i = 0; i < a.values.size(); ++i) {
    worst = std::max(worst, std::fabs(a.values[i] - b.values[i]));
  }
  EXPECT_LT(worst, 1e-9);
  // A capped solve stops after exactly max_iterations sweeps, even mid-pass.
  o.max_iterations = 6;
  EXPECT_EQ(valueIteration(g, o).iterations, 6u);
}

}  // namespace
}  // namespace mdp
}  // namespace krr
