// Sparse storage of T and O (issue 15): the sparse form must give the same beliefs, backups and
// solver bounds as the dense one, and a model of thousands of states must load within a small
// memory budget (RockSample[5,7] was refused: its dense tables needed 3.7 GiB).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/point_based_solver.h"

namespace krr {
namespace pomdp {
namespace {

struct Tables {
  std::vector<Eigen::MatrixXd> t, z;
  Eigen::MatrixXd r;
};

/// @brief A random POMDP with `support` successors per (s, a), two observations per (s1, a)
/// and, for action 0, identity transitions (the dialog's questions take that path).
Tables randomTables(std::uint64_t seed, std::size_t S, std::size_t A, std::size_t O,
                    std::size_t support) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Tables m;
  const auto n = static_cast<Eigen::Index>(S);
  for (std::size_t a = 0; a < A; ++a) {
    Eigen::MatrixXd ta = Eigen::MatrixXd::Zero(n, n);
    Eigen::MatrixXd za = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(O));
    for (Eigen::Index s = 0; s < n; ++s) {
      if (a == 0) {
        ta(s, s) = 1.0;
      } else {
        for (std::size_t k = 0; k < support; ++k)
          ta(s, static_cast<Eigen::Index>(rng() % S)) += u(rng) + 1e-3;
        ta.row(s) /= ta.row(s).sum();
      }
      for (int k = 0; k < 2; ++k) za(s, static_cast<Eigen::Index>(rng() % O)) += u(rng) + 1e-3;
      za.row(s) /= za.row(s).sum();
    }
    m.t.push_back(std::move(ta));
    m.z.push_back(std::move(za));
  }
  m.r.resize(n, static_cast<Eigen::Index>(A));
  for (Eigen::Index s = 0; s < n; ++s)
    for (Eigen::Index a = 0; a < static_cast<Eigen::Index>(A); ++a) m.r(s, a) = 20.0 * u(rng) - 10.0;
  return m;
}

/// @brief The same tables as sparse rows (the reader's form).
std::vector<SparseRows> rowsOf(const std::vector<Eigen::MatrixXd>& mats) {
  std::vector<SparseRows> out;
  for (const auto& m : mats) {
    SparseRows rows;
    rows.cols = static_cast<std::size_t>(m.cols());
    for (Eigen::Index s = 0; s < m.rows(); ++s) {
      std::vector<ModelEntry> row;
      for (Eigen::Index k = 0; k < m.cols(); ++k)
        if (m(s, k) > 0.0) row.emplace_back(static_cast<std::size_t>(k), m(s, k));
      rows.pushRow(row);
    }
    out.push_back(std::move(rows));
  }
  return out;
}

/// @brief Random beliefs: the uniform one, full-support ones and peaked ones (few states).
std::vector<Belief> randomBeliefs(std::size_t S, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::gamma_distribution<double> g(0.3, 1.0);
  std::vector<Belief> out{Belief::Constant(static_cast<Eigen::Index>(S), 1.0 / S)};
  for (int k = 0; k < 6; ++k) {
    Belief b = Belief::Zero(static_cast<Eigen::Index>(S));
    const std::size_t support = k < 3 ? S : 3;
    for (std::size_t i = 0; i < support; ++i) b(static_cast<Eigen::Index>(rng() % S)) += g(rng) + 1e-3;
    out.push_back(b / b.sum());
  }
  return out;
}

constexpr double kTol = 1e-12;

TEST(SparseModel, StorageFollowsSizeAndDensity) {
  const Tables small = randomTables(1, 20, 3, 4, 2);
  EXPECT_TRUE(Model(small.t, small.z, small.r, 0.95).hasDenseTransitions());  // tiny: dense
  const Tables sparse = randomTables(2, 200, 3, 4, 3);
  const Model auto200(sparse.t, sparse.z, sparse.r, 0.95);
  EXPECT_FALSE(auto200.hasDenseTransitions());  // 1.5% non-zero: sparse
  EXPECT_TRUE(auto200.hasDenseObservations());  // 200 x 4 per action is cheap
  EXPECT_THROW(auto200.transitionMatrix(1), std::logic_error);
  const Tables dense = randomTables(3, 200, 3, 4, 200);
  EXPECT_TRUE(Model(dense.t, dense.z, dense.r, 0.95).hasDenseTransitions());
  const Model forced(sparse.t, sparse.z, sparse.r, 0.95, 0.0, ModelStorage::kSparse);
  EXPECT_FALSE(forced.hasDenseTransitions());
  EXPECT_FALSE(forced.hasDenseObservations());
  EXPECT_LT(forced.storageBytes(), auto200.storageBytes());
}

// Dense matrices, the dense constructor forced sparse and the sparse-row constructor hold the
// same model: same entries, identity flags, predictions, expectations and belief updates.
TEST(SparseModel, SparseAndDenseGiveTheSameBeliefsAndProducts) {
  for (std::uint64_t seed : {11u, 12u, 13u}) {
    const Tables tb = randomTables(seed, 150, 4, 5, 1 + seed % 4);
    const Model dense(tb.t, tb.z, tb.r, 0.95, 0.0, ModelStorage::kDense);
    const Model sparse(tb.t, tb.z, tb.r, 0.95, 0.0, ModelStorage::kSparse);
    const Model rows(rowsOf(tb.t), rowsOf(tb.z), tb.r, 0.95, 0.0, ModelStorage::kSparse);
    ASSERT_TRUE(dense.hasDenseTransitions());
    ASSERT_FALSE(rows.hasDenseTransitions());
    for (const Model* m : {&sparse, &rows}) {
      for (std::size_t a = 0; a < dense.getA(); ++a) {
        EXPECT_EQ(m->isIdentityTransition(a), dense.isIdentityTransition(a));
        EXPECT_EQ(m->possibleObservations(a), dense.possibleObservations(a));
        EXPECT_EQ(m->denseTransition(a), dense.transitionMatrix(a));
        EXPECT_EQ(m->denseObservation(a), dense.observationMatrix(a));
        for (std::size_t s = 0; s < dense.getS(); s += 7)
          for (std::size_t s1 = 0; s1 < dense.getS(); ++s1)
            ASSERT_EQ(m->getTransitionProbability(s, a, s1),
                      dense.getTransitionProbability(s, a, s1));
      }
      for (const Belief& b : randomBeliefs(dense.getS(), seed)) {
        for (std::size_t a = 0; a < dense.getA(); ++a) {
          Eigen::VectorXd pd, ps, ed, es;
          dense.predict(a, b, pd);
          m->predict(a, b, ps);
          EXPECT_LE((pd - ps).cwiseAbs().maxCoeff(), kTol);
          dense.expectNext(a, tb.r.col(static_cast<Eigen::Index>(a)), ed);
          m->expectNext(a, tb.r.col(static_cast<Eigen::Index>(a)), es);
          EXPECT_LE((ed - es).cwiseAbs().maxCoeff(), 10 * kTol);
          for (std::size_t o = 0; o < dense.getO(); ++o) {
            Belief bd, bs;
            double pdo = 0.0, pso = 0.0;
            const bool okd = tryUpdateBelief(dense, b, a, o, bd, &pdo);
            const bool oks = tryUpdateBelief(*m, b, a, o, bs, &pso);
            ASSERT_EQ(okd, oks);
            EXPECT_NEAR(pdo, pso, kTol);
            EXPECT_NEAR(observationProbability(dense, b, a, o),
                        observationProbability(*m, b, a, o), kTol);
            if (okd) EXPECT_LE((bd - bs).cwiseAbs().maxCoeff(), 1e-10);
          }
        }
      }
    }
  }
}

/// @brief max_a [R(b, a) + gamma sum_o P(o | b, a) L(b_ao)] for a solver's lower bound L.
double lowerBackupValue(const Model& m, const PointBasedSolver& solver, const Belief& b) {
  double best = -1e300;
  for (std::size_t a = 0; a < m.getA(); ++a) {
    double q = expectedReward(m, b, a);
    for (std::size_t o = 0; o < m.getO(); ++o) {
      Belief next;
      double p = 0.0;
      if (tryUpdateBelief(m, b, a, o, next, &p)) q += m.getDiscount() * p * solver.lowerBound(next);
    }
    best = std::max(best, q);
  }
  return best;
}

// The solver on the two storages: same bounds at b0 and elsewhere, same backups, after a fixed
// number of trials (deterministic; sums differ only in rounding).
TEST(SparseModel, SolverBoundsAndBackupsMatchOnBothStorages) {
  for (std::uint64_t seed : {21u, 22u}) {
    const Tables tb = randomTables(seed, 120, 3, 3, 2);
    const Model dense(tb.t, tb.z, tb.r, 0.95, 0.0, ModelStorage::kDense);
    const Model sparse(rowsOf(tb.t), rowsOf(tb.z), tb.r, 0.95, 0.0, ModelStorage::kSparse);
    SolverOptions opt;
    opt.maxTrials = 25;
    opt.timeout = 60.0;
    PointBasedSolver sd(dense, dense.initialBelief(), opt), ss(sparse, sparse.initialBelief(), opt);
    EXPECT_NEAR(sd.report().lower, ss.report().lower, 1e-9);  // after set-up
    EXPECT_NEAR(sd.report().upper, ss.report().upper, 1e-9);
    sd.solve();
    ss.solve();
    const double scale = 1.0 + std::abs(sd.report().lower);
    EXPECT_NEAR(sd.report().lower, ss.report().lower, 1e-7 * scale);
    EXPECT_NEAR(sd.report().upper, ss.report().upper, 1e-7 * scale);
    EXPECT_EQ(sd.report().trials, ss.report().trials);
    for (const Belief& b : randomBeliefs(dense.getS(), seed)) {
      EXPECT_NEAR(sd.lowerBound(b), ss.lowerBound(b), 1e-7 * scale);
      EXPECT_NEAR(sd.upperBound(b), ss.upperBound(b), 1e-7 * scale);
      EXPECT_NEAR(lowerBackupValue(dense, sd, b), lowerBackupValue(sparse, ss, b), 1e-7 * scale);
      // And the invariant that makes the lower bound the value of the written policy.
      EXPECT_LE(ss.lowerBound(b), lowerBackupValue(sparse, ss, b) + 1e-7 * scale);
    }
  }
}

TEST(SparseModel, SparseRowsAreValidated) {
  const Tables tb = randomTables(31, 10, 2, 2, 2);
  auto t = rowsOf(tb.t);
  auto* largest = &t[1].entries[t[1].start[3]];  // row 3 of action 1 no longer sums to 1
  for (std::size_t k = t[1].start[3]; k < t[1].start[4]; ++k)
    if (t[1].entries[k].second > largest->second) largest = &t[1].entries[k];
  largest->second -= 0.01;
  try {
    Model(t, rowsOf(tb.z), tb.r, 0.95);
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("action 1, state 3 sums to"), std::string::npos)
        << e.what();
  }
  auto z = rowsOf(tb.z);
  z[0].cols = 1;  // observation indices out of range
  EXPECT_THROW(Model(rowsOf(tb.t), z, tb.r, 0.95), ConfigError);
}

