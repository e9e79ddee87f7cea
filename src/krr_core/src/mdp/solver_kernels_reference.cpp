// The portable value-iteration kernels (contract: solver_kernels.h).
#include <algorithm>
#include <cmath>

#include "solver_kernels.h"

namespace krr {
namespace mdp {
namespace kernels {

template <class P>
double gridRowReference(std::size_t nb, const P* __restrict prob, const P* __restrict rew,
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

namespace {

/// Backup of state s: max over actions of R(s, a) + sum_k P[s][k][a] V(N(s)_k).
template <class P>
double sweepBackupReference(const BasicSweepModel<P>& m, const double* v, std::size_t s) {
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

}  // namespace

template <class P>
bool sweepPassReference(const BasicSweepModel<P>& m, double* v, std::size_t depth,
                        std::size_t C, bool forward, double* res) {
  const std::size_t ns = m.getS();
  const std::size_t nch = (ns + C - 1) / C;
  for (std::size_t t = 0; t + 1 < nch + depth; ++t) {
    for (std::size_t i = 0; i < C; ++i) {
      for (std::size_t j = 0; j < depth; ++j) {
        if (t < j || t - j >= nch) continue;
        const std::size_t p = (t - j) * C + i;
        if (p >= ns) continue;
        const std::size_t s = forward ? p : ns - 1 - p;
        const double b = sweepBackupReference(m, v, s);
        res[j] = std::max(res[j], std::fabs(b - v[s]));
        v[s] = b;
      }
    }
  }
  return true;
}

template <int K>
void sweepPaddedReference(const SparseModel& m, const std::vector<StateId>& nx,
                          const std::vector<double>& pr, std::vector<double>& v,
                          const SolverOptions& options, Solution& sol) {
  sweepPaddedBody<K>(m, nx, pr, v, options, sol);
}

KRR_MDP_INSTANTIATE_KERNELS(Reference)

}  // namespace kernels
}  // namespace mdp
}  // namespace krr
