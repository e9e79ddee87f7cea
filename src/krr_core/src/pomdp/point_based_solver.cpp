#include "krr_core/pomdp/point_based_solver.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace pomdp {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

/// @brief Adds the seconds from construction to destruction to a profile counter.
class ScopedTimer {
 public:
  explicit ScopedTimer(double& sink) : sink_(sink) {}
  ~ScopedTimer() { sink_ += sw_.seconds(); }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  double& sink_;
  Stopwatch sw_;
};
}  // namespace

PointBasedSolver::PointBasedSolver(const Model& model, const Belief& b0, SolverOptions options)
    : m_(model), options_(options), s_(model.getS()), a_(model.getA()),
      gamma_(model.getDiscount()) {
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
  b0_ = toSparse(b0);
  obsOffset_.assign(1, 0);
  slotOf_.assign(a_, std::vector<std::uint32_t>(m_.getO(), 0));
  for (std::size_t a = 0; a < a_; ++a) {
    const auto& obs = m_.possibleObservations(a);
    for (std::size_t k = 0; k < obs.size(); ++k) slotOf_[a][obs[k]] = static_cast<std::uint32_t>(k);
    obsOffset_.push_back(obsOffset_.back() + obs.size());
    // Does a always lead to terminal (absorbing, zero-reward) states, like serve?
    bool allTerminal = true;
    for (std::size_t s = 0; s < s_ && allTerminal; ++s)
      for (const auto& e : m_.successors(s, a)) allTerminal = allTerminal && m_.isTerminal(e.first);
    toTerminal_.push_back(allTerminal ? 1 : 0);
  }
  std::size_t maxSlots = 0;
  for (std::size_t a = 0; a < a_; ++a) maxSlots = std::max(maxSlots, obsOffset_[a + 1] - obsOffset_[a]);
  kids_.resize(maxSlots);
  probs_.resize(maxSlots);
  scatter_.assign(s_, 0.0);
  firstOf_.assign(s_, {});
  acc_.assign(s_, 0.0);
  mark_.assign(s_, 0);
  const auto n = static_cast<Eigen::Index>(s_);
  accVec_.resize(n);
  nextVec_.resize(n);
  candidate_.resize(n);
  // Set-up budget: a third to the lower bound, half the rest to the MDP values, the rest
  // (at most initTimeLimit) to FIB. A phase that finishes early leaves its time to the next.
  Stopwatch sw;
  const double limit =
      options_.setupTimeLimit > 0.0 ? options_.setupTimeLimit : 0.5 * options_.timeout;
  const double share = std::max(0.0, limit - sw.seconds());
  initLower(sw.seconds() + share / 3.0);
  setup_.lowerSeconds = sw.seconds();
  initUpper(sw.seconds() + std::max(0.0, limit - sw.seconds()) / 2.0, limit);
  rootLower_ = lowerAt(b0_);
  rootUpper_ = upperAt(b0_);
  clock_.setElapsed(sw.seconds());
}

PointBasedSolver::SparseBelief PointBasedSolver::toSparse(const Belief& b) const {
  SparseBelief out;
  for (std::size_t s = 0; s < s_; ++s)
    if (b(static_cast<Eigen::Index>(s)) != 0.0) {
      out.idx.push_back(static_cast<std::uint32_t>(s));
      out.val.push_back(b(static_cast<Eigen::Index>(s)));
    }
  return out;
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
    if (!addAlpha(alpha.data(), a, std::vector<std::uint32_t>(obsOffset_[a + 1] - obsOffset_[a], self)))
      throw ConfigError("point-based solver: the memory limit of " +
                        std::to_string(options_.memoryLimit >> 20) +
                        " MiB does not hold the initial lower bound (" + std::to_string(a_) +
                        " vectors of " + std::to_string(s_) + " states)");
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
  const std::function<bool(double)> late = [&](double deadline) {
    return offset + sw.seconds() >= deadline;
  };
  Eigen::MatrixXd q = s_ <= kDenseSetupStates ? mdpQExact() : mdpQSweeps(late, mdpDeadline);
  checkUpperFixedPoint(q);
  setup_.mdpSeconds = sw.seconds();
  const double fibDeadline = std::min(setupEnd, offset + sw.seconds() + options_.initTimeLimit);
  const bool fibDone = fastInformedBound(q, late, fibDeadline);
  setup_.fibConverged = fibDone;
  setup_.timedOut = setup_.timedOut || (!fibDone && late(setupEnd));
  setup_.fibSeconds = sw.seconds() - setup_.mdpSeconds;
  for (std::size_t s = 0; s < s_; ++s)
    if (m_.isTerminal(s)) q.row(static_cast<Eigen::Index>(s)).setZero();  // exactly 0
  corner_ = q.rowwise().maxCoeff();
  keepUndominatedFib(q);
}

