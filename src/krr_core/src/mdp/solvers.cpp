#include "krr_core/common/format.h"
#include "krr_core/mdp/solvers.h"

#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <string>

#include "krr_core/common/errors.h"

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

#if defined(__x86_64__) && defined(__GNUC__)
#define KRR_MDP_X86_DISPATCH 1
bool cpuHasAvx2Fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#define KRR_AVX2 __attribute__((target("avx2,fma"), always_inline)) inline
KRR_AVX2 __m256d load4(const double* p) { return _mm256_loadu_pd(p); }
KRR_AVX2 __m256d load4(const float* p) { return _mm256_cvtps_pd(_mm_loadu_ps(p)); }
KRR_AVX2 double hmax4(__m256d v) {
  __m128d h = _mm_max_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_max_sd(h, _mm_unpackhi_pd(h, h)));
}
#endif

/*
 * One grid row, Jacobi-style: for every cell x of row y, b[x] = live[x] * max_a (r_a[x] +
 * g * sum_k p_ak[x] V(neighbour_k of x)), reading V from the padded array (zero halo, so the
 * edges need no branch), then V(row y) = b; returns max_x |b[x] - V_old(x)|. The store of a
 * block is delayed until the next block has loaded its (old) left neighbour, so the row is
 * updated in place in one pass. `cur` points at the left halo cell (index x + 1 is cell x);
 * all kernels use the same operation order (with fused multiply-adds where the CPU has them).
 */
constexpr std::size_t kGL = BasicGridModel<double>::kLanes;
constexpr std::size_t kGA = BasicGridModel<double>::kNumActions;
constexpr std::size_t kGK = BasicGridModel<double>::kSweepOutcomes;
constexpr std::size_t kGBlock = BasicGridModel<double>::kBlockSize;
static_assert(kGL == 8 && kGK == 5, "grid kernels assume 8 lanes and 5 sweep outcomes");

template <class P>
double gridRowGeneric(std::size_t nb, const P* __restrict prob, const P* __restrict rew,
                      const P* __restrict live, const double* __restrict up,
                      double* __restrict cur, const double* __restrict dn, double g) {
  double pend[kGL] = {0.0}, res = 0.0;
  for (std::size_t xb = 0; xb < nb; ++xb) {
    const std::size_t x0 = xb * kGL;
    double vl[kGL], vc[kGL], vr[kGL], vu[kGL], vd[kGL], best[kGL];
    for (std::size_t l = 0; l < kGL; ++l) {
      vl[l] = cur[x0 + l];
      vc[l] = cur[x0 + l + 1];
      vr[l] = cur[x0 + l + 2];
      vu[l] = up[x0 + l + 1];
      vd[l] = dn[x0 + l + 1];
    }
    if (xb > 0) std::copy(pend, pend + kGL, cur + x0 + 1 - kGL);
    for (std::size_t a = 0; a < kGA; ++a) {
      const P* q = prob + xb * kGBlock + a * kGK * kGL;
      const P* r = rew + (xb * kGA + a) * kGL;
      for (std::size_t l = 0; l < kGL; ++l) {
        const double acc0 = double(q[l]) * vc[l] + double(q[2 * kGL + l]) * vd[l] +
                            double(q[4 * kGL + l]) * vr[l];
        const double acc1 = double(q[kGL + l]) * vu[l] + double(q[3 * kGL + l]) * vl[l];
        const double v = (acc0 + acc1) * g + double(r[l]);
        best[l] = (a == 0 || v > best[l]) ? v : best[l];
      }
    }
    for (std::size_t l = 0; l < kGL; ++l) {
      pend[l] = best[l] * double(live[x0 + l]);
      res = std::max(res, std::fabs(pend[l] - vc[l]));
    }
  }
  if (nb > 0) std::copy(pend, pend + kGL, cur + (nb - 1) * kGL + 1);
  return res;
}

