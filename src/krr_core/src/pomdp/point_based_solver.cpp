#include "krr_core/pomdp/point_based_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace pomdp {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

/*
 * Sawtooth scan: best = min(best, min over points i (in `order`, by increasing improvement)
 * of improve[i] * ratio_i), ratio_i = min_s (b(s) inv_i(s) + pen_i(s)) over sp (padded)
 * entries. Points are visited most negative improvement first; a point contributes at least
 * its improvement (ratio <= 1), so the scan stops at the first one that cannot beat `best`.
 */
double sawtoothGeneric(const double* b, const double* inv, const double* pen, std::size_t sp,
                       const std::size_t* order, std::size_t n, const double* improve,
                       double best) {
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t i = order[j];
    const double imp = improve[i];
    if (imp >= best) break;
    const double* iv = inv + i * sp;
    const double* pe = pen + i * sp;
    double m0 = 1.0, m1 = 1.0, m2 = 1.0, m3 = 1.0;
    for (std::size_t s = 0; s < sp; s += 4) {
      const double r0 = b[s] * iv[s] + pe[s], r1 = b[s + 1] * iv[s + 1] + pe[s + 1];
      const double r2 = b[s + 2] * iv[s + 2] + pe[s + 2], r3 = b[s + 3] * iv[s + 3] + pe[s + 3];
      m0 = r0 < m0 ? r0 : m0;
      m1 = r1 < m1 ? r1 : m1;
      m2 = r2 < m2 ? r2 : m2;
      m3 = r3 < m3 ? r3 : m3;
    }
    const double ratio = std::min(std::min(m0, m1), std::min(m2, m3));
    best = std::min(best, imp * ratio);
  }
  return best;
}

#if defined(__x86_64__) && defined(__GNUC__)
#define KRR_POMDP_X86_DISPATCH 1
__attribute__((target("avx2,fma"))) double sawtoothAvx2(
    const double* b, const double* inv, const double* pen, std::size_t sp,
    const std::size_t* order, std::size_t n, const double* improve, double best) {
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t i = order[j];
    const double imp = improve[i];
    if (imp >= best) break;
    const double* iv = inv + i * sp;
    const double* pe = pen + i * sp;
    __m256d m = _mm256_set1_pd(1.0);
    for (std::size_t s = 0; s < sp; s += 4) {
      m = _mm256_min_pd(m, _mm256_fmadd_pd(_mm256_loadu_pd(b + s), _mm256_loadu_pd(iv + s),
                                           _mm256_loadu_pd(pe + s)));
    }
    __m128d h = _mm_min_pd(_mm256_castpd256_pd128(m), _mm256_extractf128_pd(m, 1));
    const double ratio = _mm_cvtsd_f64(_mm_min_sd(h, _mm_unpackhi_pd(h, h)));
    best = std::min(best, imp * ratio);
  }
  return best;
}

bool cpuHasAvx2Fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif
}  // namespace

PointBasedSolver::PointBasedSolver(const Model& model, const Belief& b0, SolverOptions options)
    : m_(model), options_(options), s_(model.getS()), a_(model.getA()),
      gamma_(model.getDiscount()), b0_(b0) {
  if (!(gamma_ < 1.0))
    throw ConfigError("point-based solver: discount " + std::to_string(gamma_) +
                      " must be below 1 for infinite-horizon bounds");
  if (static_cast<std::size_t>(b0.size()) != s_)
    throw ConfigError("point-based solver: initial belief has " + std::to_string(b0.size()) +
                      " entries, model has " + std::to_string(s_) + " states");
  if (std::abs(b0.sum() - 1.0) > Model::kTolerance || b0.minCoeff() < 0.0)
    throw ConfigError("point-based solver: initial belief is not a distribution (sum " +
                      std::to_string(b0.sum()) + ")");
  if (!(options_.precision > 0.0))
    throw ConfigError("point-based solver: precision must be positive");
  obsCol_.resize(a_);
  obsOffset_.assign(1, 0);
  for (std::size_t a = 0; a < a_; ++a) {
    for (std::size_t o : m_.possibleObservations(a))
      obsCol_[a].push_back(m_.observationColumn(a, o));
    obsOffset_.push_back(obsOffset_.back() + obsCol_[a].size());
    // Does a always lead to terminal (absorbing, zero-reward) states, like serve?
    bool allTerminal = true;
    for (std::size_t s = 0; s < s_ && allTerminal; ++s)
      for (const auto& e : m_.successors(s, a)) allTerminal = allTerminal && m_.isTerminal(e.first);
    toTerminal_.push_back(allTerminal ? 1 : 0);
  }
  sp_ = (s_ + 3) / 4 * 4;
  bpad_.assign(sp_, 0.0);
  const auto n = static_cast<Eigen::Index>(s_);
  pred_.resize(n);
  child_.resize(n);
  acc_.resize(n);
  bestAlpha_.resize(n);
  // Set-up budget: a third to the lower bound, half the rest to the MDP values, the rest
  // (at most initTimeLimit) to FIB. A phase that finishes early leaves its time to the next.
  Stopwatch sw;
  const double limit =
      options_.setupTimeLimit > 0.0 ? options_.setupTimeLimit : 0.5 * options_.timeout;
  const double share = std::max(0.0, limit - sw.seconds());
  initLower(sw.seconds() + share / 3.0);
  setup_.lowerSeconds = sw.seconds();
  initUpper(sw.seconds() + std::max(0.0, limit - sw.seconds()) / 2.0, limit);
  rootLower_ = lowerRaw(b0_.data());
  rootUpper_ = upperRaw(b0_.data());
  elapsed_ = sw.seconds();
  candidate_.resize(n);
}

