// Tests of PointBasedSolver's deterministic work budget (SolverOptions::maxTrials) and memory
// limit (SolverOptions::memoryLimit): with the same trial budget two runs give identical bounds,
// a larger budget never gives a lower lower bound (issue 15: reproducible and monotone in the
// budget), and a memory limit stops the search with valid bounds or refuses a model whose
// initial bounds do not fit.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_core/examples/tiger.h"

namespace krr {
namespace pomdp {
using examples::makeTiger;
namespace {

const std::string kData = std::string(KRR_TEST_DATA_DIR) + "/pomdp/";

SolverOptions budget(std::size_t trials) {
  SolverOptions o;
  o.maxTrials = trials;
  o.timeout = 600.0;  // never the limit here: the trial budget is
  o.precision = 1e-9;
  return o;
}

BoundsReport run(const Model& m, const SolverOptions& o) {
  PointBasedSolver solver(m, m.initialBelief(), o);
  solver.solve();
  EXPECT_FALSE(solver.setupReport().timedOut);
  return solver.report();
}

TEST(PointBasedSolverWork, TheSameTrialBudgetGivesIdenticalBounds) {
  const Model rs = loadCassandra(kData + "RockSample_4_4.pomdp");
  for (std::size_t trials : {5u, 40u}) {
    const BoundsReport a = run(rs, budget(trials)), b = run(rs, budget(trials));
    EXPECT_EQ(a.trials, trials);
    EXPECT_EQ(a.lower, b.lower) << trials << " trials";
    EXPECT_EQ(a.upper, b.upper) << trials << " trials";
    EXPECT_EQ(a.alphas, b.alphas);
    EXPECT_EQ(a.points, b.points);
  }
}

TEST(PointBasedSolverWork, MoreTrialsNeverGiveALowerLowerBound) {
  const Model rs = loadCassandra(kData + "RockSample_4_4.pomdp");
  BoundsReport prev = run(rs, budget(1));
  for (std::size_t trials : {2u, 5u, 10u, 20u, 40u, 80u}) {
    const BoundsReport r = run(rs, budget(trials));
    EXPECT_GE(r.lower, prev.lower) << trials << " trials";
    EXPECT_LE(r.upper, prev.upper) << trials << " trials";
    EXPECT_LE(r.lower, r.upper);
    prev = r;
  }
  // The budget is work, not time: 80 trials improve on the blind-policy start.
  EXPECT_GT(prev.lower, run(rs, budget(1)).lower);
}

TEST(PointBasedSolverWork, RunningOnInStepsEqualsOneRun) {
  // runUntil may be called repeatedly (pomdp_solve's checkpoints): the trial budget counts
  // trials in total, so the result does not depend on how the run was split.
  const Model rs = loadCassandra(kData + "RockSample_4_4.pomdp");
  const BoundsReport whole = run(rs, budget(30));
  PointBasedSolver split(rs, rs.initialBelief(), budget(30));
  for (int k = 0; k < 5; ++k) split.runUntil(600.0);
  EXPECT_EQ(split.report().trials, 30u);
  EXPECT_EQ(split.report().lower, whole.lower);
  EXPECT_EQ(split.report().upper, whole.upper);
}

TEST(PointBasedSolverWork, CheckpointsThatDoNotCutTrialsDoNotChangeTheResult) {
  // pomdp_solve reports at checkpoints (runUntil(checkpoint, final deadline)): a trial under
  // way at a checkpoint is finished, so the result equals one uninterrupted run however the
  // checkpoints fall (before, a checkpoint cut the trial under way and the bounds of two
  // runs with the same --max-trials differed).
  const Model rs = loadCassandra(kData + "RockSample_4_4.pomdp");
  const BoundsReport whole = run(rs, budget(30));
  PointBasedSolver split(rs, rs.initialBelief(), budget(30));
  for (int k = 0; k < 100000 && split.report().trials < 30; ++k)
    split.runUntil(split.report().time + 1e-4, 600.0);
  EXPECT_EQ(split.report().trials, 30u);
  EXPECT_EQ(split.report().lower, whole.lower);
  EXPECT_EQ(split.report().upper, whole.upper);
  EXPECT_EQ(split.report().alphas, whole.alphas);
}

TEST(PointBasedSolverWork, AMemoryLimitStopsTheSearchWithValidBounds) {
  const Model rs = loadCassandra(kData + "RockSample_4_4.pomdp");
  const BoundsReport free = run(rs, budget(200));
  ASSERT_GT(free.bytes, 200u * 1024u);
  SolverOptions o = budget(200);
  o.memoryLimit = 200 * 1024;  // enough for the start (9 vectors of 257 states), not for all
  PointBasedSolver solver(rs, rs.initialBelief(), o);
  solver.solve();
  const BoundsReport r = solver.report();
  EXPECT_TRUE(solver.memoryLimited());
  EXPECT_LT(r.trials, 200u);
  EXPECT_LE(r.bytes, o.memoryLimit);
  // Still bounds on the same value: each lower bound is below the other run's upper bound,
  // and the limited run's lower bound is the value of its own policy (it is the max over the
  // vectors it kept).
  EXPECT_LE(r.lower, free.upper + 1e-9);
  EXPECT_LE(free.lower, r.upper + 1e-9);
  EXPECT_LE(r.lower, r.upper);
  EXPECT_NEAR(solver.policy().value(rs.initialBelief()), r.lower, 1e-9);
  EXPECT_FALSE(free.lower < r.lower - 1e-9 && free.trials <= r.trials);
}

TEST(PointBasedSolverWork, AMemoryLimitBelowTheInitialBoundsIsAClearError) {
  const Model rs = loadCassandra(kData + "RockSample_4_4.pomdp");
  SolverOptions o = budget(10);
  o.memoryLimit = 4 * 1024;  // 9 blind-policy vectors of 257 states need 18 KiB
  try {
    PointBasedSolver solver(rs, rs.initialBelief(), o);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("memory limit"), std::string::npos) << e.what();
  }
}

TEST(PointBasedSolverWork, TigerConvergesUnderAGenerousMemoryLimit) {
  const Model tiger = makeTiger();
  SolverOptions o;
  o.timeout = 10.0;
  o.memoryLimit = 1 << 20;
  PointBasedSolver solver(tiger, tiger.initialBelief(), o);
  EXPECT_TRUE(solver.solve());
  EXPECT_FALSE(solver.memoryLimited());
  EXPECT_NEAR(solver.report().lower, 19.37, 0.01);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
