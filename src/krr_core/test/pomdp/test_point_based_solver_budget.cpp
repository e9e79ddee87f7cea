// Tests of PointBasedSolver's time budget (issue 15): the set-up of a model with thousands of
// states took 7.6 s before the first report of a 2 s run. Every set-up phase now stops at the
// deadline and keeps valid bounds; these tests check the budget and the bounds it leaves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/pomdp/point_based_solver.h"

namespace krr {
namespace pomdp {
namespace {

/// @brief A seeded random POMDP with `support` successors per (s, a) (S for dense rows) and
/// two observations per state, rewards in [-10, 10].
Model randomModel(std::uint64_t seed, std::size_t S, std::size_t A, std::size_t O,
                  std::size_t support) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::MatrixXd> t, z;
  const auto n = static_cast<Eigen::Index>(S);
  for (std::size_t a = 0; a < A; ++a) {
    Eigen::MatrixXd ta = Eigen::MatrixXd::Zero(n, n), za = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(O));
    if (support >= S) {
      for (Eigen::Index c = 0; c < n; ++c)
        for (Eigen::Index r = 0; r < n; ++r) ta(r, c) = u(rng);
    } else {
      for (Eigen::Index s = 0; s < n; ++s)
        for (std::size_t k = 0; k < support; ++k) ta(s, static_cast<Eigen::Index>(rng() % S)) += u(rng) + 1e-3;
    }
    for (Eigen::Index s = 0; s < n; ++s) {
      ta.row(s) /= ta.row(s).sum();
      for (int k = 0; k < 2; ++k) za(s, static_cast<Eigen::Index>(rng() % O)) += u(rng) + 1e-3;
      za.row(s) /= za.row(s).sum();
    }
    t.push_back(std::move(ta));
    z.push_back(std::move(za));
  }
  Eigen::MatrixXd r(n, static_cast<Eigen::Index>(A));
  for (Eigen::Index s = 0; s < n; ++s)
    for (Eigen::Index a = 0; a < static_cast<Eigen::Index>(A); ++a) r(s, a) = 20.0 * u(rng) - 10.0;
  return Model(std::move(t), std::move(z), std::move(r), 0.95);
}

/// @brief max_a [R(b, a) + gamma sum_o P(o | b, a) L(b_ao)] for the solver's lower bound L.
double lowerBackupValue(const Model& m, const PointBasedSolver& solver, const Belief& b) {
  double best = -1e300;
  for (std::size_t a = 0; a < m.getA(); ++a) {
    double q = expectedReward(m, b, a);
    for (std::size_t o = 0; o < m.getO(); ++o) {
      const double p = observationProbability(m, b, a, o);
      if (p <= 1e-12) continue;
      q += m.getDiscount() * p * solver.lowerBound(updateBelief(m, b, a, o));
    }
    best = std::max(best, q);
  }
  return best;
}

// Set-up and search together stay within the timeout + 10% on a dense 1500-state model, whose
// exact set-up (an LU per action and per policy-iteration step) takes several seconds.
TEST(PointBasedSolverBudget, SetupAndSearchHonourTheTimeoutOnALargeDenseModel) {
  const Model m = randomModel(5, 1500, 3, 3, 1500);
  const Belief b0 = m.initialBelief();
  for (double timeout : {0.5, 1.0}) {
    SolverOptions o;
    o.timeout = timeout;
    o.precision = 1e-9;
    const Stopwatch sw;
    PointBasedSolver solver(m, b0, o);
    const double setup = sw.seconds();
    solver.solve();
    const double total = sw.seconds();
    const auto rep = solver.report();
    const auto& su = solver.setupReport();
    std::printf("timeout %.1f s: set-up %.3f s (lower %zu sweeps, MDP %zu sweeps, FIB %zu), "
                "total %.3f s, [%.4f, %.4f], %zu trials\n",
                timeout, setup, su.lowerSweeps, su.mdpSweeps, su.fibIterations, total, rep.lower,
                rep.upper, rep.trials);
    // The 10 % target is a figure of bench_pomdp_suite (a timed unit test would be flaky on
    // a loaded machine); here a phase that ignores the deadline (several times over) fails.
    EXPECT_LE(total, 1.5 * timeout) << "timeout " << timeout;
    EXPECT_LE(rep.time, 1.5 * timeout);
    EXPECT_LE(rep.lower, rep.upper);
    EXPECT_TRUE(std::isfinite(rep.lower) && std::isfinite(rep.upper));
    EXPECT_FALSE(solver.converged());
  }
}

// With no set-up time at all, the bounds are the trivial ones (blind-policy iterates started
// at min R / (1 - gamma), max R / (1 - gamma)); they stay valid: they bracket the bounds of a
// full run, and the lower bound is still at most its own backup (the policy earns it).
TEST(PointBasedSolverBudget, CutShortSetupKeepsValidBounds) {
  const Model m = randomModel(7, 600, 3, 3, 4);
  const Belief b0 = m.initialBelief();
  SolverOptions cut;
  cut.setupTimeLimit = 1e-9;
  cut.maxTrials = 20;
  PointBasedSolver quick(m, b0, cut);
  EXPECT_TRUE(quick.setupReport().timedOut);
  const double rmin = m.rewardMatrix().minCoeff(), rmax = m.rewardMatrix().maxCoeff();
  EXPECT_GE(quick.report().lower, rmin / (1.0 - 0.95) - 1e-6);
  EXPECT_LE(quick.report().upper, rmax / (1.0 - 0.95) + 1e-6);
  quick.runUntil(5.0);
  SolverOptions full;
  full.maxTrials = 30;
  PointBasedSolver slow(m, b0, full);
  EXPECT_FALSE(slow.setupReport().timedOut);
  slow.runUntil(10.0);
  std::mt19937_64 rng(3);
  std::gamma_distribution<double> g(0.3, 1.0);
  std::vector<Belief> beliefs{b0};
  for (int k = 0; k < 20; ++k) {
    Belief b(600);
    for (int i = 0; i < 600; ++i) b(i) = g(rng);
    beliefs.push_back(b / b.sum());
  }
  for (const Belief& b : beliefs) {
    EXPECT_LE(quick.lowerBound(b), slow.upperBound(b) + 1e-7);
    EXPECT_GE(quick.upperBound(b), slow.lowerBound(b) - 1e-7);
    const double l = quick.lowerBound(b);
    EXPECT_LE(l, lowerBackupValue(m, quick, b) + 1e-7 * (1.0 + std::fabs(l)));
  }
}

// Above kDenseSetupStates the blind policies are evaluated by Gauss-Seidel sweeps instead of an
// LU; given the time, the sweeps converge to the same values.
TEST(PointBasedSolverBudget, SweptBlindPoliciesMatchTheExactSolve) {
  const std::size_t S = PointBasedSolver::kDenseSetupStates + 100;
  const Model m = randomModel(9, S, 2, 2, 5);
  const Belief b0 = m.initialBelief();
  PointBasedSolver solver(m, b0);
  EXPECT_TRUE(solver.setupReport().lowerExact);
  EXPECT_GT(solver.setupReport().lowerSweeps, 0u);
  double exact = -1e300;
  const auto n = static_cast<Eigen::Index>(S);
  for (std::size_t a = 0; a < 2; ++a) {
    Eigen::MatrixXd lhs = Eigen::MatrixXd::Identity(n, n) - 0.95 * m.denseTransition(a);
    const Eigen::VectorXd alpha =
        lhs.partialPivLu().solve(m.rewardMatrix().col(static_cast<Eigen::Index>(a)));
    exact = std::max(exact, alpha.dot(b0));
  }
  EXPECT_NEAR(solver.report().lower, exact, 1e-6 * (1.0 + std::fabs(exact)));
  EXPECT_LE(solver.report().lower, exact);
}

// Building the dense model is bounded too (pomdp_solve passes what is left of --timeout).
TEST(PointBasedSolverBudget, ModelConstructionStopsAtItsTimeLimit) {
  const Model m = randomModel(11, 300, 2, 2, 300);
  std::vector<Eigen::MatrixXd> t{m.denseTransition(0), m.denseTransition(1)};
  std::vector<Eigen::MatrixXd> z{m.denseObservation(0), m.denseObservation(1)};
  try {
    Model late(t, z, m.rewardMatrix(), 0.95, 1e-12);
    ADD_FAILURE() << "no time limit";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("time limit"), std::string::npos) << e.what();
  }
  EXPECT_EQ(Model(t, z, m.rewardMatrix(), 0.95, 60.0).getS(), 300u);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