void PointBasedSolver::initLower(double deadline) {
  // Blind policy "always a": alpha_a = (I - gamma T_a)^{-1} R_a, the exact value of a plan.
  // Large models: Gauss-Seidel sweeps v(s) <- R(s, a) + gamma sum T(s, a, s') v(s') from
  // v = min_s R(s, a) / (1 - gamma). The sweeps increase to alpha_a, and each entry is computed
  // from entries that only grow afterwards, so every iterate v satisfies v <= R_a + gamma T_a v:
  // a vector whose plan continues with itself is then at most its own backup, which is all the
  // lower bound needs. The sweeps can therefore stop at any time.
  const Stopwatch sw;
  const auto& r = m_.rewardMatrix();
  const auto S = static_cast<Eigen::Index>(s_);
  bool exact = true;
  for (std::size_t a = 0; a < a_; ++a) {
    const auto ac = static_cast<Eigen::Index>(a);
    Eigen::VectorXd alpha;
    if (s_ <= kDenseSetupStates) {
      Eigen::MatrixXd lhs = Eigen::MatrixXd::Identity(S, S) - gamma_ * m_.denseTransition(a);
      alpha = lhs.partialPivLu().solve(r.col(ac));
    } else {
      // This action's share of the time left.
      const double end = sw.seconds() + std::max(0.0, deadline - sw.seconds()) /
                                            static_cast<double>(a_ - a);
      alpha = Eigen::VectorXd::Constant(S, r.col(ac).minCoeff() / (1.0 - gamma_));
      bool converged = false;
      while (!converged && sw.seconds() < end) {
        double delta = 0.0, scale = 1.0;
        bool cut = false;  // a partial sweep keeps the invariant too
        for (std::size_t s = 0; s < s_ && !cut; ++s) {
          cut = (s & 255) == 255 && sw.seconds() >= end;
          double v = r(static_cast<Eigen::Index>(s), ac);
          for (const auto& e : m_.successors(s, a))
            v += gamma_ * e.second * alpha(static_cast<Eigen::Index>(e.first));
          v = std::max(v, alpha(static_cast<Eigen::Index>(s)));  // monotone under rounding
          delta = std::max(delta, v - alpha(static_cast<Eigen::Index>(s)));
          scale = std::max(scale, std::abs(v));
          alpha(static_cast<Eigen::Index>(s)) = v;
        }
        ++setup_.lowerSweeps;
        converged = !cut && delta <= 1e-12 * scale;
      }
      exact = exact && converged;
    }
    // Rounding safety: shift down by a relative epsilon so the vector stays a lower bound.
    alpha.array() -= 1e-9 * (1.0 + alpha.cwiseAbs().maxCoeff());
    // Its plan continues with itself after every observation.
    const auto self = static_cast<std::uint32_t>(alphaAction_.size());
    addAlpha(alpha, a, std::vector<std::uint32_t>(obsCol_[a].size(), self));
  }
  setup_.lowerExact = exact;
  setup_.timedOut = setup_.timedOut || !exact;
  pruneAlphas();
}

