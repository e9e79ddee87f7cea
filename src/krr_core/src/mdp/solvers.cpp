#include "krr_core/mdp/solvers.h"

#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

namespace {

std::string num(double v) {
  std::ostringstream o;
  o.precision(17);
  o << v;
  return o.str();
}

void checkWarmStart(const std::vector<double>* warm, std::size_t n) {
  if (warm != nullptr && warm->size() != n) {
    throw ConfigError("valueIteration: warm start has " + std::to_string(warm->size()) +
                      " values, the model has " + std::to_string(n) + " states");
  }
}

/// Max of |a[i]| over n values with four independent accumulators (breaks the maxsd chain).
inline double maxAbs4(const double* d, std::size_t n) {
  double m0 = 0.0, m1 = 0.0, m2 = 0.0, m3 = 0.0;
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    const double a0 = std::fabs(d[i]), a1 = std::fabs(d[i + 1]);
    const double a2 = std::fabs(d[i + 2]), a3 = std::fabs(d[i + 3]);
    m0 = a0 > m0 ? a0 : m0;
    m1 = a1 > m1 ? a1 : m1;
    m2 = a2 > m2 ? a2 : m2;
    m3 = a3 > m3 ? a3 : m3;
  }
  for (; i < n; ++i) {
    const double a = std::fabs(d[i]);
    m0 = a > m0 ? a : m0;
  }
  return std::max(std::max(m0, m1), std::max(m2, m3));
}

/**
 * Backed-up values of one grid row, Jacobi-style: b[x] = max_a (r_a[x] + g * sum_k p_ak[x]
 * V(neighbour_k of x)), reading V from the padded array (zero halo, so the edges need no
 * branch). All pointers are restrict-qualified parameters and the row's probabilities share one
 * base pointer, so -O3 vectorises the loop without runtime alias checks.
 */