#ifdef KRR_MDP_X86_DISPATCH
template <class P>
__attribute__((target("avx2,fma"))) double gridRowAvx2(
    std::size_t nb, const P* __restrict prob, const P* __restrict rew, const P* __restrict live,
    const double* __restrict up, double* __restrict cur, const double* __restrict dn,
    double g) {
  const __m256d gv = _mm256_set1_pd(g);
  const __m256d absmask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffLL));
  __m256d res = _mm256_setzero_pd(), pend0 = res, pend1 = res;
  for (std::size_t xb = 0; xb < nb; ++xb) {
    const std::size_t x0 = xb * kGL;
    __m256d out[2];
#pragma GCC unroll 2
    for (std::size_t h = 0; h < 2; ++h) {
      const std::size_t xh = x0 + 4 * h;
      const __m256d vl = _mm256_loadu_pd(cur + xh), vc = _mm256_loadu_pd(cur + xh + 1);
      const __m256d vr = _mm256_loadu_pd(cur + xh + 2), vu = _mm256_loadu_pd(up + xh + 1);
      const __m256d vd = _mm256_loadu_pd(dn + xh + 1);
      if (h == 0 && xb > 0) {
        _mm256_storeu_pd(cur + x0 + 1 - kGL, pend0);
        _mm256_storeu_pd(cur + x0 + 5 - kGL, pend1);
      }
      __m256d best = _mm256_setzero_pd();
#pragma GCC unroll 4
      for (std::size_t a = 0; a < kGA; ++a) {
        const P* q = prob + xb * kGBlock + a * kGK * kGL + 4 * h;
        __m256d acc0 = _mm256_mul_pd(load4(q), vc);
        __m256d acc1 = _mm256_mul_pd(load4(q + kGL), vu);
        acc0 = _mm256_fmadd_pd(load4(q + 2 * kGL), vd, acc0);
        acc1 = _mm256_fmadd_pd(load4(q + 3 * kGL), vl, acc1);
        acc0 = _mm256_fmadd_pd(load4(q + 4 * kGL), vr, acc0);
        const __m256d v = _mm256_fmadd_pd(_mm256_add_pd(acc0, acc1), gv,
                                          load4(rew + (xb * kGA + a) * kGL + 4 * h));
        best = a == 0 ? v : _mm256_max_pd(v, best);
      }
      out[h] = _mm256_mul_pd(best, load4(live + xh));
      res = _mm256_max_pd(res, _mm256_and_pd(_mm256_sub_pd(out[h], vc), absmask));
    }
    pend0 = out[0];
    pend1 = out[1];
  }
  if (nb > 0) {
    _mm256_storeu_pd(cur + (nb - 1) * kGL + 1, pend0);
    _mm256_storeu_pd(cur + (nb - 1) * kGL + 5, pend1);
  }
  return hmax4(res);
}

#endif

/// Which kernels to run (chosen once per solve). AVX-512 was measured slower than AVX2 on the
/// target CPU (Zen 4 splits 512-bit operations), so AVX2 + FMA is the widest.
enum class Isa { kGeneric, kAvx2 };

/// AVX2 + FMA when the CPU has them, unless the environment variable KRR_MDP_ISA=generic
/// selects the portable kernels (to test them and compare in benchmarks).
Isa bestIsa() {
  static const Isa isa = [] {
    const char* e = std::getenv("KRR_MDP_ISA");
    if (e != nullptr && std::string(e) == "generic") return Isa::kGeneric;
#ifdef KRR_MDP_X86_DISPATCH
    if (cpuHasAvx2Fma()) return Isa::kAvx2;
#endif
    return Isa::kGeneric;
  }();
  return isa;
}