/// @brief A .pomdp grid walk of n x n cells plus a sink (RockSample-like sparsity): moves are
/// noisy (0.8 / 0.2 stay), 'scan' observes the column parity with probability 0.9.
std::string gridText(std::size_t n) {
  std::ostringstream ss;
  const std::size_t S = n * n + 1;
  ss << "discount: 0.95\nvalues: reward\nstates: " << S << "\n"
     << "actions: north south east west scan\nobservations: even odd\nstart: uniform\n"
     << "T: scan identity\n";
  const char* moves[] = {"north", "south", "east", "west"};
  for (std::size_t s = 0; s + 1 < S; ++s) {
    const std::size_t x = s % n, y = s / n;
    const std::size_t to[] = {y + 1 < n ? s + n : s, y > 0 ? s - n : s,
                              x + 1 < n ? s + 1 : S - 1, x > 0 ? s - 1 : s};
    for (int a = 0; a < 4; ++a) {
      if (to[a] == s) {
        ss << "T: " << moves[a] << " : " << s << " : " << s << " 1\n";
      } else {
        ss << "T: " << moves[a] << " : " << s << " : " << to[a] << " 0.8\n";
        ss << "T: " << moves[a] << " : " << s << " : " << s << " 0.2\n";
      }
    }
  }
  ss << "T: * : " << S - 1 << " : " << S - 1 << " 1\n";
  ss << "O: * : * : even 1\n";
  for (std::size_t s = 0; s + 1 < S; ++s)
    ss << "O: scan : " << s << " : " << ((s % n) % 2 ? "even 0.1\n" : "even 0.9\n")
       << "O: scan : " << s << " : " << ((s % n) % 2 ? "odd 0.9\n" : "odd 0.1\n");
  ss << "R: north : * : * : * -0.1\nR: south : * : * : * -0.1\n";
  for (std::size_t y = 0; y < n; ++y)  // leaving east: +10 with the move's 0.8
    ss << "R: east : " << y * n + n - 1 << " : * : * 8\n";
  return ss.str();
}