template <class P>
inline __attribute__((always_inline)) void backupGridRowBody(
    std::size_t wb, const P* __restrict prob, const P* __restrict rew,
    const double* __restrict up, const double* __restrict cur, const double* __restrict dn,
    double g, double* __restrict b) {
  constexpr std::size_t kL = BasicGridModel<P>::kLanes;
  constexpr std::size_t kA = BasicGridModel<P>::kNumActions;
  constexpr std::size_t kK = BasicGridModel<P>::kNumOutcomes;
  for (std::size_t xb = 0; xb < wb; ++xb) {
    const P* __restrict blk = prob + xb * kA * kK * kL;
    const P* __restrict rb = rew + xb * kA * kL;
    const std::size_t x0 = xb * kL;
    double best[kL];
#pragma GCC unroll 4
    for (std::size_t a = 0; a < kA; ++a) {
      const P* __restrict q = blk + a * kK * kL;
      for (std::size_t l = 0; l < kL; ++l) {
        const std::size_t x = x0 + l;
        const double acc = double(q[l]) * cur[x + 1] + double(q[kL + l]) * up[x + 1] +
                           double(q[2 * kL + l]) * dn[x + 1] + double(q[3 * kL + l]) * cur[x] +
                           double(q[4 * kL + l]) * cur[x + 2];
        const double v = double(rb[a * kL + l]) + g * acc;
        best[l] = (a == 0 || v > best[l]) ? v : best[l];
      }
    }
    for (std::size_t l = 0; l < kL; ++l) b[x0 + l] = best[l];
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
#define KRR_MDP_X86_DISPATCH 1
/// The same kernel compiled for AVX2 + FMA (4 doubles per instruction, fused multiply-add);
/// chosen at run time when the CPU has them, so the default -O3 build needs no -march flag.
template <class P>
__attribute__((target("avx2,fma"))) void backupGridRowAvx2(
    std::size_t w, const P* __restrict prob, const P* __restrict rew,
    const double* __restrict up, const double* __restrict cur, const double* __restrict dn,
    double g, double* __restrict b) {
  backupGridRowBody<P>(w, prob, rew, up, cur, dn, g, b);
}

bool cpuHasAvx2Fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif

template <class P>
void backupGridRow(std::size_t w, const P* __restrict prob, const P* __restrict rew,
                   const double* __restrict up, const double* __restrict cur,
                   const double* __restrict dn, double g, double* __restrict b) {
#ifdef KRR_MDP_X86_DISPATCH
  if (cpuHasAvx2Fma()) {
    backupGridRowAvx2<P>(w, prob, rew, up, cur, dn, g, b);
    return;
  }
#endif
  backupGridRowBody<P>(w, prob, rew, up, cur, dn, g, b);
}

/// Writes live[x] * b[x] into the row of V (cur points at the first real cell) and returns the
/// largest change.
template <class P>
double storeGridRow(std::size_t w, const double* __restrict b, const P* __restrict live,
                    double* __restrict cur, double* __restrict diff) {
  for (std::size_t x = 0; x < w; ++x) {
    const double v = b[x] * double(live[x]);
    diff[x] = v - cur[x];
    cur[x] = v;
  }
  return maxAbs4(diff, w);
}

template <class P>
double updateGridRow(const BasicGridModel<P>& m, std::uint32_t y, double* vp, std::size_t wp,
                     double g, double* best, double* diff) {
  const std::size_t w = m.paddedWidth();
  // Row pointers start at the left halo cell: index x + 1 is cell x.
  const double* up = vp + static_cast<std::size_t>(y) * wp;
  double* cur = vp + static_cast<std::size_t>(y + 1) * wp;
  const double* dn = vp + static_cast<std::size_t>(y + 2) * wp;
  backupGridRow<P>(w / BasicGridModel<P>::kLanes, m.probBlocks(y), m.rewardBlocks(y), up, cur,
                   dn, g, best);
  return storeGridRow<P>(w, best, m.liveRow(y), cur + 1, diff);
}

template <class P>
Solution gridValueIteration(const BasicGridModel<P>& m, const SolverOptions& options,
                            const std::vector<double>* warm) {
  options.validate();
  checkWarmStart(warm, m.getS());
  const std::uint32_t w = m.width(), h = m.height();
  const std::size_t wpad = m.paddedWidth();
  const std::size_t wp = wpad + 2;
  const double g = m.getDiscount();
  std::vector<double> vp((static_cast<std::size_t>(h) + 2) * wp, 0.0);
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      const StateId c = m.cell(x, y);
      double v = 0.0;
      if (m.isTerminal(c)) {
        v = 0.0;
      } else if (warm != nullptr) {
        v = (*warm)[c];
      } else {
        double best = m.getExpectedReward(c, 0);
        for (ActionId a = 1; a < BasicGridModel<P>::kNumActions; ++a) {
          best = std::max(best, m.getExpectedReward(c, a));
        }
        v = initialValue(options.initial, best, g);
      }
      vp[(y + 1) * wp + x + 1] = v;
    }
  }
  std::vector<double> diff(wpad);
  const double threshold = stoppingThreshold(options.epsilon, g);
  Solution sol;
  // Grids whose model does not fit in the per-core cache run `depth` sweeps per pass over
  // memory, pipelined one row apart (sweep j updates row t - j at step t, in order of j). Each
  // sweep then sees exactly the rows a sequential sweep would see, so the result is identical
  // to `depth` consecutive sweeps, but every model row is read from memory once per pass
  // instead of once per sweep. Passes alternate direction, like single sweeps.
  const std::size_t depth = m.modelBytes() > (std::size_t(2) << 20) ? 4 : 1;
  std::vector<double> bests(depth * wpad), res(depth);
  std::size_t it = 0;
  for (bool forward = true; it < options.max_iterations; forward = !forward) {
    const std::size_t d = std::min(depth, options.max_iterations - it);
    std::fill(res.begin(), res.end(), 0.0);
    for (std::size_t t = 0; t < h + d - 1; ++t) {
      for (std::size_t j = 0; j < d; ++j) {
        if (t < j || t - j >= h) continue;
        const std::uint32_t row = static_cast<std::uint32_t>(forward ? t - j : h - 1 - (t - j));
        res[j] = std::max(res[j], updateGridRow(m, row, vp.data(), wp, g,
                                                bests.data() + j * wpad, diff.data()));
      }
    }
    bool done = false;
    for (std::size_t j = 0; j < d; ++j) {
      ++it;
      sol.residual = res[j];
      if (res[j] < threshold) {  // later sweeps of the pass only got closer
        sol.converged = done = true;
        sol.residual = res[d - 1];
        it += d - 1 - j;
        break;
      }
    }
    sol.iterations = it;
    if (done) break;
  }
  sol.values.assign(m.getS(), 0.0);
  sol.policy.assign(m.getS(), 0);
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      const StateId c = m.cell(x, y);
      sol.values[c] = vp[(y + 1) * wp + x + 1];
    }
  }
  // Greedy policy from the final values, through the same outcome slots as the sweep.
  for (StateId c = 0; c < m.numCells(); ++c) {
    if (m.isTerminal(c)) continue;
    double bq = -std::numeric_limits<double>::infinity();
    for (ActionId a = 0; a < BasicGridModel<P>::kNumActions; ++a) {
      double acc = 0.0;
      for (unsigned k = 0; k < kFail; ++k) {
        acc += m.outcomeProbability(c, a, k) * sol.values[m.outcomeState(c, k)];
      }
      const double q = m.getExpectedReward(c, a) + g * acc;
      if (q > bq) {
        bq = q;
        sol.policy[c] = a;
      }
    }
  }
  return sol;
}

}  // namespace