Eigen::MatrixXd PointBasedSolver::mdpQExact() {
  // Policy iteration from the greedy immediate-reward policy.
  const auto& r = m_.rewardMatrix();
  const auto S = static_cast<Eigen::Index>(s_), A = static_cast<Eigen::Index>(a_);
  Eigen::VectorXd v = Eigen::VectorXd::Zero(S);
  Eigen::MatrixXd q(S, A);
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
  return q;
}

Eigen::MatrixXd PointBasedSolver::mdpQSweeps(const std::function<bool(double)>& late,
                                             double mdpDeadline) {
  // Gauss-Seidel value iteration downwards from Rmax / (1 - gamma), stoppable at any sweep.
  const auto& r = m_.rewardMatrix();
  const auto S = static_cast<Eigen::Index>(s_), A = static_cast<Eigen::Index>(a_);
  Eigen::VectorXd v = Eigen::VectorXd::Constant(S, r.maxCoeff() / (1.0 - gamma_));
  Eigen::MatrixXd q(S, A);
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
  return q;
}

void PointBasedSolver::checkUpperFixedPoint(Eigen::MatrixXd& q) const {
  // Rounding safety margin, and a Bellman check: if the MDP values are not an upper fixed
  // point (e.g. ill-conditioned), fall back to the trivial bound Rmax / (1 - gamma).
  const auto& r = m_.rewardMatrix();
  q.array() += 1e-9 * (1.0 + q.cwiseAbs().maxCoeff());
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

bool PointBasedSolver::fastInformedBound(Eigen::MatrixXd& q,
                                         const std::function<bool(double)>& late,
                                         double fibDeadline) {
  const auto& r = m_.rewardMatrix();
  Eigen::MatrixXd next = q;
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
  return fibDone;
}

void PointBasedSolver::keepUndominatedFib(const Eigen::MatrixXd& q) {
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
  fibK_ = kept.size();
  fib_.assign(s_ * fibK_, 0.0);
  fibScratch_.assign(fibK_, 0.0);
  for (std::size_t s = 0; s < s_; ++s)
    for (std::size_t k = 0; k < fibK_; ++k)
      fib_[s * fibK_ + k] = q(static_cast<Eigen::Index>(s), kept[k]);
}

double PointBasedSolver::lowerAt(const SparseBelief& b, std::size_t* arg) const {
  double best = -kInf;
  std::size_t bestI = 0;
  const std::size_t n = alphaAction_.size(), m = b.size();
  const std::uint32_t* idx = b.idx.data();
  const double* val = b.val.data();
  for (std::size_t i = 0; i < n; ++i) {
    const double* al = alpha_[i].data();
    double v0 = 0.0, v1 = 0.0;
    std::size_t j = 0;
    for (; j + 1 < m; j += 2) {
      v0 += al[idx[j]] * val[j];
      v1 += al[idx[j + 1]] * val[j + 1];
    }
    if (j < m) v0 += al[idx[j]] * val[j];
    const double v = v0 + v1;
    if (v > best) {
      best = v;
      bestI = i;
    }
  }
  if (n > 0) witness_[bestI] = 1;
  if (arg) *arg = bestI;
  return best;
}

double PointBasedSolver::rewardAt(const SparseBelief& b, std::size_t a) const {
  const auto& r = m_.rewardMatrix();
  double v = 0.0;
  for (std::size_t j = 0; j < b.size(); ++j)
    v += r(static_cast<Eigen::Index>(b.idx[j]), static_cast<Eigen::Index>(a)) * b.val[j];
  return v;
}

double PointBasedSolver::upperAt(const SparseBelief& b) const {
  double base = 0.0;
  const double best = upperBelowCorners(b, &base, nullptr);
  return base + best;
}

double PointBasedSolver::upperBelowCorners(const SparseBelief& b, double* base,
                                           const char* skip) const {
  // Corners and FIB vectors over the support of b.
  double corners = 0.0;
  double fibBest = kInf;
  if (fibK_ > 0) {
    double* fibv = fibScratch_.data();
    const std::size_t k0 = fibK_;
    std::fill(fibv, fibv + k0, 0.0);
    for (std::size_t j = 0; j < b.size(); ++j) {
      const std::size_t s = b.idx[j];
      const double p = b.val[j];
      corners += corner_(static_cast<Eigen::Index>(s)) * p;
      const double* f = &fib_[s * fibK_];
      for (std::size_t k = 0; k < k0; ++k) fibv[k] += f[k] * p;
    }
    fibBest = -kInf;
    for (std::size_t k = 0; k < k0; ++k) fibBest = std::max(fibBest, fibv[k]);
  } else {
    for (std::size_t j = 0; j < b.size(); ++j)
      corners += corner_(static_cast<Eigen::Index>(b.idx[j])) * b.val[j];
  }
  *base = corners;
  // Sawtooth over the points, relative to the corners: point i lowers the bound by
  // |improve_i| * min over its support of b(s) / b_i(s), which is 0 as soon as one state of
  // its support is outside b's (the usual case, found at its first entries). Buckets are
  // sorted by increasing improvement; a point contributes at least its improvement (the ratio
  // is at most 1), so a bucket's scan stops at the first one that cannot beat `best`.
  double best = std::min(0.0, fibBest - corners);
  if (!options_.sawtooth) {
    const std::size_t i = findPoint(b);
    if (i != kNoPoint && !(skip && skip[i])) best = std::min(best, improve_[i]);
    return best;
  }
  // Only points whose first support state is in b's support can have a non-zero ratio: they
  // are found through firstOf_ (for RockSample, the points at the robot's position).
  for (std::size_t j = 0; j < b.size(); ++j) scatter_[b.idx[j]] = b.val[j];
  for (std::size_t j = 0; j < b.size(); ++j) {
    for (std::uint32_t i : firstOf_[b.idx[j]]) {  // by increasing improvement
      const double imp = improve_[i];
      if (imp >= best) break;
      if (skip && skip[i]) continue;
      // The ratio only decreases along the support and imp < 0, so once imp * ratio >= best
      // the point cannot lower the bound: the scan of its support stops there (dense beliefs
      // of small models, where every point meets b's support, read about half as many entries).
      double ratio = 1.0;
      bool beaten = false;
      for (std::size_t e = pointStart_[i], end = pointStart_[i + 1]; e < end; ++e) {
        const double r = scatter_[pointIdx_[e]] * pointInv_[e];
        if (r < ratio) {
          ratio = r;
          if (imp * ratio >= best) {
            beaten = true;
            break;
          }
        }
      }
      if (!beaten) best = std::min(best, imp * ratio);
    }
  }
  for (std::size_t j = 0; j < b.size(); ++j) scatter_[b.idx[j]] = 0.0;
  return best;
}

double PointBasedSolver::lowerBound(const Belief& b) const {
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("lowerBound: belief size " + std::to_string(b.size()));
  return lowerAt(toSparse(b));
}

double PointBasedSolver::upperBound(const Belief& b) const {
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("upperBound: belief size " + std::to_string(b.size()));
  return upperAt(toSparse(b));
}

std::size_t PointBasedSolver::boundBytes() const {
  std::size_t bytes = alpha_.size() * (s_ * sizeof(double) + sizeof(std::vector<double>)) +
                      alphaAction_.size() * sizeof(std::size_t);
  for (const auto& c : alphaChildren_) bytes += sizeof(c) + c.size() * sizeof(std::uint32_t);
  bytes += lowerNodeBytes_;
  bytes += pointIdx_.size() * (sizeof(std::uint32_t) + sizeof(double)) +
           improve_.size() * (2 * sizeof(double) + 2 * sizeof(std::size_t) + 48);
  return bytes;
}

bool PointBasedSolver::addAlpha(const double* alpha, std::size_t action,
                                std::vector<std::uint32_t> children) {
  if (options_.memoryLimit > 0 &&
      boundBytes() + s_ * sizeof(double) + children.size() * 4 + 64 > options_.memoryLimit) {
    memoryStop_ = true;
    return false;
  }
  alpha_.emplace_back(alpha, alpha + s_);
  alphaAction_.push_back(action);
  alphaChildren_.push_back(std::move(children));
  witness_.push_back(1);
  ++profile_.alphasAdded;
  return true;
}

std::uint64_t PointBasedSolver::beliefKey(const SparseBelief& b) const {
  std::uint64_t h = 0x9e3779b97f4a7c15ULL;
  for (std::size_t j = 0; j < b.size(); ++j) {
    const auto q = static_cast<std::int64_t>(std::llround(b.val[j] * 1e9));
    h = splitMix64(h ^ (static_cast<std::uint64_t>(b.idx[j]) * 0x100000001b3ULL) ^
                   static_cast<std::uint64_t>(q));
  }
  return h;
}

std::size_t PointBasedSolver::findPoint(const SparseBelief& b) const {
  auto it = pointIndex_.find(beliefKey(b));
  if (it == pointIndex_.end()) return kNoPoint;
  for (std::size_t i : it->second) {
    const std::size_t n = pointStart_[i + 1] - pointStart_[i];
    if (n != b.size()) continue;
    bool same = true;
    for (std::size_t j = 0; j < n && same; ++j) {
      const std::size_t e = pointStart_[i] + j;
      same = pointIdx_[e] == b.idx[j] && std::abs(1.0 / pointInv_[e] - b.val[j]) < 1e-12;
    }
    if (same) return i;
  }
  return kNoPoint;
}

void PointBasedSolver::insertByImprovement(std::vector<std::uint32_t>& bucket,
                                           std::size_t i) const {
  auto pos = std::lower_bound(bucket.begin(), bucket.end(), improve_[i],
                              [this](std::uint32_t k, double v) { return improve_[k] < v; });
  bucket.insert(pos, static_cast<std::uint32_t>(i));
}

void PointBasedSolver::addPoint(const SparseBelief& b, double v) {
  double cornerValue = 0.0;
  for (std::size_t j = 0; j < b.size(); ++j)
    cornerValue += corner_(static_cast<Eigen::Index>(b.idx[j])) * b.val[j];
  const double imp = v - cornerValue;
  if (!(imp < 0.0)) return;  // the corners already give this value
  // Replace an identical point rather than duplicating it.
  const std::size_t found = findPoint(b);
  if (found != kNoPoint) {
    if (imp < improve_[found]) {
      auto& bucket = firstOf_[b.idx.front()];
      bucket.erase(std::find(bucket.begin(), bucket.end(), static_cast<std::uint32_t>(found)));
      improve_[found] = imp;
      insertByImprovement(bucket, found);
    }
    return;
  }
  const auto overLimit = [&] {
    return options_.memoryLimit > 0 && boundBytes() + b.size() * 12 + 96 > options_.memoryLimit;
  };
  // At the memory limit, dominated points are dropped first: that frees room without
  // loosening the bound.
  if (overLimit() && options_.pointPruning && options_.sawtooth &&
      improve_.size() > pointsPrunedAt_)
    prunePointsUntil(true);
  if (overLimit()) {
    memoryStop_ = true;
    return;
  }
  pointIndex_[beliefKey(b)].push_back(improve_.size());
  for (std::size_t j = 0; j < b.size(); ++j) {
    pointIdx_.push_back(b.idx[j]);
    pointInv_.push_back(1.0 / b.val[j]);
  }
  pointStart_.push_back(pointIdx_.size());
  improve_.push_back(imp);
  insertByImprovement(firstOf_[b.idx.front()], improve_.size() - 1);
  ++profile_.pointsAdded;
}

std::size_t PointBasedSolver::prunePointsUntil(bool interruptible) {
  const ScopedTimer timer(profile_.pointPruneSeconds);
  ++profile_.pointPrunes;
  const std::size_t n = improve_.size();
  std::vector<char> dead(n, 0);
  SparseBelief b;
  std::size_t removed = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (interruptible && (i & 63) == 63 && cut()) break;  // what was removed stays removed
    b.clear();
    for (std::size_t e = pointStart_[i]; e < pointStart_[i + 1]; ++e) {
      b.idx.push_back(pointIdx_[e]);
      b.val.push_back(1.0 / pointInv_[e]);
    }
    // The bound at b_i from the corners, the FIB vectors and the points still kept but i.
    dead[i] = 1;
    double base = 0.0;
    if (upperBelowCorners(b, &base, dead.data()) <= improve_[i])
      ++removed;
    else
      dead[i] = 0;
  }
  if (removed > 0) {
    // Compact the point arrays and renumber the buckets and the hash index (their order is
    // kept, so the buckets stay sorted by improvement).
    std::vector<std::uint32_t> newIndex(n, 0);
    std::size_t w = 0, e0 = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (dead[i]) continue;
      newIndex[i] = static_cast<std::uint32_t>(w);
      const std::size_t begin = pointStart_[i], end = pointStart_[i + 1];
      for (std::size_t e = begin; e < end; ++e, ++e0) {
        pointIdx_[e0] = pointIdx_[e];
        pointInv_[e0] = pointInv_[e];
      }
      improve_[w] = improve_[i];
      pointStart_[++w] = e0;
    }
    pointStart_.resize(w + 1);
    pointIdx_.resize(e0);
    pointInv_.resize(e0);
    improve_.resize(w);
    for (auto& bucket : firstOf_) {
      if (bucket.empty()) continue;
      std::size_t k = 0;
      for (std::uint32_t i : bucket)
        if (!dead[i]) bucket[k++] = newIndex[i];
      bucket.resize(k);
    }
    for (auto it = pointIndex_.begin(); it != pointIndex_.end();) {
      auto& v = it->second;
      std::size_t k = 0;
      for (std::size_t i : v)
        if (!dead[i]) v[k++] = newIndex[i];
      v.resize(k);
      it = v.empty() ? pointIndex_.erase(it) : std::next(it);
    }
  }
  profile_.pointsPruned += removed;
  pointsPrunedAt_ = improve_.size();
  return removed;
}

