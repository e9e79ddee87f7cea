/**
 * @file solver_kernels.h
 * @brief Private to mdp: the inner loops of value iteration, in two sets with one contract.
 *
 * solver_kernels_reference.cpp holds the portable kernels (the reference: plain C++, any CPU),
 * solver_kernels_avx2.cpp the AVX2 + FMA ones (x86-64, chosen at run time). Both compute the
 * same backups in the same operation order, so a solve gives the same values with either (up
 * to fused multiply-adds); solvers.cpp, the driver, picks the set once per solve (bestIsa()).
 */
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "krr_core/mdp/grid_model.h"
#include "krr_core/mdp/solvers.h"
#include "krr_core/mdp/sparse_model.h"

#if defined(__x86_64__) && defined(__GNUC__)
/// The AVX2 kernels exist in this build (they still need a CPU with AVX2 + FMA).
#define KRR_MDP_X86_DISPATCH 1
#endif

namespace krr {
namespace mdp {
namespace kernels {

/// @name Grid layout constants (see BasicGridModel).
/// @{
constexpr std::size_t kGL = BasicGridModel<double>::kLanes;
constexpr std::size_t kGA = BasicGridModel<double>::kNumActions;
constexpr std::size_t kGK = BasicGridModel<double>::kSweepOutcomes;
constexpr std::size_t kGBlock = BasicGridModel<double>::kBlockSize;
static_assert(kGL == 8 && kGK == 5, "grid kernels assume 8 lanes and 5 sweep outcomes");
/// @}

/// @brief Which kernels to run (chosen once per solve). AVX-512 was measured slower than AVX2
/// on the target CPU (Zen 4 splits 512-bit operations), so AVX2 + FMA is the widest.
enum class Isa { kReference, kAvx2 };

/// @brief AVX2 + FMA when this build has the kernels and the CPU the instructions, unless the
/// environment variable KRR_MDP_ISA=generic selects the reference kernels (to test them and to
/// compare in benchmarks).
Isa bestIsa();

/// @brief Whether the CPU runs AVX2 + FMA (false where the build has no AVX2 kernels).
bool cpuHasAvx2Fma();

/**
 * @brief One grid row, Jacobi-style: for every cell x of row y, b[x] = live[x] * max_a (r_a[x] +
 * g * sum_k p_ak[x] V(neighbour_k of x)), reading V from the padded array (zero halo, so the
 * edges need no branch), then V(row y) = b; returns max_x |b[x] - V_old(x)|. The store of a
 * block is delayed until the next block has loaded its (old) left neighbour, so the row is
 * updated in place in one pass. `cur` points at the left halo cell (index x + 1 is cell x);
 * `nb` is the number of 8-cell blocks of the row, `up` / `dn` the rows above and below.
 */
template <class P>
double gridRowReference(std::size_t nb, const P* prob, const P* rew, const P* live,
                        const double* up, double* cur, const double* dn, double g);
/// @brief gridRowReference() with AVX2 + FMA (only when cpuHasAvx2Fma()).
template <class P>
double gridRowAvx2(std::size_t nb, const P* prob, const P* rew, const P* live, const double* up,
                   double* cur, const double* dn, double g);

/**
 * @brief One pass of `depth` pipelined Gauss-Seidel sweeps over the sweep layout (see
 * BasicSweepModel) in chunks of C states, sweep j one chunk behind sweep j - 1; res[j] becomes
 * max(res[j], largest change of sweep j). Returns true (it has a kernel for every model).
 */
template <class P>
bool sweepPassReference(const BasicSweepModel<P>& m, double* v, std::size_t depth,
                        std::size_t C, bool forward, double* res);
/// @brief sweepPassReference() with AVX2 + FMA; false (nothing done) for a successor count or
/// depth it has no kernel for.
template <class P>
bool sweepPassAvx2(const BasicSweepModel<P>& m, double* v, std::size_t depth, std::size_t C,
                   bool forward, double* res);

/**
 * @brief Gauss-Seidel sweeps (alternating direction) of the tabular model until the stopping
 * threshold or options.max_iterations; `expect(i, v)` is sum_k P(k | row i) V(k) of row i =
 * s * A + a, in whatever layout the caller keeps the rows (CSR, padded).
 */
template <class Expect>
inline __attribute__((always_inline)) void gaussSeidelSweeps(const SparseModel& m,
                                                             std::vector<double>& v,
                                                             const SolverOptions& options,
                                                             Solution& sol, Expect expect) {
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
        const double q = rw[i] + g * expect(i, vv);
        best = q > best ? q : best;
      }
      const double d = std::fabs(best - vv[s]);
      res = d > res ? d : res;
      vv[s] = best;
    }
    if (sol.recordSweep(it, res, threshold)) break;
  }
}