void SolverOptions::validate() const {
  if (!(epsilon > 0.0) || !std::isfinite(epsilon)) {
    throw ConfigError("SolverOptions.epsilon must be > 0, got " + num(epsilon));
  }
  if (max_iterations == 0) throw ConfigError("SolverOptions.max_iterations must be > 0, got 0");
}

double stoppingThreshold(double epsilon, double discount) {
  if (discount >= 1.0) return epsilon;
  if (discount <= 0.0) return std::numeric_limits<double>::infinity();
  return epsilon * (1.0 - discount) / (2.0 * discount);
}

double qValue(const SparseModel& m, const std::vector<double>& v, StateId s, ActionId a) {
  double acc = 0.0;
  for (Outcome o : m.successors(s, a)) acc += o.probability * v[o.state];
  return m.getExpectedReward(s, a) + m.getDiscount() * acc;
}

std::vector<ActionId> greedyPolicy(const SparseModel& m, const std::vector<double>& v) {
  std::vector<ActionId> pi(m.getS(), 0);
  for (StateId s = 0; s < m.getS(); ++s) {
    if (m.isTerminal(s)) continue;
    double best = -std::numeric_limits<double>::infinity();
    for (ActionId a = 0; a < m.getA(); ++a) {
      const double q = qValue(m, v, s, a);
      if (q > best) {
        best = q;
        pi[s] = a;
      }
    }
  }
  return pi;
}

double bellmanResidual(const SparseModel& m, const std::vector<double>& v) {
  double res = 0.0;
  for (StateId s = 0; s < m.getS(); ++s) {
    if (m.isTerminal(s)) continue;
    double best = -std::numeric_limits<double>::infinity();
    for (ActionId a = 0; a < m.getA(); ++a) best = std::max(best, qValue(m, v, s, a));
    res = std::max(res, std::fabs(best - v[s]));
  }
  return res;
}