void PointBasedSolver::initUpper(double mdpDeadline, double setupEnd) {
  // 1. MDP values; Q_MDP is an upper bound (QMDP). Small models: exact, by policy iteration.
  //    Large ones: Gauss-Seidel value iteration from V = max R / (1 - gamma); the sweeps
  //    decrease to V_MDP and every iterate satisfies V >= H V (the mirror of initLower), so
  //    Q = R + gamma T V >= H Q is an upper bound wherever the sweeps stop.
  // 2. Fast informed bound Q(s,a) = R(s,a) + gamma sum_o max_a' sum_s' T O Q(s',a'),
  //    iterated downwards from Q_MDP: each iterate is an upper bound, so stopping early is
  //    safe; the FIB operator is below the QMDP operator, hence the sequence is monotone.
  // mdpDeadline and setupEnd are in seconds of the constructor's clock (since initLower
  // started). FIB gets initTimeLimit, within setupEnd.
  const Stopwatch sw;
  const double offset = setup_.lowerSeconds;
  auto late = [&](double deadline) { return offset + sw.seconds() >= deadline; };
  const auto& r = m_.rewardMatrix();
  const auto S = static_cast<Eigen::Index>(s_), A = static_cast<Eigen::Index>(a_);
  Eigen::VectorXd v = Eigen::VectorXd::Zero(S);
  Eigen::MatrixXd q(S, A);
  if (s_ <= kDenseSetupStates) {
    std::vector<std::size_t> pol(s_, 0);
    for (std::size_t s = 0; s < s_; ++s) {
      Eigen::Index best = 0;
      r.row(static_cast<Eigen::Index>(s)).maxCoeff(&best);
      pol[s] = static_cast<std::size_t>(best);
    }
    for (int it = 0; it < 1000; ++it) {
      Eigen::MatrixXd lhs = Eigen::MatrixXd::Identity(S, S);
      Eigen::VectorXd rhs(S);
      for (std::size_t s = 0; s < s_; ++s) {
        for (const auto& e : m_.successors(s, pol[s]))
          lhs(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(e.first)) -=
              gamma_ * e.second;
        rhs(s) = r(s, pol[s]);
      }
      v = lhs.partialPivLu().solve(rhs);
      bool changed = false;
      Eigen::VectorXd tv;
      for (std::size_t a = 0; a < a_; ++a) {
        m_.expectNext(a, v, tv);
        q.col(static_cast<Eigen::Index>(a)) = r.col(static_cast<Eigen::Index>(a)) + gamma_ * tv;
      }
      for (std::size_t s = 0; s < s_; ++s) {
        Eigen::Index best = 0;
        const double bv = q.row(static_cast<Eigen::Index>(s)).maxCoeff(&best);
        if (bv > q(s, pol[s]) + 1e-12) {
          pol[s] = static_cast<std::size_t>(best);
          changed = true;
        }
      }
      if (!changed) break;
    }
    setup_.mdpExact = true;
  } else {
    v.setConstant(r.maxCoeff() / (1.0 - gamma_));
    bool converged = false;
    while (!converged && !late(mdpDeadline)) {
      double delta = 0.0, scale = 1.0;
      bool cut = false;  // a partial sweep keeps V >= H V too
      for (std::size_t s = 0; s < s_ && !cut; ++s) {
        cut = (s & 255) == 255 && late(mdpDeadline);
        double best = -kInf;
        for (std::size_t a = 0; a < a_; ++a) {
          double x = r(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(a));
          for (const auto& e : m_.successors(s, a))
            x += gamma_ * e.second * v(static_cast<Eigen::Index>(e.first));
          best = std::max(best, x);
        }
        best = std::min(best, v(static_cast<Eigen::Index>(s)));  // monotone under rounding
        delta = std::max(delta, v(static_cast<Eigen::Index>(s)) - best);
        scale = std::max(scale, std::abs(best));
        v(static_cast<Eigen::Index>(s)) = best;
      }
      ++setup_.mdpSweeps;
      converged = !cut && delta <= 1e-12 * scale;
    }
    setup_.mdpExact = converged;
    setup_.timedOut = setup_.timedOut || !converged;
    for (std::size_t a = 0; a < a_; ++a)
      for (std::size_t s = 0; s < s_; ++s) {
        double x = r(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(a));
        for (const auto& e : m_.successors(s, a))
          x += gamma_ * e.second * v(static_cast<Eigen::Index>(e.first));
        q(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(a)) = x;
      }
  }
  // Rounding safety margin, and a Bellman check: if the MDP values are not an upper fixed
  // point (e.g. ill-conditioned), fall back to the trivial bound Rmax / (1 - gamma).
  q.array() += 1e-9 * (1.0 + q.cwiseAbs().maxCoeff());
  {
    const Eigen::VectorXd qmax = q.rowwise().maxCoeff();
    double worst = 0.0;
    for (std::size_t a = 0; a < a_; ++a)
      for (std::size_t s = 0; s < s_; ++s) {
        double back = r(s, a);
        for (const auto& e : m_.successors(s, a))
          back += gamma_ * e.second * qmax(static_cast<Eigen::Index>(e.first));
        worst = std::max(worst, back - q(s, a));
      }
    if (worst > 0.0) q.setConstant(r.maxCoeff() / (1.0 - gamma_) + 1e-9);
  }
  setup_.mdpSeconds = sw.seconds();
  Eigen::MatrixXd next = q;
  const double fibDeadline = std::min(setupEnd, offset + sw.seconds() + options_.initTimeLimit);
  bool fibDone = false, cut = false;
  // slotOf[a][o]: index of o among the possible observations of a. The sums over successors
  // run over the sparse O rows (so O need not be dense), accumulating per (slot, a2) in the
  // same order as sum_s' T O Q.
  std::vector<std::vector<std::size_t>> slotOf(a_, std::vector<std::size_t>(m_.getO(), 0));
  for (std::size_t a = 0; a < a_; ++a)
    for (std::size_t k = 0; k < m_.possibleObservations(a).size(); ++k)
      slotOf[a][m_.possibleObservations(a)[k]] = k;
  std::vector<double> acc;
  for (std::size_t it = 0; it < options_.initIterations && !fibDone && !cut; ++it) {
    double delta = 0.0;
    for (std::size_t a = 0; a < a_ && !cut; ++a) {
      const std::size_t slots = m_.possibleObservations(a).size();
      for (std::size_t s = 0; s < s_; ++s) {
        // An unfinished iteration is dropped (q stays the last complete one).
        if ((s & 63) == 0 && late(fibDeadline)) {
          cut = true;
          break;
        }
        double val = r(s, a);
        acc.assign(slots * a_, 0.0);
        for (const auto& e : m_.successors(s, a)) {
          const auto s1 = static_cast<Eigen::Index>(e.first);
          for (const auto& z : m_.observationRow(e.first, a)) {
            const double w = e.second * z.second;
            double* row = &acc[slotOf[a][z.first] * a_];
            for (std::size_t a2 = 0; a2 < a_; ++a2)
              row[a2] += w * q(s1, static_cast<Eigen::Index>(a2));
          }
        }
        for (std::size_t k = 0; k < slots; ++k) {
          double best = -kInf;
          for (std::size_t a2 = 0; a2 < a_; ++a2) best = std::max(best, acc[k * a_ + a2]);
          val += gamma_ * best;
        }
        next(s, a) = std::min(val, q(s, a));  // keep the sequence monotone under rounding
        delta = std::max(delta, q(s, a) - next(s, a));
      }
    }
    if (cut) break;
    q.swap(next);
    ++setup_.fibIterations;
    fibDone = delta < 1e-10;
  }
  setup_.fibConverged = fibDone;
  setup_.timedOut = setup_.timedOut || (!fibDone && late(setupEnd));
  setup_.fibSeconds = sw.seconds() - setup_.mdpSeconds;
  for (std::size_t s = 0; s < s_; ++s)
    if (m_.isTerminal(s)) q.row(static_cast<Eigen::Index>(s)).setZero();  // exactly 0
  corner_ = q.rowwise().maxCoeff();
  // Keep the FIB action vectors that are not pointwise dominated: max_a Q(., a) . b is an
  // upper bound at every belief, often much tighter than the corner interpolation.
  std::vector<char> keep(a_, 1);
  for (std::size_t a = 0; a < a_; ++a)
    for (std::size_t a2 = 0; a2 < a_ && keep[a]; ++a2) {
      if (a2 == a || !keep[a2]) continue;
      if ((q.col(static_cast<Eigen::Index>(a)).array() <=
           q.col(static_cast<Eigen::Index>(a2)).array()).all())
        keep[a] = 0;
    }
  std::vector<Eigen::Index> kept;
  for (std::size_t a = 0; a < a_; ++a)
    if (keep[a]) kept.push_back(static_cast<Eigen::Index>(a));
  fibMat_.resize(static_cast<Eigen::Index>(kept.size()), S);
  for (std::size_t k = 0; k < kept.size(); ++k)
    fibMat_.row(static_cast<Eigen::Index>(k)) = q.col(kept[k]).transpose();
  fibBuf_.resize(static_cast<Eigen::Index>(kept.size()));
}

