// Tests of PointBasedSolver's pruning of sawtooth points (SolverOptions::pointPruning,
// PointBasedSolver::prunePoints): a point is removed only when the other points, the corners
// or the FIB vectors already give a value at or below its own at its belief, so the upper
// bound must be the same function before and after, while points are actually removed on
// problems where later points dominate earlier ones.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "krr_core/pomdp/belief.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "../support/pomdp_random.h"

namespace krr {
namespace pomdp {
namespace {

const std::string kData = std::string(KRR_TEST_DATA_DIR) + "/pomdp/";

using test::randomSparseModel;

/// @brief Beliefs to compare the bound at: those the greedy policy of the solver reaches from
/// b0 (where the trials went, so near the stored points), random dense ones, and random
/// ones on 1 to 3 states (sparse beliefs meet few points' supports).
std::vector<Belief> probeBeliefs(const Model& m, const PointBasedSolver& solver, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::gamma_distribution<double> g(0.5, 1.0);
  const std::size_t S = m.getS();
  const AlphaVectorPolicy pol = solver.policy();
  std::vector<Belief> out;
  std::uniform_int_distribution<std::size_t> state(0, S - 1);
  for (int run = 0; run < 20; ++run) {
    Belief b = m.initialBelief();
    std::size_t s = state(rng);
    for (int step = 0; step < 20; ++step) {
      out.push_back(b);
      // Mostly the greedy action, sometimes another one, to leave the policy's path.
      const std::size_t a = step % 3 == 2 ? rng() % m.getA() : pol.bestAction(b);
      const auto [s1, obs, r] = m.sampleSOR(s, a, rng);
      (void)r;
      Belief next;
      if (!tryUpdateBelief(m, b, a, obs, next)) break;
      b = next;
      s = s1;
    }
  }
  for (int k = 0; k < 200; ++k) {
    Belief b(static_cast<Eigen::Index>(S));
    for (std::size_t i = 0; i < S; ++i) b(static_cast<Eigen::Index>(i)) = g(rng);
    out.push_back(b / b.sum());
    Belief sparse = Belief::Zero(static_cast<Eigen::Index>(S));
    for (int j = 0; j < 1 + k % 3; ++j) sparse(static_cast<Eigen::Index>(state(rng))) += g(rng) + 1e-3;
    out.push_back(sparse / sparse.sum());
  }
  return out;
}

/// @brief Prune the points of a search run without pruning, and check the bound at `probes`.
void expectPruningKeepsTheBound(const Model& m, std::size_t trials, std::size_t* removedOut) {
  SolverOptions o;
  o.maxTrials = trials;
  o.timeout = 600.0;  // the trial budget is the limit
  o.pointPruning = false;
  PointBasedSolver solver(m, m.initialBelief(), o);
  solver.solve();
  ASSERT_EQ(solver.report().trials, trials);
  const std::size_t before = solver.report().points;
  const std::vector<Belief> probes = probeBeliefs(m, solver, trials);
  std::vector<double> u;
  for (const Belief& b : probes) u.push_back(solver.upperBound(b));
  const double rootBefore = solver.upperBound(m.initialBelief());
  const std::size_t removed = solver.prunePoints();
  EXPECT_EQ(solver.report().points, before - removed);
  for (std::size_t k = 0; k < probes.size(); ++k)
    ASSERT_NEAR(solver.upperBound(probes[k]), u[k], 1e-9 * (1.0 + std::fabs(u[k])))
        << "probe " << k << " of " << probes.size() << ", " << removed << " of " << before
        << " points removed";
  EXPECT_NEAR(solver.upperBound(m.initialBelief()), rootBefore, 1e-9 * (1.0 + std::fabs(rootBefore)));
  *removedOut = removed;
}

TEST(PointBasedSolverPruning, PruningNeverChangesTheUpperBoundOnRandomModels) {
  std::size_t removed = 0, total = 0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Model m = randomSparseModel(seed, 12, 4, 3);
    for (std::size_t trials : {40u, 200u}) {
      SCOPED_TRACE("seed " + std::to_string(seed) + ", " + std::to_string(trials) + " trials");
      expectPruningKeepsTheBound(m, trials, &removed);
      total += removed;
      // Deep trials at nearby dense beliefs: later points dominate many earlier ones.
      EXPECT_GT(removed, 0u);
    }
  }
  EXPECT_GT(total, 100u);
}

TEST(PointBasedSolverPruning, PruningNeverChangesTheUpperBoundOnRockSample) {
  // Sparse beliefs (the robot's position is known): points rarely share a support.
  const Model rs = loadCassandra(kData + "RockSample_4_4.pomdp");
  std::size_t removed = 0;
  expectPruningKeepsTheBound(rs, 60, &removed);
}

TEST(PointBasedSolverPruning, ADominatedPointIsRemovedAndTheOthersStay) {
  // Pruning checks each point against the points still kept, oldest first: what it keeps is
  // not dominated by the rest, so pruning again removes nothing, and it never removes the
  // newest point, which improved on all the others where the search stored it.
  const Model m = randomSparseModel(7, 12, 4, 3);
  SolverOptions o;
  o.maxTrials = 150;
  o.timeout = 600.0;
  o.pointPruning = false;
  PointBasedSolver solver(m, m.initialBelief(), o);
  solver.solve();
  const std::size_t before = solver.report().points;
  const std::size_t removed = solver.prunePoints();
  EXPECT_GT(removed, 0u);
  EXPECT_LT(removed, before);  // not everything: the newest points improve the bound
  EXPECT_EQ(solver.prunePoints(), 0u);
  EXPECT_EQ(solver.report().points, before - removed);
}

TEST(PointBasedSolverPruning, PruningDuringTheSearchChangesNothingButThePointCount) {
  // The search only reads the bound's values, which pruning leaves as they were: with the
  // same trial budget, the run with pruning reaches the same bounds with fewer points.
  const Model m = randomSparseModel(2, 12, 4, 3);
  SolverOptions o;
  o.maxTrials = 300;
  o.timeout = 600.0;
  o.pointPruning = false;
  PointBasedSolver plain(m, m.initialBelief(), o);
  plain.solve();
  o.pointPruning = true;
  PointBasedSolver pruned(m, m.initialBelief(), o);
  pruned.solve();
  const BoundsReport a = plain.report(), b = pruned.report();
  EXPECT_NEAR(b.lower, a.lower, 1e-9 * (1.0 + std::fabs(a.lower)));
  EXPECT_NEAR(b.upper, a.upper, 1e-9 * (1.0 + std::fabs(a.upper)));
  EXPECT_GT(pruned.profile().pointPrunes, 0u);
  EXPECT_GT(pruned.profile().pointsPruned, 0u);
  EXPECT_EQ(b.points + pruned.profile().pointsPruned, pruned.profile().pointsAdded);
  EXPECT_LT(b.points, a.points);
  EXPECT_LT(b.bytes, a.bytes);
  EXPECT_EQ(plain.profile().pointsPruned, 0u);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
