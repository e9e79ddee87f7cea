#include "krr_core/pomdp/turn_limited_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"

namespace krr {
namespace pomdp {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kImprove = 1e-12;  // smallest bound change worth recording

}  // namespace

TurnLimitedSolver::TurnLimitedSolver(const Model& model, const Belief& b0, int turnLimit,
                                     TurnLimitedSolverOptions options)
    : m_(model), options_(options), s_(model.getS()), a_(model.getA()), limit_(turnLimit),
      gamma_(model.getDiscount()), b0_(b0) {
  if (turnLimit < 0)
    throw ConfigError("turn-limited solver: turn limit " + std::to_string(turnLimit) + " < 0");
  if (!(gamma_ > 0.0 && gamma_ <= 1.0))
    throw ConfigError("turn-limited solver: discount " + std::to_string(gamma_) +
                      " outside (0, 1]");
  if (static_cast<std::size_t>(b0.size()) != s_)
    throw ConfigError("turn-limited solver: initial belief has " + std::to_string(b0.size()) +
                      " entries, model has " + std::to_string(s_) + " states");
  if (!b0.allFinite() || b0.minCoeff() < 0.0 || std::abs(b0.sum() - 1.0) > Model::kTolerance)
    throw ConfigError("turn-limited solver: initial belief is not a distribution (sum " +
                      std::to_string(b0.sum()) + ")");
  if (!(options_.precision > 0.0) || !(options_.timeout >= 0.0) ||
      !(options_.trialGapFactor > 0.0 && options_.trialGapFactor <= 1.0))
    throw ConfigError("turn-limited solver: precision must be > 0, timeout >= 0 and the trial "
                      "gap factor in (0, 1]");
  ending_.assign(a_, 0);
  slotOffset_.assign(a_ + 1, 0);
  obsCol_.resize(a_);
  for (std::size_t a = 0; a < a_; ++a) {
    bool ends = true;
    for (std::size_t s = 0; s < s_ && ends; ++s)
      for (const auto& e : m_.successors(s, a)) ends = ends && m_.isTerminal(e.first);
    ending_[a] = ends ? 1 : 0;
    if (!ends) {
      continuing_.push_back(a);
      for (std::size_t o : m_.possibleObservations(a))
        obsCol_[a].push_back(m_.observationColumn(a, o));
    }
    slotOffset_[a + 1] = slotOffset_[a] + obsCol_[a].size();
  }
  if (continuing_.size() == a_)
    throw ConfigError("turn-limited solver: no action ends the episode (an action whose "
                      "successors are all terminal states), so the turn limit cannot be met");
  const auto n = static_cast<Eigen::Index>(s_);
  pred_.resize(n);
  child_.resize(n);
  acc_.resize(n);
  candidate_.resize(n);
  best_.resize(n);
  Stopwatch sw;
  initBounds();
  rootLower_ = lowerRaw(b0_.data(), 0);
  rootUpper_ = upperRaw(b0_.data(), 0);
  clock_.setElapsed(sw.seconds());
}

void TurnLimitedSolver::initBounds() {
  const auto& r = m_.rewardMatrix();
  stages_.assign(static_cast<std::size_t>(limit_) + 1, Stage());
  // Turn L: only the ending actions, whose values are exactly their rewards.
  for (std::size_t a = 0; a < a_; ++a)
    if (ending_[a]) addAlpha(limit_, r.col(static_cast<Eigen::Index>(a)), a);
  // Finite-horizon fast informed bound, backwards from turn L:
  //   Q_t(s, a) = R(s, a) for ending actions,
  //   Q_t(s, a) = R(s, a) + gamma sum_o max_a' sum_s' T(s, a, s') Z(s', a, o) Q_{t+1}(s', a').
  const auto S = static_cast<Eigen::Index>(s_), A = static_cast<Eigen::Index>(a_);
  Eigen::MatrixXd next = Eigen::MatrixXd::Constant(S, A, -kInf);
  for (std::size_t a = 0; a < a_; ++a)
    if (ending_[a]) next.col(static_cast<Eigen::Index>(a)) = r.col(static_cast<Eigen::Index>(a));
  std::vector<char> allowedNext(ending_);  // actions allowed at turn t + 1
  for (int t = limit_ - 1; t >= 0; --t) {
    Eigen::MatrixXd q = Eigen::MatrixXd::Constant(S, A, -kInf);
    for (std::size_t a = 0; a < a_; ++a) {
      const auto ai = static_cast<Eigen::Index>(a);
      if (ending_[a]) {
        q.col(ai) = r.col(ai);
        continue;
      }
      const Eigen::MatrixXd z = m_.denseObservation(a);  // dialog-size models only
      for (std::size_t s = 0; s < s_; ++s) {
        double val = r(static_cast<Eigen::Index>(s), ai);
        for (std::size_t o : m_.possibleObservations(a)) {
          double best = -kInf;
          for (std::size_t a2 = 0; a2 < a_; ++a2) {
            if (!allowedNext[a2]) continue;
            double sum = 0.0;
            for (const auto& e : m_.successors(s, a))
              sum += e.second * z(static_cast<Eigen::Index>(e.first), static_cast<Eigen::Index>(o)) *
                     next(static_cast<Eigen::Index>(e.first), static_cast<Eigen::Index>(a2));
            best = std::max(best, sum);
          }
          val += gamma_ * best;
        }
        q(static_cast<Eigen::Index>(s), ai) = val;
      }
    }
    for (std::size_t s = 0; s < s_; ++s)
      if (m_.isTerminal(s)) q.row(static_cast<Eigen::Index>(s)).setZero();
    // Rounding margin: the corners and FIB vectors must stay upper bounds.
    q.array() += 1e-9 * (1.0 + q.cwiseAbs().maxCoeff());
    for (std::size_t s = 0; s < s_; ++s)
      if (m_.isTerminal(s)) q.row(static_cast<Eigen::Index>(s)).setZero();
    Stage& st = stages_[static_cast<std::size_t>(t)];
    st.corner = q.rowwise().maxCoeff();
    std::vector<Eigen::Index> kept;  // FIB action vectors that no other one dominates
    for (Eigen::Index a = 0; a < A; ++a) {
      bool dominated = false;
      for (Eigen::Index a2 = 0; a2 < A && !dominated; ++a2)
        dominated = a2 != a && (q.col(a).array() <= q.col(a2).array()).all() &&
                    ((q.col(a).array() < q.col(a2).array()).any() || a2 < a);
      if (!dominated) kept.push_back(a);
    }
    st.fib.resize(static_cast<Eigen::Index>(kept.size()), S);
    for (std::size_t k = 0; k < kept.size(); ++k)
      st.fib.row(static_cast<Eigen::Index>(k)) = q.col(kept[k]).transpose();
    next = q;
    allowedNext.assign(a_, 1);
  }
}

double TurnLimitedSolver::lowerRaw(const double* b, int t) const {
  double best = -kInf;
  for (int k = std::clamp(t, 0, limit_); k <= limit_; ++k) {
    const Stage& st = stages_[static_cast<std::size_t>(k)];
    const std::size_t n = st.action.size();
    for (std::size_t i = 0; i < n; ++i) {
      const double* al = &st.alpha[i * s_];
      double v = 0.0;
      for (std::size_t s = 0; s < s_; ++s) v += al[s] * b[s];
      best = std::max(best, v);
    }
  }
  return best;
}

double TurnLimitedSolver::upperRaw(const double* b, int t) const {
  if (t >= limit_) return lowerRaw(b, limit_);  // exact at the limit
  const Stage& st = stages_[static_cast<std::size_t>(std::max(t, 0))];
  Eigen::Map<const Eigen::VectorXd> bm(b, static_cast<Eigen::Index>(s_));
  const double base = st.corner.dot(bm);
  double best = std::min(0.0, (st.fib * bm).maxCoeff() - base);
  // Sawtooth: point i lowers the corner interpolation by improve_i * min_s b(s) / b_i(s)
  // (over b_i's support). Points come most improving first; none later can beat `best`
  // once improve_i >= best.
  for (std::size_t i : st.order) {
    const double imp = st.improve[i];
    if (imp >= best) break;
    const double* iv = &st.inv[i * s_];
    double ratio = 1.0;
    for (std::size_t s = 0; s < s_; ++s)
      if (iv[s] > 0.0) ratio = std::min(ratio, b[s] * iv[s]);
    best = std::min(best, imp * ratio);
  }
  double u = base + best;
  if (extra_) u = std::min(u, extra_(bm, t));
  return u;
}

void TurnLimitedSolver::setExtraUpper(ExtraUpper f) {
  extra_ = std::move(f);
  rootUpper_ = std::min(rootUpper_, upperRaw(b0_.data(), 0));
}

double TurnLimitedSolver::lowerBound(const Belief& b, int turns) const {
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("lowerBound: belief size " + std::to_string(b.size()));
  return lowerRaw(b.data(), turns);
}

double TurnLimitedSolver::upperBound(const Belief& b, int turns) const {
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("upperBound: belief size " + std::to_string(b.size()));
  return upperRaw(b.data(), std::max(turns, 0));
}

void TurnLimitedSolver::addAlpha(int t, const Eigen::VectorXd& alpha, std::size_t action) {
  // Safe pruning only: a vector is dropped when the new one is at least as good everywhere
  // and usable at least as long (stage <= t), so the greedy policy keeps every guarantee.
  const double* a = alpha.data();
  for (int k = 0; k <= t && k < limit_; ++k) {
    Stage& st = stages_[static_cast<std::size_t>(k)];
    std::size_t kept = 0;
    for (std::size_t i = 0; i < st.action.size(); ++i) {
      const double* v = &st.alpha[i * s_];
      bool dominated = true;
      for (std::size_t s = 0; s < s_ && dominated; ++s) dominated = v[s] <= a[s];
      if (dominated) continue;
      if (kept != i) {
        std::copy(v, v + s_, &st.alpha[kept * s_]);
        st.action[kept] = st.action[i];
      }
      ++kept;
    }
    st.alpha.resize(kept * s_);
    st.action.resize(kept);
  }
  Stage& st = stages_[static_cast<std::size_t>(t)];
  st.alpha.insert(st.alpha.end(), a, a + s_);
  st.action.push_back(action);
}

std::uint64_t TurnLimitedSolver::beliefKey(const double* b) const {
  std::uint64_t h = 0x9e3779b97f4a7c15ULL;
  for (std::size_t s = 0; s < s_; ++s)
    h = splitMix64(h ^ static_cast<std::uint64_t>(std::llround(b[s] * 1e9)));
  return h;
}

std::size_t TurnLimitedSolver::findPoint(const Stage& st, std::uint64_t key,
                                         const double* b) const {
  auto it = st.index.find(key);
  if (it == st.index.end()) return static_cast<std::size_t>(-1);
  for (std::size_t i : it->second) {
    const double* p = &st.point[i * s_];
    bool same = true;
    for (std::size_t s = 0; s < s_ && same; ++s) same = std::abs(p[s] - b[s]) < 1e-12;
    if (same) return i;
  }
  return static_cast<std::size_t>(-1);
}

void TurnLimitedSolver::addPoint(int t, const Eigen::VectorXd& b, double v) {
  Stage& st = stages_[static_cast<std::size_t>(t)];
  const double imp = v - st.corner.dot(b);
  if (!(imp < 0.0)) return;  // the corners already give this value
  auto insertOrdered = [&st](std::size_t i) {
    auto pos = std::lower_bound(st.order.begin(), st.order.end(), st.improve[i],
                                [&st](std::size_t k, double x) { return st.improve[k] < x; });
    st.order.insert(pos, i);
  };
  const std::uint64_t key = beliefKey(b.data());
  const std::size_t found = findPoint(st, key, b.data());
  if (found != static_cast<std::size_t>(-1)) {
    if (imp < st.improve[found]) {
      st.order.erase(std::find(st.order.begin(), st.order.end(), found));
      st.improve[found] = imp;
      insertOrdered(found);
    }
    return;
  }
  st.index[key].push_back(st.improve.size());
  st.point.insert(st.point.end(), b.data(), b.data() + s_);
  for (std::size_t s = 0; s < s_; ++s) {
    const double x = b(static_cast<Eigen::Index>(s));
    st.inv.push_back(x > 0.0 ? 1.0 / x : 0.0);
  }
  st.improve.push_back(imp);
  insertOrdered(st.improve.size() - 1);
}

void TurnLimitedSolver::predict(const Eigen::VectorXd& b, std::size_t a, Eigen::VectorXd& out) const {
  if (m_.isIdentityTransition(a)) out = b;
  else m_.predict(a, b, out);
}

void TurnLimitedSolver::upperBackup(const Eigen::VectorXd& b, int t, NodeCache& c) {
  // Q_U(b, a) = R(b, a) + gamma sum_o P(o | b, a) U_{t+1}(b_ao); P and U are cached per slot
  // so the way back up a trial re-evaluates only the child it visited (a cached U was an
  // upper bound when computed and bounds only decrease).
  const auto& r = m_.rewardMatrix();
  c.q.assign(a_, 0.0);
  c.p.assign(slotOffset_.back(), 0.0);
  c.u.assign(slotOffset_.back(), 0.0);
  for (std::size_t a = 0; a < a_; ++a) {
    double q = r.col(static_cast<Eigen::Index>(a)).dot(b);
    if (!ending_[a]) {
      predict(b, a, pred_);
      for (std::size_t k = 0; k < obsCol_[a].size(); ++k) {
        child_ = obsCol_[a][k].cwiseProduct(pred_);
        const double p = child_.sum();
        double u = 0.0;
        if (p > 0.0) {
          child_ /= p;
          if (refine_) refine_(child_, t + 1);
          u = upperRaw(child_.data(), t + 1);
          q += gamma_ * p * u;
        }
        c.p[slotOffset_[a] + k] = p;
        c.u[slotOffset_[a] + k] = u;
      }
    }
    c.q[a] = q;
  }
  finishUpper(b, t, c);
}

void TurnLimitedSolver::finishUpper(const Eigen::VectorXd& b, int t, NodeCache& c) {
  double best = -kInf;
  for (std::size_t a = 0; a < a_; ++a)
    if (c.q[a] > best) {
      best = c.q[a];
      c.action = a;
    }
  if (best < upperRaw(b.data(), t) - kImprove) addPoint(t, b, best);
}

void TurnLimitedSolver::refreshUpper(const Eigen::VectorXd& b, int t, NodeCache& c, std::size_t k,
                                     const Eigen::VectorXd& child) {
  const std::size_t a = c.action;
  const std::size_t slot = slotOffset_[a] + k;
  c.u[slot] = std::min(c.u[slot], upperRaw(child.data(), t + 1));
  double q = m_.rewardMatrix().col(static_cast<Eigen::Index>(a)).dot(b);
  for (std::size_t j = slotOffset_[a]; j < slotOffset_[a + 1]; ++j) q += gamma_ * c.p[j] * c.u[j];
  c.q[a] = std::min(c.q[a], q);
  finishUpper(b, t, c);
}

void TurnLimitedSolver::lowerBackup(const Eigen::VectorXd& b, int t) {
  // alpha = R_a + gamma T_a sum_o (Z_ao .* alpha_o), alpha_o the best vector usable at turn
  // t + 1 at b_ao: the value of "do a, then follow the greedy policy". Scores of all vectors
  // usable at t + 1 against all children come from one product per stage (unnormalised
  // children give the same argmax).
  if (t >= limit_) return;  // the ending vectors are exact
  const auto S = static_cast<Eigen::Index>(s_);
  const std::size_t slots = slotOffset_.back();
  children_.resize(S, static_cast<Eigen::Index>(slots));
  for (std::size_t a : continuing_) {
    predict(b, a, pred_);
    for (std::size_t k = 0; k < obsCol_[a].size(); ++k)
      children_.col(static_cast<Eigen::Index>(slotOffset_[a] + k)) = obsCol_[a][k].cwiseProduct(pred_);
  }
  std::vector<double> bestScore(slots, -kInf);
  std::vector<const double*> bestVec(slots, nullptr);
  for (int k = t + 1; k <= limit_; ++k) {
    const Stage& st = stages_[static_cast<std::size_t>(k)];
    const auto n = static_cast<Eigen::Index>(st.action.size());
    if (n == 0) continue;
    Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
        alphas(st.alpha.data(), n, S);
    const Eigen::MatrixXd scores = alphas * children_;
    for (std::size_t j = 0; j < slots; ++j) {
      Eigen::Index i = 0;
      const double v = scores.col(static_cast<Eigen::Index>(j)).maxCoeff(&i);
      if (v > bestScore[j]) {
        bestScore[j] = v;
        bestVec[j] = &st.alpha[static_cast<std::size_t>(i) * s_];
      }
    }
  }
  const auto& r = m_.rewardMatrix();
  double bestValue = -kInf;
  std::size_t bestAction = 0;
  for (std::size_t a : continuing_) {
    acc_.setZero();
    for (std::size_t k = 0; k < obsCol_[a].size(); ++k)
      acc_ += obsCol_[a][k].cwiseProduct(
          Eigen::Map<const Eigen::VectorXd>(bestVec[slotOffset_[a] + k], S));
    candidate_ = r.col(static_cast<Eigen::Index>(a));
    if (m_.isIdentityTransition(a)) candidate_ += gamma_ * acc_;
    else if (m_.hasDenseTransitions())
      candidate_.noalias() += gamma_ * (m_.transitionMatrix(a) * acc_);
    else {
      m_.expectNext(a, acc_, child_);
      candidate_ += gamma_ * child_;
    }
    const double v = candidate_.dot(b);
    if (v > bestValue) {
      bestValue = v;
      bestAction = a;
      best_.swap(candidate_);
    }
  }
  if (bestValue > lowerRaw(b.data(), t) + kImprove) addAlpha(t, best_, bestAction);
}

void TurnLimitedSolver::trial() {
  const bool lowerGuided =
      options_.lowerGuidedEvery > 0 && trials_ % options_.lowerGuidedEvery == options_.lowerGuidedEvery - 1;
  trialFrom(b0_, 0, std::max(options_.precision, options_.trialGapFactor * (rootUpper_ - rootLower_)),
            lowerGuided);
  ++trials_;
  rootLower_ = std::max(rootLower_, lowerRaw(b0_.data(), 0));
  rootUpper_ = std::min(rootUpper_, upperRaw(b0_.data(), 0));
}

double TurnLimitedSolver::improveAt(const Belief& b, int turns, double precision,
                                    std::size_t maxTrials) {
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("improveAt: belief size " + std::to_string(b.size()));
  const int t0 = std::clamp(turns, 0, limit_);
  double gap = upperRaw(b.data(), t0) - lowerRaw(b.data(), t0);
  if (gap <= precision || maxTrials == 0) return gap;
  const double savedDeadline = clock_.deadline();
  clock_.start(std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < maxTrials && gap > precision; ++k) {
    trialFrom(b, t0, std::max(precision, options_.trialGapFactor * gap));
    gap = upperRaw(b.data(), t0) - lowerRaw(b.data(), t0);
  }
  clock_.stop();
  clock_.setDeadline(savedDeadline);
  rootLower_ = std::max(rootLower_, lowerRaw(b0_.data(), 0));
  rootUpper_ = std::min(rootUpper_, upperRaw(b0_.data(), 0));
  return gap;
}

std::size_t TurnLimitedSolver::lowerGreedy(const Eigen::VectorXd& b, int t, const NodeCache& c) {
  const auto& r = m_.rewardMatrix();
  double best = -kInf;
  std::size_t arg = 0;
  for (std::size_t a = 0; a < a_; ++a) {
    double q = r.col(static_cast<Eigen::Index>(a)).dot(b);
    if (!ending_[a]) {
      predict(b, a, pred_);
      for (std::size_t k = 0; k < obsCol_[a].size(); ++k) {
        const double p = c.p[slotOffset_[a] + k];
        if (!(p > 0.0)) continue;
        child_ = obsCol_[a][k].cwiseProduct(pred_) / p;
        q += gamma_ * p * lowerRaw(child_.data(), t + 1);
      }
    }
    if (q > best) {
      best = q;
      arg = a;
    }
  }
  return arg;
}

void TurnLimitedSolver::trialFrom(const Eigen::VectorXd& root, int t0, double thr, bool lowerGuided) {
  const auto depthMax = static_cast<std::size_t>(limit_) + 1;
  if (path_.size() < depthMax) {
    path_.resize(depthMax);
    cache_.resize(depthMax);
  }
  path_[static_cast<std::size_t>(t0)] = root;
  chosen_.assign(depthMax, 0);
  int t = t0;
  while (t < limit_) {
    NodeCache& c = cache_[static_cast<std::size_t>(t)];
    const Eigen::VectorXd& b = path_[static_cast<std::size_t>(t)];
    upperBackup(b, t, c);
    if (lowerGuided) c.action = lowerGreedy(b, t, c);
    const std::size_t a = c.action;
    const double gap = upperRaw(b.data(), t) - lowerRaw(b.data(), t);
    if (gap <= thr || ending_[a] || clock_.expired()) break;
    const double childThr = thr / gamma_;
    double bestScore = 0.0;
    std::size_t bestK = obsCol_[a].size();
    predict(b, a, pred_);
    for (std::size_t k = 0; k < obsCol_[a].size(); ++k) {
      const double p = c.p[slotOffset_[a] + k];
      if (!(p > 0.0)) continue;
      child_ = obsCol_[a][k].cwiseProduct(pred_) / p;
      const double score = p * (c.u[slotOffset_[a] + k] - lowerRaw(child_.data(), t + 1) - childThr);
      if (score > bestScore) {
        bestScore = score;
        bestK = k;
      }
    }
    if (bestK == obsCol_[a].size()) break;
    path_[static_cast<std::size_t>(t) + 1] = obsCol_[a][bestK].cwiseProduct(pred_) /
                                             c.p[slotOffset_[a] + bestK];
    chosen_[static_cast<std::size_t>(t)] = bestK;
    ++t;
    thr = childThr;
  }
  lowerBackup(path_[static_cast<std::size_t>(t)], t);
  for (int d = t - 1; d >= t0; --d) {
    const auto du = static_cast<std::size_t>(d);
    refreshUpper(path_[du], d, cache_[du], chosen_[du], path_[du + 1]);
    lowerBackup(path_[du], d);
  }
}

bool TurnLimitedSolver::runUntil(double untilSeconds) {
  runTrials(clock_, untilSeconds, options_.maxTrials, trials_, [this] { return converged(); },
            [this] { trial(); });
  return converged();
}

BoundsReport TurnLimitedSolver::report() const {
  BoundsReport r;
  r.time = clock_.elapsed();
  r.lower = rootLower_;
  r.upper = rootUpper_;
  for (const Stage& st : stages_) {
    r.alphas += st.action.size();
    r.points += st.improve.size();
  }
  r.trials = trials_;
  return r;
}

TurnLimitedPolicy TurnLimitedSolver::policy() const {
  TurnLimitedPolicy p(s_, limit_);
  for (int k = 0; k <= limit_; ++k) {
    const Stage& st = stages_[static_cast<std::size_t>(k)];
    for (std::size_t i = 0; i < st.action.size(); ++i)
      p.add(Eigen::Map<const Eigen::VectorXd>(&st.alpha[i * s_], static_cast<Eigen::Index>(s_)),
            st.action[i], k);
  }
  return p;
}

}  // namespace pomdp
}  // namespace krr