double PointBasedSolver::lowerRaw(const double* b) const {
  double best = -kInf;
  const std::size_t n = alphaAction_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double* al = &alpha_[i * s_];
    double v = 0.0;
    for (std::size_t s = 0; s < s_; ++s) v += al[s] * b[s];
    best = std::max(best, v);
  }
  return best;
}

double PointBasedSolver::upperRaw(const double* b) const {
  Eigen::Map<const Eigen::VectorXd> bm(b, static_cast<Eigen::Index>(s_));
  const double base = corner_.dot(bm);
  // FIB vectors: upper bound max_a Q_FIB(., a) . b (one vectorised matrix-vector product)
  fibBuf_.noalias() = fibMat_ * bm;
  const double fib = fibBuf_.maxCoeff();
  // Sawtooth over the points, relative to the corners; improvements below the FIB value
  // are what counts.
  double best = std::min(0.0, fib - base);
  if (!options_.sawtooth) {
    // Exact values at stored points only (hash lookup), FIB elsewhere.
    const std::size_t i = findPoint(b);
    if (i != kNoPoint) best = std::min(best, improve_[i]);
    return base + best;
  }
  // ratio_i = min over the support of point i of b(s) / b_i(s), computed as
  // min_s (b(s) * inv_i(s) + pen_i(s)) with inv = 1 / b_i, pen = 0 on the support and
  // inv = 0, pen = 2 (neutral: the ratio is at most 1) off it and on the padding.
  std::copy(b, b + s_, bpad_.begin());
#ifdef KRR_POMDP_X86_DISPATCH
  if (cpuHasAvx2Fma()) {
    best = sawtoothAvx2(bpad_.data(), inv_.data(), pen_.data(), sp_, order_.data(),
                        order_.size(), improve_.data(), best);
    return base + best;
  }
#endif
  best = sawtoothGeneric(bpad_.data(), inv_.data(), pen_.data(), sp_, order_.data(),
                         order_.size(), improve_.data(), best);
  return base + best;
}