// 3250 states: the dense tables would need 2 x 5 x 3250^2 doubles (845 MB) with their
// transposes; the sparse model takes a few MB, so it loads in a 48 MiB budget (tokens of the
// 1.3 MB file included) and the solver runs on it.
TEST(SparseModel, ThousandsOfStatesLoadWithinASmallMemoryBudget) {
  const std::string text = gridText(57);  // 57^2 + 1 = 3250 states
  CassandraLimits limits;
  limits.memory_budget = std::size_t(48) << 20;
  const Model m = readCassandra(text, "grid.pomdp", limits);
  ASSERT_EQ(m.getS(), 3250u);
  EXPECT_FALSE(m.hasDenseTransitions());
  EXPECT_LT(m.storageBytes(), std::size_t(4) << 20) << m.storageBytes();
  EXPECT_GT(estimateModelBytes(3250, 5, 2), 0u);
  EXPECT_LT(estimateModelBytes(3250, 5, 2), limits.memory_budget / 4);
  EXPECT_TRUE(m.isIdentityTransition(4));
  EXPECT_DOUBLE_EQ(m.getTransitionProbability(0, 0, 57), 0.8);
  EXPECT_DOUBLE_EQ(m.getObservationProbability(1, 4, 1), 0.9);
  SolverOptions opt;
  opt.timeout = 2.0;
  PointBasedSolver solver(m, m.initialBelief(), opt);
  solver.solve();
  const BoundsReport r = solver.report();
  EXPECT_LE(r.lower, r.upper + 1e-9);
  EXPECT_TRUE(r.trials > 0 || solver.converged()) << r.lower << " " << r.upper;
  EXPECT_LE(r.time, 2.0 * 1.1);
  // The same file in a budget too small for its entries is refused, not bad_alloc.
  limits.memory_budget = std::size_t(3) << 20;
  EXPECT_THROW(readCassandra(text, "grid.pomdp", limits), ParseError);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