void PointBasedSolver::pruneAlphas() {
  // 1. Remove pointwise-dominated vectors (never changes max_i alpha_i . b anywhere).
  // 2. Keep only vectors that were the best at some belief the search evaluated since the
  //    last pruning, or are the best at b0 (SARSOP-style pruning): the bound stays valid
  //    everywhere and unchanged at b0, it may only loosen elsewhere.
  //    A removed vector's plan is replaced by the one dominating it (`into`).
  // 3. The vectors the kept ones' plans continue with are kept too (closure over
  //    alphaChildren_): every kept vector is then at most the backup of the kept set, so the
  //    greedy policy of the written set earns its bound (SARSOP's invariant; without it the
  //    simulated value fell below the certified bound, test TheLowerBoundNeverExceedsItsOwnBackup).
  const ScopedTimer timer(profile_.pruneSeconds);
  ++profile_.prunes;
  const std::size_t n = alphaAction_.size();
  std::vector<char> keep(n, 1);
  std::vector<std::size_t> into(n);
  for (std::size_t i = 0; i < n; ++i) into[i] = i;
  for (std::size_t i = 0; i < n; ++i) {
    if (!keep[i]) continue;
    const double* ai = alpha_[i].data();
    for (std::size_t j = 0; j < n; ++j) {
      if (i == j || !keep[j]) continue;
      const double* aj = alpha_[j].data();
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
  if (options_.witnessPruning && !improve_.empty()) {
    std::vector<char> witness(n, 0);
    std::size_t atRoot = 0;
    lowerAt(b0_, &atRoot);
    witness[survivor(atRoot)] = 1;
    for (std::size_t i = 0; i < n; ++i)
      if (witness_[i]) witness[survivor(i)] = 1;
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
  std::size_t w = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (keep[i]) {
      if (w != i) {
        alpha_[w] = std::move(alpha_[i]);
        alphaAction_[w] = alphaAction_[i];
        alphaChildren_[w] = std::move(alphaChildren_[i]);
      }
      for (std::uint32_t& c : alphaChildren_[w]) c = newIndex[survivor(c)];
      ++w;
    }
  alpha_.resize(w);
  alphaAction_.resize(w);
  alphaChildren_.resize(w);
  witness_.assign(w, 0);
  prunedAt_ = w;
  ++epoch_;  // cached scores refer to the old indices
}

void PointBasedSolver::expand(const SparseBelief& b, std::size_t a) {
  // pred = T_a^T b over the support of b, then split by observation slot. States are visited
  // in increasing order, so every child is sorted.
  SparseBelief& pred = pred_;
  if (m_.isIdentityTransition(a)) {
    pred = b;
  } else {
    pred.clear();
    touched_.clear();
    for (std::size_t j = 0; j < b.size(); ++j) {
      const double bs = b.val[j];
      for (const auto& e : m_.successors(b.idx[j], a)) {
        if (!mark_[e.first]) {
          mark_[e.first] = 1;
          touched_.push_back(static_cast<std::uint32_t>(e.first));
        }
        acc_[e.first] += bs * e.second;
      }
    }
    std::sort(touched_.begin(), touched_.end());
    for (std::uint32_t s : touched_) {
      if (acc_[s] > 0.0) {
        pred.idx.push_back(s);
        pred.val.push_back(acc_[s]);
      }
      acc_[s] = 0.0;
      mark_[s] = 0;
    }
  }
  const std::size_t slots = obsOffset_[a + 1] - obsOffset_[a];
  for (std::size_t k = 0; k < slots; ++k) {
    kids_[k].clear();
    probs_[k] = 0.0;
  }
  const auto& slotOf = slotOf_[a];
  for (std::size_t j = 0; j < pred.size(); ++j) {
    const std::uint32_t s = pred.idx[j];
    for (const auto& z : m_.observationRow(s, a)) {
      const double p = pred.val[j] * z.second;
      if (!(p > 0.0)) continue;
      const std::size_t k = slotOf[z.first];
      kids_[k].idx.push_back(s);
      kids_[k].val.push_back(p);
      probs_[k] += p;
    }
  }
}

void PointBasedSolver::upperBackup(const SparseBelief& b, NodeCache& c) {
  // Q_U(b, a) = R(b, a) + gamma sum_o P(o | b, a) U(b_ao), caching P and U per (a, o) so that
  // the way back up a trial only re-evaluates the child that the trial visited (a cached U
  // was a valid upper bound when computed and bounds only decrease, so it stays valid).
  const ScopedTimer timer(profile_.upperBackupSeconds);
  ++profile_.upperBackups;
  c.q.resize(a_);
  c.p.resize(obsOffset_.back());
  c.u.resize(obsOffset_.back());
  for (std::size_t a = 0; a < a_; ++a) {
    expand(b, a);
    double qU = rewardAt(b, a);
    for (std::size_t k = 0; k < obsOffset_[a + 1] - obsOffset_[a]; ++k) {
      const double p = probs_[k];
      double u = 0.0;
      if (p > 0.0 && !toTerminal_[a]) {  // terminal successors are worth exactly 0
        for (double& v : kids_[k].val) v /= p;
        u = upperAt(kids_[k]);
        qU += gamma_ * p * u;
      }
      c.p[obsOffset_[a] + k] = p;
      c.u[obsOffset_[a] + k] = u;
    }
    c.q[a] = qU;
  }
  finishUpper(b, c);
}

void PointBasedSolver::finishUpper(const SparseBelief& b, NodeCache& c) {
  double best = -kInf;
  for (std::size_t a = 0; a < a_; ++a)
    if (c.q[a] > best) {
      best = c.q[a];
      c.action = a;
    }
  if (best < upperAt(b) - 1e-12) addPoint(b, best);
}

void PointBasedSolver::refreshUpper(const SparseBelief& b, NodeCache& c, std::size_t a,
                                    std::size_t k, const SparseBelief& child) {
  const std::size_t idx = obsOffset_[a] + k;
  if (!toTerminal_[a]) c.u[idx] = std::min(c.u[idx], upperAt(child));
  double qU = rewardAt(b, a);
  for (std::size_t j = obsOffset_[a]; j < obsOffset_[a + 1]; ++j) qU += gamma_ * c.p[j] * c.u[j];
  c.q[a] = std::min(c.q[a], qU);
  finishUpper(b, c);
}

std::size_t PointBasedSolver::lowerNode(const SparseBelief& b) {
  // max_i alpha_i . x for x = b and for every unnormalised child b_ao, over the vectors added
  // since the node was last scored (vectors are only appended between prunings, so the best
  // of the older ones is still the best of them: the result is the same as a full scan).
  // Children of different actions often share their support (RockSample: every check stays on
  // b's support), so they are scored together: each vector's entries on a support are read
  // once per scan, not once per child.
  const std::uint64_t key = beliefKey(b);
  std::size_t id = kNoPoint;
  auto it = lowerIndex_.find(key);
  if (it != lowerIndex_.end())
    for (std::size_t c : it->second)
      if (lowerNodes_[c].b.idx == b.idx && lowerNodes_[c].b.val == b.val) id = c;
  if (id == kNoPoint) {
    id = lowerNodes_.size();
    lowerNodes_.emplace_back();
    lowerNodes_[id].b = b;
    lowerIndex_[key].push_back(id);
    lowerNodeBytes_ += b.size() * 12 + obsOffset_.back() * 12 + sizeof(LowerNode) + 16;
  }
  const std::size_t n = alphaAction_.size();
  {
    LowerNode& nd = lowerNodes_[id];
    if (nd.epoch != epoch_ || nd.best.empty()) {
      nd.epoch = epoch_;
      nd.checked = 0;
      nd.self = -kInf;
      nd.selfArg = 0;
      nd.best.assign(obsOffset_.back(), -kInf);
      nd.arg.assign(obsOffset_.back(), 0);
    }
    if (nd.checked >= n) return id;
  }
  std::size_t nk = 0;
  auto pooled = [&]() -> PooledChild& {
    if (pool_.size() <= nk) pool_.emplace_back();
    return pool_[nk++];
  };
  {
    PooledChild& self = pooled();
    self.kid = b;
    self.slot = kNoPoint;
  }
  for (std::size_t a = 0; a < a_; ++a) {
    expand(b, a);
    for (std::size_t k = 0; k < obsOffset_[a + 1] - obsOffset_[a]; ++k) {
      if (!(probs_[k] > 0.0)) {  // a zero-probability observation may take any vector
        lowerNodes_[id].best[obsOffset_[a] + k] = 0.0;
        continue;
      }
      PooledChild& c = pooled();
      c.kid.idx.swap(kids_[k].idx);
      c.kid.val.swap(kids_[k].val);
      c.slot = obsOffset_[a] + k;
    }
  }
  LowerNode& nd = lowerNodes_[id];
  // Group the children by support.
  groupOf_.assign(nk, 0);
  std::vector<std::size_t>& heads = groupHeads_;
  heads.clear();
  for (std::size_t t = 0; t < nk; ++t) {
    const auto& idx = pool_[t].kid.idx;
    std::size_t g = 0;
    for (; g < heads.size(); ++g)
      if (pool_[heads[g]].kid.idx == idx) break;
    if (g == heads.size()) heads.push_back(t);
    groupOf_[t] = g;
  }
  std::vector<std::size_t>& members = members_;
  for (std::size_t g = 0; g < heads.size(); ++g) {
    members.clear();
    for (std::size_t t = 0; t < nk; ++t)
      if (groupOf_[t] == g) members.push_back(t);
    const auto& idx = pool_[heads[g]].kid.idx;
    const std::size_t m = idx.size(), mm = members.size();
    gather_.resize(m);
    scores_.resize(mm);
    args_.resize(mm);
    for (std::size_t r = 0; r < mm; ++r) {
      const std::size_t slot = pool_[members[r]].slot;
      scores_[r] = slot == kNoPoint ? nd.self : nd.best[slot];
      args_[r] = slot == kNoPoint ? nd.selfArg : nd.arg[slot];
    }
    for (std::size_t i = nd.checked; i < n; ++i) {
      const double* al = alpha_[i].data();
      for (std::size_t j = 0; j < m; ++j) gather_[j] = al[idx[j]];
      for (std::size_t r = 0; r < mm; ++r) {
        const double* w = pool_[members[r]].kid.val.data();
        double v0 = 0.0, v1 = 0.0, v2 = 0.0, v3 = 0.0;
        std::size_t j = 0;
        for (; j + 3 < m; j += 4) {
          v0 += gather_[j] * w[j];
          v1 += gather_[j + 1] * w[j + 1];
          v2 += gather_[j + 2] * w[j + 2];
          v3 += gather_[j + 3] * w[j + 3];
        }
        for (; j < m; ++j) v0 += gather_[j] * w[j];
        const double v = (v0 + v1) + (v2 + v3);
        if (v > scores_[r]) {
          scores_[r] = v;
          args_[r] = i;
        }
      }
    }
    for (std::size_t r = 0; r < mm; ++r) {
      const std::size_t slot = pool_[members[r]].slot;
      if (slot == kNoPoint) {
        nd.self = scores_[r];
        nd.selfArg = args_[r];
      } else {
        nd.best[slot] = scores_[r];
        nd.arg[slot] = static_cast<std::uint32_t>(args_[r]);
      }
      witness_[args_[r]] = 1;
    }
  }
  nd.checked = n;
  return id;
}

void PointBasedSolver::lowerBackup(const SparseBelief& b) {
  // alpha_a = R_a + gamma T_a sum_o (O_ao .* alpha_{k(o)}), alpha_{k(o)} best at b_ao: the
  // value of the plan "do a, then follow the vector chosen for the observation". The action is
  // chosen by its value at b, R(b, a) + gamma sum_o max_i alpha_i . (unnormalised b_ao), from
  // the node's cached scores; only the winner's vector is built over all S states.
  const ScopedTimer timer(profile_.lowerBackupSeconds);
  ++profile_.lowerBackups;
  const LowerNode& nd = lowerNodes_[lowerNode(b)];
  double bestQ = -kInf;
  std::size_t bestA = 0;
  for (std::size_t a = 0; a < a_; ++a) {
    double q = rewardAt(b, a);
    for (std::size_t j = obsOffset_[a]; j < obsOffset_[a + 1]; ++j) q += gamma_ * nd.best[j];
    if (q > bestQ) {
      bestQ = q;
      bestA = a;
    }
  }
  const std::size_t a = bestA;
  bestChildren_.assign(nd.arg.begin() + static_cast<long>(obsOffset_[a]),
                       nd.arg.begin() + static_cast<long>(obsOffset_[a + 1]));
  const double current = nd.self;
  // The vector of the best action: acc(s1) = sum_o O(o | s1, a) alpha_{k(o)}(s1).
  const auto& slotOf = slotOf_[a];
  for (std::size_t s = 0; s < s_; ++s) {
    double x = 0.0;
    for (const auto& z : m_.observationRow(s, a))
      x += z.second * alpha_[bestChildren_[slotOf[z.first]]][s];
    accVec_(static_cast<Eigen::Index>(s)) = x;
  }
  m_.expectNext(a, accVec_, nextVec_);
  candidate_ = m_.rewardMatrix().col(static_cast<Eigen::Index>(a)) + gamma_ * nextVec_;
  double value = 0.0;
  for (std::size_t j = 0; j < b.size(); ++j)
    value += candidate_(static_cast<Eigen::Index>(b.idx[j])) * b.val[j];
  if (value > current + 1e-12) addAlpha(candidate_.data(), a, bestChildren_);
  if (alphaAction_.size() > 2 * prunedAt_ + 32) pruneAlphas();
}

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
  // SARSOP's upper target: the value U(b) must come down to for the parent's target to be met
  // (at the root: L(b0) + eps). A node whose best Q_U is already at its target stops the trial,
  // even if its own gap is still above thr / gamma^depth.
  double targetU = -kInf;
  std::vector<std::size_t>& chosenObs = chosenObs_;
  chosenObs.clear();
  // A belief whose gap is within its precision is never expanded: the trial only descends
  // into a child whose gap (cached U minus the node's cached lower score) exceeds the child's
  // precision, and stops below at a node whose gap its own backup closed.
  while (true) {
    const SparseBelief& bd = path_[depth];
    NodeCache& c = cache_[depth];
    upperBackup(bd, c);
    const std::size_t a = c.action;
    const std::size_t node = lowerNode(bd);
    const double gap = upperAt(bd) - lowerNodes_[node].self;
    if (gap <= thr || depth + 1 >= options_.maxDepth || cut()) break;
    const double curTargetU = std::max(targetU, lowerNodes_[node].self + thr);
    if (c.q[a] <= curTargetU) break;
    // A node whose weighted gap is a negligible share of the root gap cannot move the root.
    if (weight * gap < cutoffScale_ * options_.trialWeightCutoff * rootGap) break;
    const ScopedTimer timer(profile_.sampleSeconds);
    const double childThr = thr / gamma_;
    double bestScore = 0.0;
    const std::size_t slots = obsOffset_[a + 1] - obsOffset_[a];
    std::size_t bestK = slots;
    expand(bd, a);
    for (std::size_t k = 0; k < slots; ++k) {
      const double p = probs_[k];
      if (!(p > 0.0)) continue;
      // L(b_ao) = (max_i alpha_i . unnormalised child) / p, from the node's cache.
      const double lower = lowerNodes_[node].best[obsOffset_[a] + k] / p;
      const double score = p * (c.u[obsOffset_[a] + k] - lower - childThr);
      if (score > bestScore) {
        bestScore = score;
        bestK = k;
      }
    }
    if (bestK == slots) break;
    const double pChosen = c.p[obsOffset_[a] + bestK];  // before cache_ may reallocate
    double others = 0.0;  // gamma-free sum over the other observations of P(o) U(b_ao)
    for (std::size_t k = 0; k < slots; ++k)
      if (k != bestK) others += c.p[obsOffset_[a] + k] * c.u[obsOffset_[a] + k];
    targetU = ((curTargetU - rewardAt(bd, a)) / gamma_ - others) / pChosen;
    weight *= gamma_ * pChosen;
    if (path_.size() < depth + 2) {
      path_.emplace_back();
      cache_.emplace_back();
    }
    path_[depth + 1] = kids_[bestK];
    for (double& v : path_[depth + 1].val) v /= pChosen;
    chosenObs.push_back(bestK);
    ++depth;
    thr = childThr;
  }
  profile_.depthSum += depth;
  profile_.maxDepth = std::max(profile_.maxDepth, depth);
  // Backups are optional for the bounds' validity: past the deadline, the rest are skipped,
  // so that a deep trial cannot overrun the budget by its own length.
  lowerBackup(path_[depth]);
  for (std::size_t d = depth; d-- > 0;) {
    if (cut()) break;
    NodeCache& c = cache_[d];
    refreshUpper(path_[d], c, c.action, chosenObs[d], path_[d + 1]);
    lowerBackup(path_[d]);
  }
  ++trials_;
  // Point pruning when the set has doubled since the last one: amortised, each point is
  // checked a constant number of times on average.
  if (options_.pointPruning && options_.sawtooth && !cut() &&
      improve_.size() >= 2 * pointsPrunedAt_ + 64)
    prunePointsUntil(true);
  const double lowerBefore = rootLower_;
  rootLower_ = std::max(rootLower_, lowerAt(b0_));
  rootUpper_ = std::min(rootUpper_, upperAt(b0_));
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

bool PointBasedSolver::runUntil(double untilSeconds, double cutSeconds) {
  cutAt_ = std::max(untilSeconds, cutSeconds);
  runTrials(clock_, untilSeconds, options_.maxTrials, trials_,
            [this] { return converged() || memoryStop_; }, [this] { trial(); });
  return converged();
}

bool PointBasedSolver::converged() const {
  return rootUpper_ - rootLower_ <= options_.precision;
}

BoundsReport PointBasedSolver::report() const {
  BoundsReport r;
  r.time = clock_.elapsed();
  r.lower = rootLower_;
  r.upper = rootUpper_;
  r.alphas = alphaAction_.size();
  r.points = improve_.size();
  r.trials = trials_;
  r.bytes = boundBytes();
  return r;
}

AlphaVectorPolicy PointBasedSolver::policy() const {
  AlphaVectorPolicy p(s_);
  for (std::size_t i = 0; i < alphaAction_.size(); ++i)
    p.add(Eigen::Map<const Eigen::VectorXd>(alpha_[i].data(), static_cast<Eigen::Index>(s_)),
          alphaAction_[i]);
  return p;
}

}  // namespace pomdp
}  // namespace krr
