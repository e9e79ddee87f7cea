// The AVX2 + FMA value-iteration kernels (contract: solver_kernels.h). Compiled for every
// x86-64 target with per-function target attributes, so one binary runs on any CPU: the driver
// calls them only where cpuHasAvx2Fma().
#include "solver_kernels.h"

#ifdef KRR_MDP_X86_DISPATCH
#include <immintrin.h>
#endif

namespace krr {
namespace mdp {
namespace kernels {

#ifndef KRR_MDP_X86_DISPATCH

bool cpuHasAvx2Fma() { return false; }

#else

bool cpuHasAvx2Fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}

namespace {

#define KRR_AVX2 __attribute__((target("avx2,fma"), always_inline)) inline
KRR_AVX2 __m256d load4(const double* p) { return _mm256_loadu_pd(p); }
KRR_AVX2 __m256d load4(const float* p) { return _mm256_cvtps_pd(_mm_loadu_ps(p)); }
KRR_AVX2 double hmax4(__m256d v) {
  __m128d h = _mm_max_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_max_sd(h, _mm_unpackhi_pd(h, h)));
}
KRR_AVX2 __m256d bcast(const double* p) { return _mm256_broadcast_sd(p); }

template <class P>
__attribute__((target("avx2,fma"))) double gridRowKernel(
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

template <int K, int L, class P>
KRR_AVX2 double sweepBackup(const std::uint32_t* __restrict sc, const P* __restrict pr,
                            const P* __restrict rw, const double* __restrict v, std::size_t s) {
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
KRR_AVX2 double sweepUpdate(const std::uint32_t* __restrict sc, const P* __restrict pr,
                            const P* __restrict rw, double* __restrict v, std::size_t s,
                            double res) {
  const double b = sweepBackup<K, L, P>(sc, pr, rw, v, s);
  const double d = std::fabs(b - v[s]);
  v[s] = b;
  return d > res ? d : res;
}

template <int K, int L, int D, class P>
__attribute__((target("avx2,fma"))) void sweepPassKernel(const BasicSweepModel<P>& m, double* v,
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
          r[j] = sweepUpdate<K, L, P>(sc, pr, rw, v, forward ? p : ns - 1 - p, r[j]);
        }
      }
    } else {
      for (std::size_t i = 0; i < C; ++i) {
        for (int j = 0; j < D; ++j) {
          if (t < static_cast<std::size_t>(j) || t - j >= nch) continue;
          const std::size_t p = (t - j) * C + i;
          if (p < ns) r[j] = sweepUpdate<K, L, P>(sc, pr, rw, v, forward ? p : ns - 1 - p, r[j]);
        }
      }
    }
  }
  for (int j = 0; j < D; ++j) res[j] = r[j];
}

template <int K, int L, class P>
bool sweepPassDepth(const BasicSweepModel<P>& m, double* v, std::size_t depth, std::size_t C,
                    bool forward, double* res) {
  if (depth == 4) {
    sweepPassKernel<K, L, 4, P>(m, v, C, forward, res);
  } else if (depth == 1) {
    sweepPassKernel<K, L, 1, P>(m, v, C, forward, res);
  } else {
    return false;
  }
  return true;
}

template <int L, class P>
bool sweepPassSuccessors(const BasicSweepModel<P>& m, double* v, std::size_t depth,
                         std::size_t C, bool forward, double* res) {
  switch (m.successorsPerState()) {
    case 2: return sweepPassDepth<2, L, P>(m, v, depth, C, forward, res);
    case 4: return sweepPassDepth<4, L, P>(m, v, depth, C, forward, res);
    case 5: return sweepPassDepth<5, L, P>(m, v, depth, C, forward, res);
    case 6: return sweepPassDepth<6, L, P>(m, v, depth, C, forward, res);
    case 8: return sweepPassDepth<8, L, P>(m, v, depth, C, forward, res);
    default: return false;
  }
}

template <int K>
__attribute__((target("avx2,fma"))) void sweepPaddedKernel(
    const SparseModel& m, const std::vector<StateId>& nx, const std::vector<double>& pr,
    std::vector<double>& v, const SolverOptions& options, Solution& sol) {
  sweepPaddedBody<K>(m, nx, pr, v, options, sol);
}

}  // namespace

template <class P>
double gridRowAvx2(std::size_t nb, const P* prob, const P* rew, const P* live, const double* up,
                   double* cur, const double* dn, double g) {
  return gridRowKernel<P>(nb, prob, rew, live, up, cur, dn, g);
}

template <class P>
bool sweepPassAvx2(const BasicSweepModel<P>& m, double* v, std::size_t depth, std::size_t C,
                   bool forward, double* res) {
  return m.actionLanes() == 4 ? sweepPassSuccessors<4, P>(m, v, depth, C, forward, res)
                              : sweepPassSuccessors<8, P>(m, v, depth, C, forward, res);
}

template <int K>
void sweepPaddedAvx2(const SparseModel& m, const std::vector<StateId>& nx,
                     const std::vector<double>& pr, std::vector<double>& v,
                     const SolverOptions& options, Solution& sol) {
  sweepPaddedKernel<K>(m, nx, pr, v, options, sol);
}

KRR_MDP_INSTANTIATE_KERNELS(Avx2)

#endif  // KRR_MDP_X86_DISPATCH

}  // namespace kernels
}  // namespace mdp
}  // namespace krr