namespace {

/**
 * Gauss-Seidel sweeps over rows padded to exactly K entries (zero-probability padding pointing
 * at the state itself). A compile-time trip count removes the branch mispredictions that
 * variable-length CSR rows cost on every (s, a).
 */
template <int K>
inline __attribute__((always_inline)) void sweepPaddedBody(
    const SparseModel& m, const std::vector<StateId>& nx, const std::vector<double>& pr,
    std::vector<double>& v, const SolverOptions& options, Solution& sol) {
  const std::size_t ns = m.getS(), na = m.getA();
  const std::vector<std::uint8_t>& term = m.terminalFlags();
  const double* rw = m.rewards();
  const double g = m.getDiscount();
  const double threshold = stoppingThreshold(options.epsilon, g);
  double* vv = v.data();
  for (std::size_t it = 1; it <= options.max_iterations; ++it) {
    double res = 0.0;
    const bool forward = it % 2 == 1;
    for (std::size_t idx = 0; idx < ns; ++idx) {
      const std::size_t s = forward ? idx : ns - 1 - idx;
      if (term[s]) continue;
      double best = -std::numeric_limits<double>::infinity();
      const std::size_t i0 = s * na;
      for (std::size_t i = i0; i < i0 + na; ++i) {
        const StateId* n = nx.data() + i * K;
        const double* p = pr.data() + i * K;
        // Two accumulators halve the floating-point add chain of a row.
        double acc0 = 0.0, acc1 = 0.0;
#pragma GCC unroll 8
        for (int k = 0; k < K; k += 2) {
          acc0 += p[k] * vv[n[k]];
          acc1 += p[k + 1] * vv[n[k + 1]];
        }
        const double q = rw[i] + g * (acc0 + acc1);
        best = q > best ? q : best;
      }
      const double d = std::fabs(best - vv[s]);
      res = d > res ? d : res;
      vv[s] = best;
    }
    sol.iterations = it;
    sol.residual = res;
    if (res < threshold) {
      sol.converged = true;
      break;
    }
  }
}

#ifdef KRR_MDP_X86_DISPATCH
template <int K>
__attribute__((target("avx2,fma"))) void sweepPaddedAvx2(
    const SparseModel& m, const std::vector<StateId>& nx, const std::vector<double>& pr,
    std::vector<double>& v, const SolverOptions& options, Solution& sol) {
  sweepPaddedBody<K>(m, nx, pr, v, options, sol);
}
#endif

template <int K>
void sweepPadded(const SparseModel& m, const std::vector<StateId>& nx,
                 const std::vector<double>& pr, std::vector<double>& v,
                 const SolverOptions& options, Solution& sol) {
#ifdef KRR_MDP_X86_DISPATCH
  if (cpuHasAvx2Fma()) {
    sweepPaddedAvx2<K>(m, nx, pr, v, options, sol);
    return;
  }
#endif
  sweepPaddedBody<K>(m, nx, pr, v, options, sol);
}

template <int K>
void solvePadded(const SparseModel& m, std::vector<double>& v, const SolverOptions& options,
                 Solution& sol) {
  const std::size_t pairs = m.getS() * m.getA();
  std::vector<StateId> nx(pairs * K);
  std::vector<double> pr(pairs * K, 0.0);
  const std::uint32_t* rs = m.rowStart();
  for (std::size_t i = 0; i < pairs; ++i) {
    const StateId self = static_cast<StateId>(i / m.getA());
    std::size_t k = 0;
    for (std::uint32_t j = rs[i]; j < rs[i + 1]; ++j, ++k) {
      nx[i * K + k] = m.nextStates()[j];
      pr[i * K + k] = m.probabilities()[j];
    }
    for (; k < static_cast<std::size_t>(K); ++k) nx[i * K + k] = self;
  }
  sweepPadded<K>(m, nx, pr, v, options, sol);
}

}  // namespace

Solution valueIteration(const SparseModel& m, const SolverOptions& options,
                        const std::vector<double>* warm) {
  options.validate();
  const std::size_t ns = m.getS(), na = m.getA();
  checkWarmStart(warm, ns);
  std::vector<double> v = warm != nullptr ? *warm : std::vector<double>(ns, 0.0);
  const std::vector<std::uint8_t>& term = m.terminalFlags();
  for (std::size_t s = 0; s < ns; ++s) {
    if (term[s]) {
      v[s] = 0.0;
    } else if (warm == nullptr) {
      double best = m.rewards()[s * na];
      for (std::size_t a = 1; a < na; ++a) best = std::max(best, m.rewards()[s * na + a]);
      v[s] = initialValue(options.initial, best, m.getDiscount());
    }
  }
  const std::uint32_t* rs = m.rowStart();
  std::uint32_t longest = 0;
  for (std::size_t i = 0; i < ns * na; ++i) longest = std::max(longest, rs[i + 1] - rs[i]);
  Solution sol;
  // Short rows (robot actions have a handful of outcomes): padded fixed-length rows. The
  // padding costs one O(nnz) copy, i.e. about one sweep, so only for multi-sweep solves.
  if (options.max_iterations > 2 && longest <= 8) {
    if (longest <= 2) {
      solvePadded<2>(m, v, options, sol);
    } else if (longest <= 4) {
      solvePadded<4>(m, v, options, sol);
    } else if (longest <= 6) {
      solvePadded<6>(m, v, options, sol);
    } else {
      solvePadded<8>(m, v, options, sol);
    }
    sol.policy = greedyPolicy(m, v);
    sol.values = std::move(v);
    return sol;
  }
  const StateId* nx = m.nextStates();
  const double* pr = m.probabilities();
  const double* rw = m.rewards();
  const double g = m.getDiscount();
  const double threshold = stoppingThreshold(options.epsilon, g);
  double* vv = v.data();
  for (std::size_t it = 1; it <= options.max_iterations; ++it) {
    double res = 0.0;
    const bool forward = it % 2 == 1;
    for (std::size_t idx = 0; idx < ns; ++idx) {
      const std::size_t s = forward ? idx : ns - 1 - idx;
      if (term[s]) continue;
      double best = -std::numeric_limits<double>::infinity();
      const std::size_t i0 = s * na;
      for (std::size_t i = i0; i < i0 + na; ++i) {
        double acc = 0.0;
        for (std::uint32_t k = rs[i]; k < rs[i + 1]; ++k) acc += pr[k] * vv[nx[k]];
        const double q = rw[i] + g * acc;
        best = q > best ? q : best;
      }
      const double d = std::fabs(best - vv[s]);
      res = d > res ? d : res;
      vv[s] = best;
    }
    sol.iterations = it;
    sol.residual = res;
    if (res < threshold) {
      sol.converged = true;
      break;
    }
  }
  sol.policy = greedyPolicy(m, v);
  sol.values = std::move(v);
  return sol;
}

