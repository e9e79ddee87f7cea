// Value iteration and policy iteration: the driver (initial values, passes, stopping,
// greedy policies) over the inner-loop kernels of solver_kernels.h (reference and AVX2).
#include "krr_core/mdp/solvers.h"

#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/format.h"
#include "solver_kernels.h"

namespace krr {
namespace mdp {

namespace {

std::string num(double v) { return formatNumber(v, 17); }

void checkWarmStart(const std::vector<double>* warm, std::size_t n) {
  if (warm != nullptr && warm->size() != n) {
    throw ConfigError("valueIteration: warm start has " + std::to_string(warm->size()) +
                      " values, the model has " + std::to_string(n) + " states");
  }
}

using kernels::Isa;
using kernels::kGA;
using kernels::kGBlock;
using kernels::kGK;
using kernels::kGL;

/// @brief Record a pass of d pipelined sweeps (residuals res[0..d)) as sweeps it+1..it+d; the
/// first sweep below the threshold ends the solve (the pass's later sweeps only got closer, and
/// the solution reports the last one's residual). True when the solve converged.
bool recordPass(const double* res, std::size_t d, double threshold, std::size_t& it,
                Solution& sol) {
  for (std::size_t j = 0; j < d; ++j) {
    ++it;
    sol.residual = res[j];
    if (res[j] < threshold) {
      sol.converged = true;
      sol.residual = res[d - 1];
      it += d - 1 - j;
      break;
    }
  }
  sol.iterations = it;
  return sol.converged;
}

template <class P>
double updateGridRow(Isa isa, const BasicGridModel<P>& m, std::uint32_t y, double* vp,
                     std::size_t wp, double g) {
  const std::size_t nb = m.paddedWidth() / kGL;
  const double* up = vp + static_cast<std::size_t>(y) * wp;
  double* cur = vp + static_cast<std::size_t>(y + 1) * wp;
  const double* dn = vp + static_cast<std::size_t>(y + 2) * wp;
#ifdef KRR_MDP_X86_DISPATCH
  if (isa == Isa::kAvx2) {
    return kernels::gridRowAvx2<P>(nb, m.probBlocks(y), m.rewardBlocks(y), m.liveRow(y), up,
                                   cur, dn, g);
  }
#endif
  (void)isa;
  return kernels::gridRowReference<P>(nb, m.probBlocks(y), m.rewardBlocks(y), m.liveRow(y), up,
                                      cur, dn, g);
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
    const P* rew = m.rewardBlocks(y);
    const P* live = m.liveRow(y);
    double* row = vp.data() + (static_cast<std::size_t>(y) + 1) * wp + 1;
    for (std::uint32_t x = 0; x < w; ++x) {
      double v = 0.0;
      if (live[x] == P(0)) {
        v = 0.0;
      } else if (warm != nullptr) {
        v = (*warm)[m.cell(x, y)];
      } else {
        const P* r = rew + (x / kGL) * kGA * kGL + x % kGL;
        double best = double(r[0]);
        for (std::size_t a = 1; a < kGA; ++a) best = std::max(best, double(r[a * kGL]));
        v = initialValue(options.initial, best, g);
      }
      row[x] = v;
    }
  }
  const double threshold = stoppingThreshold(options.epsilon, g);
  Solution sol;
  const Isa isa = kernels::bestIsa();
  // Grids whose model does not fit in the per-core cache run `depth` sweeps per pass over
  // memory, pipelined one row apart (sweep j updates row t - j at step t, in order of j). Each
  // sweep then sees exactly the rows a sequential sweep would see, so the result is identical
  // to `depth` consecutive sweeps, but every model row is read from memory once per pass
  // instead of once per sweep; the depth keeps the rows in flight within about 2 MiB (up to
  // 8 sweeps; measured best on 500x500 and 1000x1000 grids).
  // Passes alternate direction, like single sweeps. A warm start begins with a single sweep,
  // so that an already converged value function costs one sweep.
  std::size_t depth = 1;
  if (m.modelBytes() > (std::size_t(1) << 20)) {
    depth = std::min<std::size_t>(8, std::max<std::size_t>(2, (std::size_t(2048) << 10) /
                                                              std::max<std::size_t>(1, m.rowBytes())));
  }
  std::vector<double> res(depth);
  std::size_t it = 0;
  for (bool forward = true; it < options.max_iterations; forward = !forward) {
    const std::size_t want = (it == 0 && warm != nullptr) ? 1 : depth;
    const std::size_t d = std::min(want, options.max_iterations - it);
    std::fill(res.begin(), res.end(), 0.0);
    for (std::size_t t = 0; t < h + d - 1; ++t) {
      for (std::size_t j = 0; j < d; ++j) {
        if (t < j || t - j >= h) continue;
        const std::uint32_t row = static_cast<std::uint32_t>(forward ? t - j : h - 1 - (t - j));
        res[j] = std::max(res[j], updateGridRow(isa, m, row, vp.data(), wp, g));
      }
    }
    if (recordPass(res.data(), d, threshold, it, sol)) break;
  }
  sol.values.assign(m.getS(), 0.0);
  sol.policy.assign(m.getS(), 0);
  // Greedy policy from the final values, through the same outcome slots as the sweep (read
  // straight from the blocks: this pass costs about one sweep).
  for (std::uint32_t y = 0; y < h; ++y) {
    const double* up = vp.data() + static_cast<std::size_t>(y) * wp + 1;
    const double* cur = up + wp;
    const double* dn = cur + wp;
    const P* prob = m.probBlocks(y);
    const P* rew = m.rewardBlocks(y);
    const P* live = m.liveRow(y);
    for (std::uint32_t x = 0; x < w; ++x) {
      const StateId c = m.cell(x, y);
      sol.values[c] = cur[x];
      if (live[x] == P(0)) continue;
      const std::size_t xb = x / kGL, l = x % kGL;
      const double nb[kGK] = {cur[x], up[x], dn[x], cur[static_cast<std::ptrdiff_t>(x) - 1],
                              cur[x + 1]};
      double bq = -std::numeric_limits<double>::infinity();
      for (std::size_t a = 0; a < kGA; ++a) {
        const P* q = prob + xb * kGBlock + a * kGK * kGL + l;
        double acc = 0.0;
        for (std::size_t k = 0; k < kGK; ++k) acc += double(q[k * kGL]) * nb[k];
        const double v = double(rew[(xb * kGA + a) * kGL + l]) + g * acc;
        if (v > bq) {
          bq = v;
          sol.policy[c] = static_cast<ActionId>(a);
        }
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

template <int K>
void sweepPadded(const SparseModel& m, const std::vector<StateId>& nx,
                 const std::vector<double>& pr, std::vector<double>& v,
                 const SolverOptions& options, Solution& sol) {
#ifdef KRR_MDP_X86_DISPATCH
  // (As before the split: the CPU alone decides here, KRR_MDP_ISA does not.)
  if (kernels::cpuHasAvx2Fma()) {
    kernels::sweepPaddedAvx2<K>(m, nx, pr, v, options, sol);
    return;
  }
#endif
  kernels::sweepPaddedReference<K>(m, nx, pr, v, options, sol);
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

/*
 * Value iteration on the sweep layout (see BasicSweepModel). Gauss-Seidel in place; the
 * backups of one state's actions are evaluated together in SIMD lanes. A pass runs `depth`
 * sweeps pipelined in chunks of C >= bandwidth states, sweep j one chunk behind sweep j - 1,
 * interleaved state by state: a state's backup only reads states within the bandwidth, which
 * sweep j - 1 has already updated and sweep j + 1 has not yet, so the result is exactly that
 * of `depth` consecutive sweeps. The interleaving gives the CPU `depth` independent
 * dependency chains (a Gauss-Seidel sweep alone is latency-bound: each backup waits for its
 * predecessor's value), and on models larger than the caches every byte of the layout is read
 * from memory once per pass instead of once per sweep.
 */

template <class P>
void sweepPass(Isa isa, const BasicSweepModel<P>& m, double* v, std::size_t depth,
               std::size_t C, bool forward, double* res) {
#ifdef KRR_MDP_X86_DISPATCH
  if (isa == Isa::kAvx2 && kernels::sweepPassAvx2(m, v, depth, C, forward, res)) return;
#endif
  (void)isa;
  kernels::sweepPassReference(m, v, depth, C, forward, res);
}

template <class P>
Solution sweepValueIteration(const BasicSweepModel<P>& m, const SolverOptions& options,
                             const std::vector<double>* warm) {
  options.validate();
  const std::size_t ns = m.getS(), L = m.actionLanes();
  checkWarmStart(warm, ns);
  std::vector<double> v = warm != nullptr ? *warm : std::vector<double>(ns, 0.0);
  const P* rw = m.rewardRows();
  for (std::size_t s = 0; s < ns; ++s) {
    if (m.isTerminal(static_cast<StateId>(s))) {
      v[s] = 0.0;
    } else if (warm == nullptr) {
      double best = double(rw[s * L]);
      for (std::size_t a = 1; a < m.getA(); ++a) best = std::max(best, double(rw[s * L + a]));
      v[s] = initialValue(options.initial, best, m.getDiscount());
    }
  }
  const Isa isa = kernels::bestIsa();
  // Chunk and depth: pipelining needs chunks of at least the bandwidth and room for the
  // chunks in flight; below that (tiny or wide-reaching models) one sweep per pass.
  const std::size_t C = std::max<std::size_t>(m.bandwidth(), 64);
  // (8 sweeps in flight measured slower than 4: the chunks then spill out of L2.)
  const std::size_t depth = ns >= 8 * C ? 4 : 1;
  const double threshold = stoppingThreshold(options.epsilon, m.getDiscount());
  Solution sol;
  double res[4];
  std::size_t it = 0;
  for (bool forward = true; it < options.max_iterations; forward = !forward) {
    std::size_t d = (it == 0 && warm != nullptr) ? 1 : depth;
    if (d > options.max_iterations - it) d = 1;  // finish a capped solve sweep by sweep
    std::fill(res, res + 4, 0.0);
    sweepPass(isa, m, v.data(), d, C, forward, res);
    if (recordPass(res, d, threshold, it, sol)) break;
  }
  // Greedy policy (lowest action index among ties), through the same layout.
  sol.policy.assign(ns, 0);
  const std::size_t K = m.successorsPerState();
  for (std::size_t s = 0; s < ns; ++s) {
    if (m.isTerminal(static_cast<StateId>(s))) continue;
    const std::uint32_t* n = m.successorIndices() + s * K;
    const P* q = m.probabilityBlocks() + s * K * L;
    double bq = -std::numeric_limits<double>::infinity();
    for (std::size_t a = 0; a < m.getA(); ++a) {
      double acc = double(rw[s * L + a]);
      for (std::size_t k = 0; k < K; ++k) acc += double(q[k * L + a]) * v[n[k]];
      if (acc > bq) {
        bq = acc;
        sol.policy[s] = static_cast<ActionId>(a);
      }
    }
  }
  sol.values = std::move(v);
  return sol;
}

}  // namespace

Solution valueIteration(const SweepModel& m, const SolverOptions& o, const std::vector<double>* w) {
  return sweepValueIteration(m, o, w);
}

Solution valueIteration(const SweepModelF& m, const SolverOptions& o,
                        const std::vector<double>* w) {
  return sweepValueIteration(m, o, w);
}

Solution valueIteration(const SparseModel& m, const SolverOptions& options,
                        const std::vector<double>* warm) {
  options.validate();
  const std::size_t ns = m.getS(), na = m.getA();
  checkWarmStart(warm, ns);
  // Multi-sweep solves of models with few successors per state: the sweep layout. Building it
  // costs about one CSR sweep.
  if (options.max_iterations > 2) {
    if (auto sweep = SweepModel::tryBuild(m)) return sweepValueIteration(*sweep, options, warm);
  }
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
  kernels::gaussSeidelSweeps(m, v, options, sol, [nx, pr, rs](std::size_t i, const double* vv) {
    double acc = 0.0;
    for (std::uint32_t k = rs[i]; k < rs[i + 1]; ++k) acc += pr[k] * vv[nx[k]];
    return acc;
  });
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

namespace kernels {

Isa bestIsa() {
  static const Isa isa = [] {
    const char* e = std::getenv("KRR_MDP_ISA");
    if (e != nullptr && std::string(e) == "generic") return Isa::kReference;
    return cpuHasAvx2Fma() ? Isa::kAvx2 : Isa::kReference;
  }();
  return isa;
}

}  // namespace kernels

}  // namespace mdp
}  // namespace krr
