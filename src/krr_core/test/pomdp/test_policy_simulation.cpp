// Bound-sanity test of issue 15: the policy pomdp_solve writes (APPL XML) must earn the lower
// bound the solver certifies at b0. TheLowerBoundNeverExceedsItsOwnBackup
// (test_point_based_solver.cpp) checks the invariant that implies it, one step at a time, on
// random models; this test checks the end result instead: the written file, read back and run
// by a simulator that shares no code with the solver (own sampling from the dense matrices, own
// belief update), on Tiger, RockSample[4,4] and random POMDPs, at several budgets.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "krr_core/common/files.h"
#include "krr_core/pomdp/alpha_policy.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_core/examples/tiger.h"

namespace krr {
namespace pomdp {
using examples::makeTiger;
namespace {

const std::string kData = std::string(KRR_TEST_DATA_DIR) + "/pomdp/";

/// @brief Index drawn from the distribution `w` (non-negative, summing to about 1).
template <typename Row>
Eigen::Index draw(const Row& w, std::mt19937_64& rng) {
  double u = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  Eigen::Index last = 0;
  for (Eigen::Index i = 0; i < w.size(); ++i) {
    if (w(i) <= 0.0) continue;
    last = i;
    if (u < w(i)) return i;
    u -= w(i);
  }
  return last;
}

struct SimResult {
  double mean = 0.0, se = 0.0;
};

/// @brief Mean discounted return of `policy` from b0 over `episodes` episodes of `horizon`
/// steps (episodes stop early in absorbing zero-reward states). The belief update only visits
/// the belief's support, so that RockSample's 257 states stay cheap.
SimResult simulate(const Model& m, const AlphaVectorPolicy& policy, const Belief& b0,
                   std::size_t episodes, std::size_t horizon, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const auto S = static_cast<Eigen::Index>(m.getS());
  const double gamma = m.getDiscount();
  double sum = 0.0, sum2 = 0.0;
  Belief b(S), next(S);
  std::vector<Eigen::MatrixXd> tm, zm;  // dense copies, whatever the model's own storage
  for (std::size_t a = 0; a < m.getA(); ++a) {
    tm.push_back(m.denseTransition(a));
    zm.push_back(m.denseObservation(a));
  }
  for (std::size_t e = 0; e < episodes; ++e) {
    Eigen::Index s = draw(b0, rng);
    b = b0;
    double ret = 0.0, disc = 1.0;
    for (std::size_t t = 0; t < horizon; ++t) {
      std::vector<Eigen::Index> support;
      for (Eigen::Index i = 0; i < S; ++i)
        if (b(i) > 0.0) support.push_back(i);
      // Greedy action of the written vectors, evaluated on the support only.
      std::size_t a = 0;
      double best = -1e300;
      for (std::size_t k = 0; k < policy.size(); ++k) {
        double v = 0.0;
        for (Eigen::Index i : support) v += policy.alpha(k)(i) * b(i);
        if (v > best) {
          best = v;
          a = policy.action(k);
        }
      }
      const auto& T = tm[a];
      const auto& Z = zm[a];
      ret += disc * m.rewardMatrix()(s, static_cast<Eigen::Index>(a));
      disc *= gamma;
      const Eigen::Index s1 = draw(T.row(s), rng);
      const Eigen::Index o = draw(Z.row(s1), rng);
      if (T(s1, s1) == 1.0 && m.rewardMatrix().row(s1).isZero(0.0)) {
        bool absorbing = true;  // zero reward and absorbing under every action: episode over
        for (std::size_t a2 = 0; a2 < m.getA() && absorbing; ++a2)
          absorbing = tm[a2](s1, s1) == 1.0;
        if (absorbing) break;
      }
      next.setZero();
      for (Eigen::Index i : support)
        for (Eigen::Index j = 0; j < S; ++j)
          if (T(i, j) > 0.0) next(j) += b(i) * T(i, j);
      next = next.cwiseProduct(Z.col(o));
      const double p = next.sum();
      EXPECT_GT(p, 0.0) << "observation of probability 0 was drawn";
      if (!(p > 0.0)) break;
      b = next / p;
      s = s1;
    }
    sum += ret;
    sum2 += ret * ret;
  }
  const double n = static_cast<double>(episodes);
  SimResult r;
  r.mean = sum / n;
  r.se = std::sqrt(std::max(0.0, sum2 / n - r.mean * r.mean) / (n - 1.0));
  return r;
}

/// @brief A seeded random POMDP (sparse transitions, two observations per state).
Model randomModel(std::uint64_t seed, std::size_t S, std::size_t A, std::size_t O) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto n = static_cast<Eigen::Index>(S);
  std::vector<Eigen::MatrixXd> t, z;
  for (std::size_t a = 0; a < A; ++a) {
    Eigen::MatrixXd ta = Eigen::MatrixXd::Zero(n, n), za = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(O));
    for (Eigen::Index s = 0; s < n; ++s) {
      for (int k = 0; k < 3; ++k) ta(s, static_cast<Eigen::Index>(rng() % S)) += u(rng) + 1e-3;
      for (int k = 0; k < 2; ++k) za(s, static_cast<Eigen::Index>(rng() % O)) += u(rng) + 1e-3;
      ta.row(s) /= ta.row(s).sum();
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

/// @brief Solve with a trial budget (deterministic), write the policy as pomdp_solve does, read
/// it back and simulate it; the mean must reach the certified bound within 3 standard errors
/// (plus the discounted tail beyond the horizon).
void checkProblem(const std::string& label, const Model& m, std::size_t trials,
                  std::size_t episodes) {
  SolverOptions o;
  o.maxTrials = trials;
  o.timeout = 60.0;
  PointBasedSolver solver(m, m.initialBelief(), o);
  solver.solve();
  const BoundsReport rep = solver.report();
  ASSERT_LE(rep.lower, rep.upper + 1e-9) << label;
  const std::string path = testing::TempDir() + "policy_simulation_" + label + ".policy";
  solver.policy().writeApplXml(path, label);
  const AlphaVectorPolicy written = AlphaVectorPolicy::fromApplXml(readFile(path), path);
  ASSERT_EQ(written.size(), rep.alphas) << label;
  EXPECT_NEAR(written.value(m.initialBelief()), rep.lower, 1e-6 * (1.0 + std::fabs(rep.lower)))
      << label << ": the written vectors are not the certified bound";
  const std::size_t horizon = 300;
  const double rmax = m.rewardMatrix().cwiseAbs().maxCoeff();
  const double tail = std::pow(m.getDiscount(), horizon) * rmax / (1.0 - m.getDiscount());
  const SimResult sim = simulate(m, written, m.initialBelief(), episodes, horizon, 1234 + trials);
  std::printf("%-14s %5zu trials: certified [%.4f, %.4f], simulated %.4f +- %.4f (%zu episodes, "
              "%zu vectors)\n",
              label.c_str(), trials, rep.lower, rep.upper, sim.mean, sim.se, episodes, rep.alphas);
  EXPECT_GE(sim.mean, rep.lower - 3.0 * sim.se - tail)
      << label << ", " << trials << " trials: the written policy earns less than its bound";
  // The simulated value cannot beat the upper bound either (same tolerance).
  EXPECT_LE(sim.mean, rep.upper + 3.0 * sim.se + tail) << label;
}

TEST(PolicySimulation, TigerEarnsItsCertifiedLowerBound) {
  const Model tiger = makeTiger();
  for (std::size_t trials : {2u, 20u, 500u}) checkProblem("tiger", tiger, trials, 4000);
}

TEST(PolicySimulation, RandomPomdpsEarnTheirCertifiedLowerBound) {
  for (std::uint64_t seed : {21u, 22u}) {
    const Model m = randomModel(seed, 15, 4, 3);
    for (std::size_t trials : {10u, 300u})
      checkProblem("random" + std::to_string(seed), m, trials, 1500);
  }
}

TEST(PolicySimulation, RockSample44EarnsItsCertifiedLowerBound) {
  const Model rs = loadCassandra(kData + "RockSample_4_4.pomdp");
  ASSERT_EQ(rs.getS(), 257u);
  for (std::size_t trials : {30u, 150u}) checkProblem("rocksample44", rs, trials, 1500);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