Solution valueIteration(const GridModel& m, const SolverOptions& o, const std::vector<double>* w) {
  return gridValueIteration(m, o, w);
}

Solution valueIteration(const GridModelF& m, const SolverOptions& o,
                        const std::vector<double>* w) {
  return gridValueIteration(m, o, w);
}

std::vector<double> evaluatePolicy(const SparseModel& m, const std::vector<ActionId>& policy) {
  const std::size_t ns = m.getS();
  if (policy.size() != ns) {
    throw ConfigError("evaluatePolicy: policy has " + std::to_string(policy.size()) +
                      " entries, the model has " + std::to_string(ns) + " states");
  }
  const double g = m.getDiscount();
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(m.numTransitions() / std::max<std::size_t>(1, m.getA()) + 2 * ns);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(ns));
  for (StateId s = 0; s < ns; ++s) {
    trip.emplace_back(s, s, 1.0);
    if (m.isTerminal(s)) continue;
    const ActionId a = policy[s];
    if (a >= m.getA()) {
      throw ConfigError("evaluatePolicy: action " + std::to_string(a) + " of state " +
                        std::to_string(s) + " out of range [0, " + std::to_string(m.getA()) +
                        ")");
    }
    for (Outcome o : m.successors(s, a)) trip.emplace_back(s, o.state, -g * o.probability);
    rhs[s] = m.getExpectedReward(s, a);
  }
  Eigen::SparseMatrix<double> mat(static_cast<Eigen::Index>(ns), static_cast<Eigen::Index>(ns));
  mat.setFromTriplets(trip.begin(), trip.end());
  mat.makeCompressed();
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  lu.analyzePattern(mat);
  lu.factorize(mat);
  if (lu.info() != Eigen::Success) {
    throw ConfigError("evaluatePolicy: (I - gamma P_pi) is singular (discount " + num(g) +
                      "; does the policy ever reach a terminal state?)");
  }
  Eigen::VectorXd x = lu.solve(rhs);
  if (lu.info() != Eigen::Success) {
    throw ConfigError("evaluatePolicy: sparse LU solve failed");
  }
  std::vector<double> v(ns);
  for (std::size_t s = 0; s < ns; ++s) v[s] = m.isTerminal(static_cast<StateId>(s)) ? 0.0 : x[s];
  return v;
}

Solution policyIteration(const SparseModel& m, const SolverOptions& options,
                         const std::vector<ActionId>* initial) {
  options.validate();
  const std::size_t ns = m.getS();
  std::vector<ActionId> pi(ns, 0);
  if (initial != nullptr) {
    if (initial->size() != ns) {
      throw ConfigError("policyIteration: initial policy has " +
                        std::to_string(initial->size()) + " entries, the model has " +
                        std::to_string(ns) + " states");
    }
    pi = *initial;
  }
  Solution sol;
  for (std::size_t it = 1; it <= options.max_iterations; ++it) {
    sol.values = evaluatePolicy(m, pi);
    sol.iterations = it;
    bool changed = false;
    for (StateId s = 0; s < ns; ++s) {
      if (m.isTerminal(s)) continue;
      double best = qValue(m, sol.values, s, pi[s]);
      for (ActionId a = 0; a < m.getA(); ++a) {
        const double q = qValue(m, sol.values, s, a);
        if (q > best + 1e-10) {
          best = q;
          pi[s] = a;
          changed = true;
        }
      }
    }
    if (!changed) {
      sol.converged = true;
      break;
    }
  }
  sol.policy = std::move(pi);
  sol.residual = bellmanResidual(m, sol.values);
  return sol;
}

}  // namespace mdp
}  // namespace krr