double PointBasedSolver::lowerBound(const Belief& b) const {
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("lowerBound: belief size " + std::to_string(b.size()));
  return lowerRaw(b.data());
}

double PointBasedSolver::upperBound(const Belief& b) const {
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("upperBound: belief size " + std::to_string(b.size()));
  return upperRaw(b.data());
}

void PointBasedSolver::addAlpha(const Eigen::VectorXd& alpha, std::size_t action,
                                std::vector<std::uint32_t> children) {
  alpha_.insert(alpha_.end(), alpha.data(), alpha.data() + s_);
  alphaAction_.push_back(action);
  alphaChildren_.push_back(std::move(children));
}

std::uint64_t PointBasedSolver::beliefKey(const double* b) const {
  std::uint64_t h = 0x9e3779b97f4a7c15ULL;
  for (std::size_t s = 0; s < s_; ++s) {
    const auto q = static_cast<std::int64_t>(std::llround(b[s] * 1e9));
    h = splitMix64(h ^ static_cast<std::uint64_t>(q));
  }
  return h;
}

std::size_t PointBasedSolver::findPoint(const double* b) const {
  auto it = pointIndex_.find(beliefKey(b));
  if (it == pointIndex_.end()) return kNoPoint;
  for (std::size_t i : it->second) {
    const double* p = &point_[i * s_];
    bool same = true;
    for (std::size_t s = 0; s < s_ && same; ++s) same = std::abs(p[s] - b[s]) < 1e-12;
    if (same) return i;
  }
  return kNoPoint;
}

void PointBasedSolver::insertOrdered(std::size_t i) {
  auto pos = std::lower_bound(order_.begin(), order_.end(), improve_[i],
                              [this](std::size_t k, double v) { return improve_[k] < v; });
  order_.insert(pos, i);
}

void PointBasedSolver::addPoint(const Eigen::VectorXd& b, double v) {
  const double imp = v - corner_.dot(b);
  if (!(imp < 0.0)) return;  // the corners already give this value
  // Replace an identical point rather than duplicating it.
  const std::size_t found = findPoint(b.data());
  if (found != kNoPoint) {
    if (imp < improve_[found]) {
      order_.erase(std::find(order_.begin(), order_.end(), found));
      improve_[found] = imp;
      insertOrdered(found);
    }
    return;
  }
  pointIndex_[beliefKey(b.data())].push_back(improve_.size());
  point_.insert(point_.end(), b.data(), b.data() + s_);
  for (std::size_t s = 0; s < sp_; ++s) {
    const bool on = s < s_ && b(static_cast<Eigen::Index>(s)) > 0.0;
    inv_.push_back(on ? 1.0 / b(static_cast<Eigen::Index>(s)) : 0.0);
    pen_.push_back(on ? 0.0 : 2.0);
  }
  improve_.push_back(imp);
  insertOrdered(improve_.size() - 1);
}