template <class P>
double updateGridRow(Isa isa, const BasicGridModel<P>& m, std::uint32_t y, double* vp,
                     std::size_t wp, double g) {
  const std::size_t nb = m.paddedWidth() / kGL;
  const double* up = vp + static_cast<std::size_t>(y) * wp;
  double* cur = vp + static_cast<std::size_t>(y + 1) * wp;
  const double* dn = vp + static_cast<std::size_t>(y + 2) * wp;
#ifdef KRR_MDP_X86_DISPATCH
  if (isa == Isa::kAvx2)
    return gridRowAvx2<P>(nb, m.probBlocks(y), m.rewardBlocks(y), m.liveRow(y), up, cur, dn, g);
#endif
  (void)isa;
  return gridRowGeneric<P>(nb, m.probBlocks(y), m.rewardBlocks(y), m.liveRow(y), up, cur, dn, g);
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
  const Isa isa = bestIsa();
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

namespace {

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

/// Backup of state s: max over actions of R(s, a) + sum_k P[s][k][a] V(N(s)_k), portable.
template <class P>
double sweepBackupGeneric(const BasicSweepModel<P>& m, const double* v, std::size_t s) {
  const std::size_t K = m.successorsPerState(), L = m.actionLanes();
  const std::uint32_t* n = m.successorIndices() + s * K;
  const P* q = m.probabilityBlocks() + s * K * L;
  const P* r = m.rewardRows() + s * L;
  double acc[BasicSweepModel<P>::kMaxActions] = {0.0};
  for (std::size_t a = 0; a < L; ++a) acc[a] = double(r[a]);
  for (std::size_t k = 0; k < K; ++k) {
    const double vk = v[n[k]];
    for (std::size_t a = 0; a < L; ++a) acc[a] += double(q[k * L + a]) * vk;
  }
  double best = acc[0];
  for (std::size_t a = 1; a < L; ++a) best = acc[a] > best ? acc[a] : best;
  return best;
}

template <class P>
void sweepPassGeneric(const BasicSweepModel<P>& m, double* v, std::size_t depth, std::size_t C,
                      bool forward, double* res) {
  const std::size_t ns = m.getS();
  const std::size_t nch = (ns + C - 1) / C;
  for (std::size_t t = 0; t + 1 < nch + depth; ++t) {
    for (std::size_t i = 0; i < C; ++i) {
      for (std::size_t j = 0; j < depth; ++j) {
        if (t < j || t - j >= nch) continue;
        const std::size_t p = (t - j) * C + i;
        if (p >= ns) continue;
        const std::size_t s = forward ? p : ns - 1 - p;
        const double b = sweepBackupGeneric(m, v, s);
        res[j] = std::max(res[j], std::fabs(b - v[s]));
        v[s] = b;
      }
    }
  }
}

#ifdef KRR_MDP_X86_DISPATCH
KRR_AVX2 __m256d bcast(const double* p) { return _mm256_broadcast_sd(p); }

template <int K, int L, class P>
KRR_AVX2 double sweepBackupAvx2(const std::uint32_t* __restrict sc, const P* __restrict pr,
                                const P* __restrict rw, const double* __restrict v,
                                std::size_t s) {
  const std::uint32_t* n = sc + s * K;
  const P* q = pr + s * K * L;
  const P* r = rw + s * L;
  // Two accumulators per 4 lanes halve the dependency chain of the sum.
  __m256d a0 = load4(r), a1 = _mm256_mul_pd(load4(q), bcast(v + n[0]));
  __m256d b0 = L == 8 ? load4(r + 4) : a0, b1 = L == 8 ? _mm256_mul_pd(load4(q + 4), bcast(v + n[0])) : a1;
#pragma GCC unroll 8
  for (int k = 1; k < K; ++k) {
    const __m256d vk = bcast(v + n[k]);
    if (k % 2 == 1) {
      a0 = _mm256_fmadd_pd(load4(q + k * L), vk, a0);
      if (L == 8) b0 = _mm256_fmadd_pd(load4(q + k * L + 4), vk, b0);
    } else {
      a1 = _mm256_fmadd_pd(load4(q + k * L), vk, a1);
      if (L == 8) b1 = _mm256_fmadd_pd(load4(q + k * L + 4), vk, b1);
    }
  }
  __m256d acc = _mm256_add_pd(a0, a1);
  if (L == 8) acc = _mm256_max_pd(acc, _mm256_add_pd(b0, b1));
  return hmax4(acc);
}

/// Backs up state s in place and returns max(res, |change|).
template <int K, int L, class P>
KRR_AVX2 double sweepUpdateAvx2(const std::uint32_t* __restrict sc, const P* __restrict pr,
                                const P* __restrict rw, double* __restrict v, std::size_t s,
                                double res) {
  const double b = sweepBackupAvx2<K, L, P>(sc, pr, rw, v, s);
  const double d = std::fabs(b - v[s]);
  v[s] = b;
  return d > res ? d : res;
}

template <int K, int L, int D, class P>
__attribute__((target("avx2,fma"))) void sweepPassAvx2(const BasicSweepModel<P>& m, double* v,
                                                       std::size_t C, bool forward,
                                                       double* res) {
  const std::uint32_t* __restrict sc = m.successorIndices();
  const P* __restrict pr = m.probabilityBlocks();
  const P* __restrict rw = m.rewardRows();
  const std::size_t ns = m.getS();
  const std::size_t nch = (ns + C - 1) / C;
  double r[D];
  for (int j = 0; j < D; ++j) r[j] = res[j];
  constexpr std::size_t kAhead = 16;  // prefetch distance of the leading sweep, in states
  for (std::size_t t = 0; t + 1 < nch + D; ++t) {
    if (t + 1 >= static_cast<std::size_t>(D) && t + 1 < nch) {
      // Every sweep has a full chunk: the hot loop, without bounds checks.
      const std::size_t base = t * C;
      for (std::size_t i = 0; i < C; ++i) {
        const std::size_t pa = base + i + kAhead;
        if (pa < ns) {
          const std::size_t sa = forward ? pa : ns - 1 - pa;
          const char* qa = reinterpret_cast<const char*>(pr + sa * K * L);
          for (std::size_t off = 0; off < K * L * sizeof(P); off += 64) {
            _mm_prefetch(qa + off, _MM_HINT_T0);
          }
          _mm_prefetch(reinterpret_cast<const char*>(sc + sa * K), _MM_HINT_T0);
        }
#pragma GCC unroll 4
        for (int j = 0; j < D; ++j) {
          const std::size_t p = base + i - static_cast<std::size_t>(j) * C;
          r[j] = sweepUpdateAvx2<K, L, P>(sc, pr, rw, v, forward ? p : ns - 1 - p, r[j]);
        }
      }
    } else {
      for (std::size_t i = 0; i < C; ++i) {
        for (int j = 0; j < D; ++j) {
          if (t < static_cast<std::size_t>(j) || t - j >= nch) continue;
          const std::size_t p = (t - j) * C + i;
          if (p < ns) r[j] = sweepUpdateAvx2<K, L, P>(sc, pr, rw, v, forward ? p : ns - 1 - p, r[j]);
        }
      }
    }
  }
  for (int j = 0; j < D; ++j) res[j] = r[j];
}

template <int K, int L, class P>
bool sweepPassAvx2D(const BasicSweepModel<P>& m, double* v, std::size_t depth, std::size_t C,
                    bool forward, double* res) {
  if (depth == 4) {
    sweepPassAvx2<K, L, 4, P>(m, v, C, forward, res);
  } else if (depth == 1) {
    sweepPassAvx2<K, L, 1, P>(m, v, C, forward, res);
  } else {
    return false;
  }
  return true;
}

template <int L, class P>
bool sweepPassAvx2K(const BasicSweepModel<P>& m, double* v, std::size_t depth, std::size_t C,
                    bool forward, double* res) {
  switch (m.successorsPerState()) {
    case 2: return sweepPassAvx2D<2, L, P>(m, v, depth, C, forward, res);
    case 4: return sweepPassAvx2D<4, L, P>(m, v, depth, C, forward, res);
    case 5: return sweepPassAvx2D<5, L, P>(m, v, depth, C, forward, res);
    case 6: return sweepPassAvx2D<6, L, P>(m, v, depth, C, forward, res);
    case 8: return sweepPassAvx2D<8, L, P>(m, v, depth, C, forward, res);
    default: return false;
  }
}
#endif

template <class P>
void sweepPass(Isa isa, const BasicSweepModel<P>& m, double* v, std::size_t depth,
               std::size_t C, bool forward, double* res) {
#ifdef KRR_MDP_X86_DISPATCH
  if (isa == Isa::kAvx2) {
    const bool done = m.actionLanes() == 4 ? sweepPassAvx2K<4, P>(m, v, depth, C, forward, res)
                                           : sweepPassAvx2K<8, P>(m, v, depth, C, forward, res);
    if (done) return;
  }
#endif
  (void)isa;
  sweepPassGeneric(m, v, depth, C, forward, res);
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
  const Isa isa = bestIsa();
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
