// Tests of PointBasedSolver on Tiger (general POMDP: resets, non-identity transitions).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "../support/pomdp_random.h"
#include "krr_core/examples/tiger.h"

namespace krr {
namespace pomdp {
using examples::makeTiger;
namespace {

// ---- Independent reference: exact value iteration for 2-state POMDPs -------------------
// A vector (v0, v1) is the line V(x) = v0 (1 - x) + v1 x, x = b(state 1). The exact DP
// V_{n+1} = max_a [R_a + gamma sum_o proj_{a,o}(V_n)] is done by cross-sums, pruning each
// intermediate set to its upper envelope over [0, 1] (incremental pruning, Cassandra,
// Littman & Zhang 1997). In one dimension the envelope is exact without an LP.
using Line = std::array<double, 2>;

std::vector<Line> envelope(std::vector<Line> v) {
  // sort by slope, keep the max intercept per slope, then the convex-hull trick.
  std::sort(v.begin(), v.end(), [](const Line& a, const Line& b) {
    double sa = a[1] - a[0], sb = b[1] - b[0];
    return sa < sb || (sa == sb && a[0] > b[0]);
  });
  std::vector<Line> hull;
  auto slope = [](const Line& l) { return l[1] - l[0]; };
  auto cross = [&](const Line& a, const Line& b) {  // x where a and b meet
    return (a[0] - b[0]) / (slope(b) - slope(a));
  };
  for (const auto& l : v) {
    if (!hull.empty() && std::abs(slope(hull.back()) - slope(l)) < 1e-15) continue;
    while (hull.size() >= 2 &&
           cross(hull[hull.size() - 2], l) <= cross(hull[hull.size() - 2], hull.back()))
      hull.pop_back();
    hull.push_back(l);
  }
  // keep lines whose dominance interval meets (0, 1)
  std::vector<Line> out;
  for (std::size_t i = 0; i < hull.size(); ++i) {
    double lo = i == 0 ? -1e300 : cross(hull[i - 1], hull[i]);
    double hi = i + 1 == hull.size() ? 1e300 : cross(hull[i], hull[i + 1]);
    if (std::min(hi, 1.0) - std::max(lo, 0.0) > 1e-12) out.push_back(hull[i]);
  }
  return out;
}

std::vector<Line> exactTwoStateVectors(const Model& m, int* iterations) {
  std::vector<Line> v{{0.0, 0.0}};
  const double g = m.getDiscount();
  for (int it = 0; it < 5000; ++it) {
    std::vector<Line> all;
    for (std::size_t a = 0; a < m.getA(); ++a) {
      std::vector<Line> acc{{m.getExpectedReward(0, a), m.getExpectedReward(1, a)}};
      for (std::size_t o = 0; o < m.getO(); ++o) {
        std::vector<Line> proj;
        for (const auto& l : v) {
          Line p{0.0, 0.0};
          for (std::size_t s = 0; s < 2; ++s)
            for (std::size_t s1 = 0; s1 < 2; ++s1)
              p[s] += g * m.getTransitionProbability(s, a, s1) *
                      m.getObservationProbability(s1, a, o) * l[s1];
          proj.push_back(p);
        }
        std::vector<Line> sum;
        for (const auto& l1 : acc)
          for (const auto& l2 : envelope(proj)) sum.push_back({l1[0] + l2[0], l1[1] + l2[1]});
        acc = envelope(sum);
      }
      all.insert(all.end(), acc.begin(), acc.end());
    }
    auto next = envelope(all);
    double delta = 0.0;  // sup-norm change, checked on a fine grid
    for (int k = 0; k <= 200; ++k) {
      double xx = k / 200.0, a = -1e300, b = -1e300;
      for (const auto& l : v) a = std::max(a, l[0] * (1 - xx) + l[1] * xx);
      for (const auto& l : next) b = std::max(b, l[0] * (1 - xx) + l[1] * xx);
      delta = std::max(delta, std::abs(a - b));
    }
    v = next;
    if (delta < 1e-10) {
      *iterations = it + 1;
      break;
    }
  }
  return v;
}

double valueAt(const std::vector<Line>& v, double x) {
  double best = -1e300;
  for (const auto& l : v) best = std::max(best, l[0] * (1 - x) + l[1] * x);
  return best;
}

TEST(PointBasedSolver, TigerValueMatchesExactAndLiterature) {
  Model tiger = makeTiger();
  int iters = 0;
  const double exact = valueAt(exactTwoStateVectors(tiger, &iters), 0.5);
  EXPECT_GT(iters, 10);
  // Literature: the optimal infinite-horizon value of tiger.95 at the uniform belief is
  // 19.37 (as reported for tiger.95.pomdp by pomdp-solve / APPL runs; see the task brief).
  EXPECT_NEAR(exact, 19.37, 0.01);

  SolverOptions opt;
  opt.precision = 1e-3;
  PointBasedSolver solver(tiger, tiger.initialBelief(), opt);
  EXPECT_TRUE(solver.runUntil(5.0));
  auto rep = solver.report();
  std::printf("tiger: exact %.6f (%d iterations), solver [%.6f, %.6f] in %.3f s, %zu alphas\n",
              exact, iters, rep.lower, rep.upper, rep.time, rep.alphas);
  EXPECT_LE(rep.lower, exact + 1e-9);
  EXPECT_GE(rep.upper, exact - 1e-9);
  EXPECT_LE(rep.gap(), 1e-3);
}

TEST(PointBasedSolver, TigerPolicyListensThenOpensAfterTwoConsistentObservations) {
  Model tiger = makeTiger();
  PointBasedSolver solver(tiger, tiger.initialBelief());
  solver.runUntil(5.0);
  AlphaVectorPolicy pol = solver.policy();
  const std::size_t listen = tiger.actionIndex("listen");
  const std::size_t openRight = tiger.actionIndex("open-right");
  const std::size_t openLeft = tiger.actionIndex("open-left");
  const std::size_t hearLeft = tiger.observationIndex("tiger-left");
  const std::size_t hearRight = tiger.observationIndex("tiger-right");
  Belief b = tiger.initialBelief();
  EXPECT_EQ(pol.bestAction(b), listen);
  b = updateBelief(tiger, b, listen, hearLeft);  // (0.85, 0.15)
  EXPECT_EQ(pol.bestAction(b), listen);
  b = updateBelief(tiger, b, listen, hearLeft);  // (0.9698, 0.0302)
  EXPECT_EQ(pol.bestAction(b), openRight);
  // inconsistent answers bring the belief back to uniform: listen again
  Belief c = updateBelief(tiger, tiger.initialBelief(), listen, hearRight);
  c = updateBelief(tiger, c, listen, hearLeft);
  EXPECT_NEAR(c(0), 0.5, 1e-12);
  EXPECT_EQ(pol.bestAction(c), listen);
  c = updateBelief(tiger, tiger.initialBelief(), listen, hearRight);
  c = updateBelief(tiger, c, listen, hearRight);
  EXPECT_EQ(pol.bestAction(c), openLeft);
}

TEST(PointBasedSolver, BoundsBracketExactValueAndGapShrinksMonotonically) {
  Model tiger = makeTiger();
  int iters = 0;
  const auto exactVectors = exactTwoStateVectors(tiger, &iters);
  const double exact = valueAt(exactVectors, 0.5);
  SolverOptions opt;
  opt.precision = 1e-6;
  PointBasedSolver solver(tiger, tiger.initialBelief(), opt);
  auto prev = solver.report();
  EXPECT_LE(prev.lower, exact);
  EXPECT_GE(prev.upper, exact);
  for (double t = 0.002; t < 1.0; t *= 2) {
    solver.runUntil(t);
    auto r = solver.report();
    EXPECT_LE(r.lower, exact + 1e-9);
    EXPECT_GE(r.upper, exact - 1e-9);
    EXPECT_GE(r.lower, prev.lower);
    EXPECT_LE(r.upper, prev.upper);
    EXPECT_LE(r.gap(), prev.gap());
    prev = r;
  }
  EXPECT_LT(prev.gap(), 0.01);
  // Bounds elsewhere in the simplex also bracket the exact value.
  for (double x : {0.0, 0.1, 0.3, 0.7, 0.97, 1.0}) {
    Belief b(2);
    b << 1 - x, x;
    const double v = valueAt(exactVectors, x);
    EXPECT_LE(solver.lowerBound(b), v + 1e-9) << x;
    EXPECT_GE(solver.upperBound(b), v - 1e-9) << x;
  }
}

TEST(PointBasedSolver, RejectsUndiscountedModelsAndBadBeliefs) {
  Model undiscounted = makeTiger(1.0);
  EXPECT_THROW(PointBasedSolver(undiscounted, undiscounted.initialBelief()), ConfigError);
  Model tiger = makeTiger();
  Belief bad(2);
  bad << 0.7, 0.7;
  EXPECT_THROW(PointBasedSolver(tiger, bad), ConfigError);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr

namespace krr {
namespace pomdp {
namespace {

using test::randomSparseModel;

/// @brief max_a [R(b, a) + gamma sum_o P(o | b, a) L(b_ao)] for the solver's lower bound L.
double lowerBackupValue(const Model& m, const PointBasedSolver& solver, const Belief& b) {
  double best = -1e300;
  for (std::size_t a = 0; a < m.getA(); ++a) {
    double q = 0.0;
    for (std::size_t s = 0; s < m.getS(); ++s) q += b(static_cast<Eigen::Index>(s)) * m.getExpectedReward(s, a);
    for (std::size_t o = 0; o < m.getO(); ++o) {
      const double p = observationProbability(m, b, a, o);
      if (p <= 1e-12) continue;
      q += m.getDiscount() * p * solver.lowerBound(updateBelief(m, b, a, o));
    }
    best = std::max(best, q);
  }
  return best;
}

// The lower bound must be the value of the policy the solver returns (issue 15): the greedy
// policy of a vector set earns its bound when no belief's bound exceeds its own one-step
// backup, L(b) <= max_a [R(b,a) + gamma E L(b_ao)]. Checked at the beliefs the policy visits
// and at random beliefs, on several random POMDPs and budgets (pruning included).
TEST(PointBasedSolver, TheLowerBoundNeverExceedsItsOwnBackup) {
  std::mt19937_64 rng(11);
  std::gamma_distribution<double> g(0.5, 1.0);
  std::size_t checked = 0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Model m = randomSparseModel(seed, 12, 4, 3);
    Belief b0 = Belief::Constant(12, 1.0 / 12);
    for (std::size_t trials : {30u, 300u, 2000u}) {
      SolverOptions o;
      o.maxTrials = trials;
      o.timeout = 30;
      PointBasedSolver solver(m, b0, o);
      solver.solve();
      const AlphaVectorPolicy pol = solver.policy();
      std::vector<Belief> beliefs;
      for (int run = 0; run < 6; ++run) {  // beliefs the greedy policy reaches
        Belief b = b0;
        std::size_t s = rng() % 12;
        for (int step = 0; step < 15; ++step) {
          beliefs.push_back(b);
          const std::size_t a = pol.bestAction(b);
          const auto [s1, obs, r] = m.sampleSOR(s, a, rng);
          (void)r;
          if (observationProbability(m, b, a, obs) <= 1e-12) break;
          b = updateBelief(m, b, a, obs);
          s = s1;
        }
      }
      for (int k = 0; k < 50; ++k) {  // and anywhere
        Belief b(12);
        for (int i = 0; i < 12; ++i) b(i) = g(rng);
        beliefs.push_back(b / b.sum());
      }
      for (const Belief& b : beliefs) {
        const double l = solver.lowerBound(b), backup = lowerBackupValue(m, solver, b);
        ASSERT_LE(l, backup + 1e-7 * (1.0 + std::fabs(l)))
            << "seed " << seed << ", " << trials << " trials: L(b) exceeds its backup by "
            << l - backup;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 1000u);
}


/// @brief Value iteration over a fine grid of the 3-state belief simplex, with barycentric
/// interpolation on its Freudenthal triangulation: an independent reference that, because V*
/// is convex, converges to an upper bound of V* (Lovejoy 1991) that tightens as 1/n.
class SimplexGridValue {
 public:
  SimplexGridValue(const Model& m, int n) : m_(m), n_(n), v_((n + 1) * (n + 1), 0.0) {
    for (int sweep = 0; sweep < 5000; ++sweep) {
      std::vector<double> next(v_.size(), 0.0);
      double delta = 0.0;
      for (int i = 0; i <= n_; ++i)
        for (int j = 0; i + j <= n_; ++j) {
          Belief b(3);
          b << double(n_ - i - j) / n_, double(i) / n_, double(j) / n_;
          next[idx(i, j)] = backup(b);
          delta = std::max(delta, std::fabs(next[idx(i, j)] - v_[idx(i, j)]));
        }
      v_.swap(next);
      if (delta < 1e-9) return;
    }
  }
  double value(const Belief& b) const {
    const double u = b(1) * n_, w = b(2) * n_;
    int i = std::min(static_cast<int>(u), n_), j = std::min(static_cast<int>(w), n_ - i);
    const double fu = u - i, fw = w - j;
    if (i + j == n_) return v_[idx(i, j)];
    if (fu + fw <= 1.0)
      return (1 - fu - fw) * v_[idx(i, j)] + fu * v_[idx(i + 1, j)] + fw * v_[idx(i, j + 1)];
    return (fu + fw - 1) * v_[idx(i + 1, j + 1)] + (1 - fw) * v_[idx(i + 1, j)] +
           (1 - fu) * v_[idx(i, j + 1)];
  }

 private:
  std::size_t idx(int i, int j) const { return static_cast<std::size_t>(i * (n_ + 1) + j); }
  double backup(const Belief& b) const {
    double best = -1e300;
    for (std::size_t a = 0; a < m_.getA(); ++a) {
      double q = 0.0;
      for (std::size_t s = 0; s < 3; ++s) q += b(static_cast<Eigen::Index>(s)) * m_.getExpectedReward(s, a);
      for (std::size_t o = 0; o < m_.getO(); ++o) {
        const double p = observationProbability(m_, b, a, o);
        if (p > 1e-12) q += m_.getDiscount() * p * value(updateBelief(m_, b, a, o));
      }
      best = std::max(best, q);
    }
    return best;
  }
  const Model& m_;
  int n_;
  std::vector<double> v_;
};

// Issue 15's third canonical check: a converged solve of 3-state problems agrees with value
// iteration over a fine belief grid. The grid value is an upper bound of V*, so the solver's
// lower bound may never exceed it anywhere; and it comes within the grid's own error.
/// @brief Tiger behind one of three doors: listening (-1) names the right door with 0.7 and
/// each other door with 0.15; opening a door pays +10, or -100 on the tiger, and resets.
Model threeDoorTiger() {
  std::vector<Eigen::MatrixXd> t, z;
  Eigen::MatrixXd r(3, 4);
  t.push_back(Eigen::MatrixXd::Identity(3, 3));
  Eigen::MatrixXd hear = Eigen::MatrixXd::Constant(3, 3, 0.15);
  hear.diagonal().setConstant(0.7);
  z.push_back(hear);
  for (int door = 0; door < 3; ++door) {
    t.push_back(Eigen::MatrixXd::Constant(3, 3, 1.0 / 3));
    z.push_back(Eigen::MatrixXd::Constant(3, 3, 1.0 / 3));
  }
  for (int s = 0; s < 3; ++s) {
    r(s, 0) = -1.0;
    for (int door = 0; door < 3; ++door) r(s, door + 1) = (s == door) ? -100.0 : 10.0;
  }
  return Model(t, z, r, 0.95);
}

TEST(PointBasedSolver, ThreeStateProblemsMatchFineGridValueIteration) {
  for (std::uint64_t seed : {0u, 4u, 5u}) {
    const Model m = seed == 0 ? threeDoorTiger() : randomSparseModel(seed, 3, 3, 2);
    const SimplexGridValue coarse(m, 30), fine(m, 90);
    const Belief b0 = Belief::Constant(3, 1.0 / 3);
    SolverOptions o;
    o.precision = 1e-4;
    o.timeout = 20;
    PointBasedSolver solver(m, b0, o);
    solver.solve();
    const auto r = solver.report();
    ASSERT_LT(r.gap(), 1e-3) << "seed " << seed;
    std::mt19937_64 rng(seed);
    std::gamma_distribution<double> g(0.5, 1.0);
    for (int k = 0; k < 200; ++k) {
      const double x = g(rng), y = g(rng), w = g(rng);
      Belief b(3);
      b << x / (x + y + w), y / (x + y + w), w / (x + y + w);  // (not b /= sum: GCC 12 warns)
      EXPECT_LE(solver.lowerBound(b), fine.value(b) + 1e-7) << "seed " << seed;
    }
    // At b0 the grid closes in on the solver's value from above as 1/n: tripling n at
    // least halves its excess over the certified lower bound (up to the solver's own gap). A
    // lower bound above V* breaks the first check; one far below it (on the three-door tiger,
    // by more than about 1.5 of 14.8) breaks the second.
    const double errFine = fine.value(b0) - r.lower, errCoarse = coarse.value(b0) - r.lower;
    EXPECT_GE(errFine, -1e-7) << "seed " << seed;
    EXPECT_LE(errFine, 0.5 * errCoarse + r.gap() + 1e-6) << "seed " << seed;
    std::printf("seed %llu: solver %.6f / %.6f, grid n=30 %.6f, n=90 %.6f\n",
                static_cast<unsigned long long>(seed), r.lower, r.upper, coarse.value(b0),
                fine.value(b0));
  }
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