void PointBasedSolver::pruneAlphas() {
  // 1. Remove pointwise-dominated vectors (never changes max_i alpha_i . b anywhere).
  // 2. Once there are belief points, keep only vectors that are the best at b0 or at some
  //    stored point (SARSOP-style pruning): the bound stays valid everywhere and unchanged
  //    at b0 and at the points, it may only loosen elsewhere.
  //    A removed vector's plan is replaced by the one dominating it (`into`).
  // 3. The vectors the kept ones' plans continue with are kept too (closure over
  //    alphaChildren_): every kept vector is then at most the backup of the kept set, so the
  //    greedy policy of the written set earns its bound (SARSOP's invariant; without it the
  //    simulated value fell below the certified bound, test TheLowerBoundNeverExceedsItsOwnBackup).
  const std::size_t n = alphaAction_.size();
  std::vector<char> keep(n, 1);
  std::vector<std::size_t> into(n);
  for (std::size_t i = 0; i < n; ++i) into[i] = i;
  for (std::size_t i = 0; i < n; ++i) {
    if (!keep[i]) continue;
    const double* ai = &alpha_[i * s_];
    for (std::size_t j = 0; j < n; ++j) {
      if (i == j || !keep[j]) continue;
      const double* aj = &alpha_[j * s_];
      bool dominated = true;  // is j <= i everywhere?
      for (std::size_t s = 0; s < s_ && dominated; ++s) dominated = aj[s] <= ai[s];
      if (dominated) {
        keep[j] = 0;
        into[j] = i;
      }
    }
  }
  auto survivor = [&](std::size_t i) {  // the kept vector standing for i
    while (into[i] != i) i = into[i];
    return i;
  };
  const std::size_t np = improve_.size();
  if (np > 0 && options_.witnessPruning) {
    std::vector<char> witness(n, 0);
    auto mark = [&](const double* b) {
      std::size_t best = 0;
      double bv = -kInf;
      for (std::size_t i = 0; i < n; ++i) {
        if (!keep[i]) continue;
        const double* al = &alpha_[i * s_];
        double v = 0.0;
        for (std::size_t s = 0; s < s_; ++s) v += al[s] * b[s];
        if (v > bv) {
          bv = v;
          best = i;
        }
      }
      witness[best] = 1;
    };
    mark(b0_.data());
    for (std::size_t k = 0; k < np; ++k) mark(&point_[k * s_]);
    std::vector<std::size_t> stack;
    for (std::size_t i = 0; i < n; ++i)
      if (keep[i] && witness[i]) stack.push_back(i);
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      for (std::uint32_t c : alphaChildren_[i]) {
        const std::size_t k = survivor(c);
        if (!witness[k]) {
          witness[k] = 1;
          stack.push_back(k);
        }
      }
    }
    for (std::size_t i = 0; i < n; ++i) keep[i] = keep[i] && witness[i];
  }
  std::vector<std::uint32_t> newIndex(n, 0);
  std::uint32_t next = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (keep[i]) newIndex[i] = next++;
  std::vector<double> na;
  std::vector<std::size_t> nact;
  std::vector<std::vector<std::uint32_t>> nchild;
  for (std::size_t i = 0; i < n; ++i)
    if (keep[i]) {
      na.insert(na.end(), alpha_.begin() + static_cast<long>(i * s_),
                alpha_.begin() + static_cast<long>((i + 1) * s_));
      nact.push_back(alphaAction_[i]);
      std::vector<std::uint32_t> ch = alphaChildren_[i];
      for (std::uint32_t& c : ch) c = newIndex[survivor(c)];
      nchild.push_back(std::move(ch));
    }
  alpha_.swap(na);
  alphaAction_.swap(nact);
  alphaChildren_.swap(nchild);
  prunedAt_ = alphaAction_.size();
}

double PointBasedSolver::successor(const Eigen::VectorXd& b, std::size_t a, std::size_t k,
                                   Eigen::VectorXd& out) const {
  m_.predict(a, b, out);
  out = out.cwiseProduct(obsCol_[a][k]);
  return out.sum();
}

void PointBasedSolver::upperBackup(const Eigen::VectorXd& b, NodeCache& c) {
  // Q_U(b, a) = R(b, a) + gamma sum_o P(o | b, a) U(b_ao), caching P and U per (a, o) so that
  // the way back up a trial only re-evaluates the child that the trial visited (a cached U
  // was a valid upper bound when computed and bounds only decrease, so it stays valid).
  const auto& r = m_.rewardMatrix();
  c.q.resize(a_);
  c.p.resize(obsOffset_.back());
  c.u.resize(obsOffset_.back());
  for (std::size_t a = 0; a < a_; ++a) {
    m_.predict(a, b, pred_);
    double qU = r.col(static_cast<Eigen::Index>(a)).dot(b);
    for (std::size_t k = 0; k < obsCol_[a].size(); ++k) {
      child_ = obsCol_[a][k].cwiseProduct(pred_);
      const double p = child_.sum();
      double u = 0.0;
      if (p > 0.0 && !toTerminal_[a]) {  // terminal successors are worth exactly 0
        child_ /= p;
        u = upperRaw(child_.data());
        qU += gamma_ * p * u;
      }
      c.p[obsOffset_[a] + k] = p;
      c.u[obsOffset_[a] + k] = u;
    }
    c.q[a] = qU;
  }
  finishUpper(b, c);
}