/**
 * @brief gaussSeidelSweeps() over CSR rows padded to exactly K entries (zero-probability
 * padding pointing at the state itself). A compile-time trip count removes the branch
 * mispredictions that variable-length CSR rows cost on every (s, a). The reference and AVX2
 * versions are this body compiled for the two targets.
 */
template <int K>
inline __attribute__((always_inline)) void sweepPaddedBody(
    const SparseModel& m, const std::vector<StateId>& nx, const std::vector<double>& pr,
    std::vector<double>& v, const SolverOptions& options, Solution& sol) {
  const StateId* next = nx.data();
  const double* prob = pr.data();
  gaussSeidelSweeps(m, v, options, sol,
                    [next, prob](std::size_t i, const double* vv) __attribute__((always_inline)) {
                      const StateId* n = next + i * K;
                      const double* p = prob + i * K;
                      // Two accumulators halve the floating-point add chain of a row.
                      double acc0 = 0.0, acc1 = 0.0;
#pragma GCC unroll 8
                      for (int k = 0; k < K; k += 2) {
                        acc0 += p[k] * vv[n[k]];
                        acc1 += p[k + 1] * vv[n[k + 1]];
                      }
                      return acc0 + acc1;
                    });
}

/// @brief sweepPaddedBody() for the reference target.
template <int K>
void sweepPaddedReference(const SparseModel& m, const std::vector<StateId>& nx,
                          const std::vector<double>& pr, std::vector<double>& v,
                          const SolverOptions& options, Solution& sol);
/// @brief sweepPaddedBody() compiled for AVX2 + FMA (only when cpuHasAvx2Fma()).
template <int K>
void sweepPaddedAvx2(const SparseModel& m, const std::vector<StateId>& nx,
                     const std::vector<double>& pr, std::vector<double>& v,
                     const SolverOptions& options, Solution& sol);

/// @brief The explicit instantiations of one kernel set (SET: Reference or Avx2), in its file.
#define KRR_MDP_INSTANTIATE_KERNELS(SET)                                                        \
  template double gridRow##SET<double>(std::size_t, const double*, const double*, const double*, \
                                       const double*, double*, const double*, double);           \
  template double gridRow##SET<float>(std::size_t, const float*, const float*, const float*,    \
                                      const double*, double*, const double*, double);            \
  template bool sweepPass##SET<double>(const BasicSweepModel<double>&, double*, std::size_t,     \
                                       std::size_t, bool, double*);                              \
  template bool sweepPass##SET<float>(const BasicSweepModel<float>&, double*, std::size_t,      \
                                      std::size_t, bool, double*);                               \
  KRR_MDP_INSTANTIATE_PADDED(SET, 2)                                                             \
  KRR_MDP_INSTANTIATE_PADDED(SET, 4)                                                             \
  KRR_MDP_INSTANTIATE_PADDED(SET, 6)                                                             \
  KRR_MDP_INSTANTIATE_PADDED(SET, 8)
#define KRR_MDP_INSTANTIATE_PADDED(SET, K)                                                      \
  template void sweepPadded##SET<K>(const SparseModel&, const std::vector<StateId>&,            \
                                    const std::vector<double>&, std::vector<double>&,           \
                                    const SolverOptions&, Solution&);

}  // namespace kernels
}  // namespace mdp
}  // namespace krr