void PointBasedSolver::finishUpper(const Eigen::VectorXd& b, NodeCache& c) {
  double best = -kInf;
  for (std::size_t a = 0; a < a_; ++a)
    if (c.q[a] > best) {
      best = c.q[a];
      c.action = a;
    }
  if (best < upperRaw(b.data()) - 1e-12) addPoint(b, best);
}

void PointBasedSolver::refreshUpper(const Eigen::VectorXd& b, NodeCache& c, std::size_t a,
                                    std::size_t k, const Eigen::VectorXd& child) {
  const std::size_t idx = obsOffset_[a] + k;
  if (!toTerminal_[a]) c.u[idx] = std::min(c.u[idx], upperRaw(child.data()));
  double qU = m_.rewardMatrix().col(static_cast<Eigen::Index>(a)).dot(b);
  for (std::size_t j = 0; j < obsCol_[a].size(); ++j)
    qU += gamma_ * c.p[obsOffset_[a] + j] * c.u[obsOffset_[a] + j];
  c.q[a] = std::min(c.q[a], qU);
  finishUpper(b, c);
}

void PointBasedSolver::lowerBackup(const Eigen::VectorXd& b) {
  // alpha_a = R_a + gamma T_a sum_o (O_ao .* alpha_{k(o)}), alpha_{k(o)} best at b_ao: the
  // value of the plan "do a, then follow the vector chosen for the observation". The best
  // vectors of all (action, observation) children come from one matrix product
  // (alphas x children), which vectorises; dot products with the unnormalised child give the
  // same argmax as with the normalised one.
  const auto& r = m_.rewardMatrix();
  const auto S = static_cast<Eigen::Index>(s_);
  const std::size_t n = alphaAction_.size();
  const std::size_t slots = obsOffset_.back();
  children_.resize(S, static_cast<Eigen::Index>(slots));
  for (std::size_t a = 0; a < a_; ++a) {
    m_.predict(a, b, pred_);
    for (std::size_t k = 0; k < obsCol_[a].size(); ++k)
      children_.col(static_cast<Eigen::Index>(obsOffset_[a] + k)) =
          obsCol_[a][k].cwiseProduct(pred_);
  }
  Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
      alphas(alpha_.data(), static_cast<Eigen::Index>(n), S);
  scores_.noalias() = alphas * children_;
  double bestLower = -kInf;
  std::size_t bestLowerAction = 0;
  for (std::size_t a = 0; a < a_; ++a) {
    const bool ident = m_.isIdentityTransition(a);
    acc_.setZero();
    candChildren_.assign(obsCol_[a].size(), 0);
    for (std::size_t k = 0; k < obsCol_[a].size(); ++k) {
      const auto slot = static_cast<Eigen::Index>(obsOffset_[a] + k);
      // A zero-probability observation may take any vector (index 0).
      Eigen::Index bestI = 0;
      if (children_.col(slot).sum() > 0.0) scores_.col(slot).maxCoeff(&bestI);
      candChildren_[k] = static_cast<std::uint32_t>(bestI);
      const double* al = &alpha_[static_cast<std::size_t>(bestI) * s_];
      acc_ += obsCol_[a][k].cwiseProduct(Eigen::Map<const Eigen::VectorXd>(al, S));
    }
    if (ident) {
      candidate_ = r.col(static_cast<Eigen::Index>(a)) + gamma_ * acc_;
    } else {
      candidate_ = r.col(static_cast<Eigen::Index>(a));
      if (m_.hasDenseTransitions()) {
        candidate_.noalias() += gamma_ * (m_.transitionMatrix(a) * acc_);
      } else {
        m_.expectNext(a, acc_, child_);
        candidate_ += gamma_ * child_;
      }
    }
    const double qL = candidate_.dot(b);
    if (qL > bestLower) {
      bestLower = qL;
      bestLowerAction = a;
      bestAlpha_.swap(candidate_);
      bestChildren_.swap(candChildren_);
    }
  }
  if (bestLower > lowerRaw(b.data()) + 1e-12)
    addAlpha(bestAlpha_, bestLowerAction, bestChildren_);
  if (alphaAction_.size() > 2 * prunedAt_ + 32) pruneAlphas();
}

double PointBasedSolver::now() const { return clockOffset_ + clock_.seconds(); }

void PointBasedSolver::trial() {
  const double eps =
      std::max(options_.precision, options_.trialGapFactor * (rootUpper_ - rootLower_));
  if (path_.empty()) {
    path_.emplace_back();
    cache_.emplace_back();
  }
  path_[0] = b0_;
  std::size_t depth = 0;
  double thr = eps;
  // Weight of the current node in the root's value: P(observations so far) gamma^depth.
  double weight = 1.0;
  const double rootGap = rootUpper_ - rootLower_;
  std::vector<std::size_t>& chosenObs = chosenObs_;
  chosenObs.clear();
  while (true) {
    NodeCache& c = cache_[depth];
    upperBackup(path_[depth], c);
    const std::size_t a = c.action;
    const double* bd = path_[depth].data();
    const double gap = upperRaw(bd) - lowerRaw(bd);
    if (gap <= thr || depth + 1 >= options_.maxDepth || now() >= deadline_) break;
    // A node whose weighted gap is a negligible share of the root gap cannot move the root.
    if (weight * gap < cutoffScale_ * options_.trialWeightCutoff * rootGap) break;
    const double childThr = thr / gamma_;
    double bestScore = 0.0;
    std::size_t bestK = obsCol_[a].size();
    for (std::size_t k = 0; k < obsCol_[a].size(); ++k) {
      const double p = c.p[obsOffset_[a] + k];
      if (!(p > 0.0)) continue;
      successor(path_[depth], a, k, child_);
      child_ /= p;
      const double score = p * (c.u[obsOffset_[a] + k] - lowerRaw(child_.data()) - childThr);
      if (score > bestScore) {
        bestScore = score;
        bestK = k;
      }
    }
    if (bestK == obsCol_[a].size()) break;
    weight *= gamma_ * c.p[obsOffset_[a] + bestK];  // before cache_ may reallocate
    if (path_.size() < depth + 2) {
      path_.emplace_back();
      cache_.emplace_back();
    }
    const double p = successor(path_[depth], a, bestK, path_[depth + 1]);
    path_[depth + 1] /= p;
    chosenObs.push_back(bestK);
    ++depth;
    thr = childThr;
  }
  // Backups are optional for the bounds' validity: past the deadline, the rest are skipped,
  // so that a deep trial cannot overrun the budget by its own length.
  lowerBackup(path_[depth]);
  for (std::size_t d = depth; d-- > 0;) {
    if (now() >= deadline_) break;
    NodeCache& c = cache_[d];
    refreshUpper(path_[d], c, c.action, chosenObs[d], path_[d + 1]);
    lowerBackup(path_[d]);
  }
  ++trials_;
  const double lowerBefore = rootLower_;
  rootLower_ = std::max(rootLower_, lowerRaw(b0_.data()));
  rootUpper_ = std::min(rootUpper_, upperRaw(b0_.data()));
  // Trials that stop at the weight cutoff may stop improving the root (its gap then sits in
  // many light nodes): after kStallTrials trials without progress, halve the cutoff. The lower
  // bound is watched on its own too: on RockSample the upper bound kept shrinking (so the gap
  // "progressed") while the lower bound sat at its 0.6 s value for the rest of a 10 s run, the
  // light nodes where its plans improve never being reached.
  constexpr std::size_t kStallTrials = 16;
  if (rootUpper_ - rootLower_ < rootGap * (1.0 - 1e-9)) {
    stalled_ = 0;
  } else if (++stalled_ >= kStallTrials) {
    stalled_ = 0;
    cutoffScale_ *= 0.5;
  }
  if (rootLower_ > lowerBefore + 1e-9 * (1.0 + std::abs(lowerBefore))) {
    lowerStalled_ = 0;
  } else if (++lowerStalled_ >= 4 * kStallTrials) {
    lowerStalled_ = 0;
    cutoffScale_ *= 0.5;
  }
}

bool PointBasedSolver::runUntil(double untilSeconds) {
  clockOffset_ = elapsed_;
  clock_.reset();
  deadline_ = untilSeconds;
  while (!converged() && now() < deadline_ &&
         (options_.maxTrials == 0 || trials_ < options_.maxTrials))
    trial();
  elapsed_ = now();
  return converged();
}

bool PointBasedSolver::converged() const {
  return rootUpper_ - rootLower_ <= options_.precision;
}

BoundsReport PointBasedSolver::report() const {
  BoundsReport r;
  r.time = elapsed_;
  r.lower = rootLower_;
  r.upper = rootUpper_;
  r.alphas = alphaAction_.size();
  r.points = improve_.size();
  r.trials = trials_;
  return r;
}

AlphaVectorPolicy PointBasedSolver::policy() const {
  AlphaVectorPolicy p(s_);
  for (std::size_t i = 0; i < alphaAction_.size(); ++i)
    p.add(Eigen::Map<const Eigen::VectorXd>(&alpha_[i * s_], static_cast<Eigen::Index>(s_)),
          alphaAction_[i]);
  return p;
}

}  // namespace pomdp
}  // namespace krr
