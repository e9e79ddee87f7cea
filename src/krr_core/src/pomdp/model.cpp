#include "krr_core/common/format.h"
#include "krr_core/pomdp/model.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace pomdp {

namespace {

std::string num(double v) { return formatNumber(v, 12); }

std::vector<std::string> defaultNames(const char* prefix, std::size_t n) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < n; ++i) out.push_back(prefix + std::to_string(i));
  return out;
}

std::size_t lookup(const std::vector<std::string>& names, const std::string& name,
                   const char* kind) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return i;
  throw UnknownSymbolError(std::string("unknown ") + kind + " '" + name + "'");
}

/// @brief Checks row s of a dense T[a] (isT) or O[a]: entries are probabilities (scanned only
/// when the caller's vectorised test `allOk` failed, to name the offending entry) and the row
/// sums to 1 within Model::kTolerance. @throws ConfigError naming action, state and value.
void checkDenseRow(const Eigen::MatrixXd& m, bool allOk, const Eigen::VectorXd& sums,
                   std::size_t a, std::size_t s, bool isT) {
  const auto r = static_cast<Eigen::Index>(s);
  if (!allOk)
    for (Eigen::Index k = 0; k < m.cols(); ++k)
      if (!(m(r, k) >= 0.0 && m(r, k) <= 1.0 + Model::kTolerance))
        throw ConfigError(std::string("POMDP model: ") + (isT ? "T(action " : "O(action ") +
                          std::to_string(a) + (isT ? ", state " : ", next state ") +
                          std::to_string(s) + (isT ? ", next " : ", obs ") + std::to_string(k) +
                          ") = " + num(m(r, k)) + " is not a probability");
  const double sum = sums(r);
  if (std::abs(sum - 1.0) > Model::kTolerance)
    throw ConfigError(std::string("POMDP model: ") + (isT ? "transition" : "observation") +
                      " row of action " + std::to_string(a) + (isT ? ", state " : ", next state ") +
                      std::to_string(s) + " sums to " + num(sum) + " (expected 1)");
}

}  // namespace

Model::Model(std::vector<Eigen::MatrixXd> transitions, std::vector<Eigen::MatrixXd> observations,
             Eigen::MatrixXd rewards, double discount, double timeLimit, ModelStorage storage)
    : discount_(discount), t_(std::move(transitions)), z_(std::move(observations)),
      r_(std::move(rewards)) {
  const Stopwatch clock;
  auto checkTime = [&]() {
    if (timeLimit > 0.0 && clock.seconds() > timeLimit)
      throw ConfigError("POMDP model: construction stopped at its time limit of " +
                        num(timeLimit) + " s");
  };
  a_ = t_.size();
  if (a_ == 0) throw ConfigError("POMDP model: no actions");
  s_ = static_cast<std::size_t>(t_[0].rows());
  if (s_ == 0) throw ConfigError("POMDP model: no states");
  if (z_.size() != a_)
    throw ConfigError("POMDP model: " + std::to_string(z_.size()) +
                      " observation matrices for " + std::to_string(a_) + " actions");
  o_ = static_cast<std::size_t>(z_[0].cols());
  checkSizesAndRewards(discount);
  for (std::size_t a = 0; a < a_; ++a) {
    checkTime();
    const auto& t = t_[a];
    const auto& z = z_[a];
    if (static_cast<std::size_t>(t.rows()) != s_ || static_cast<std::size_t>(t.cols()) != s_)
      throw ConfigError("POMDP model: transition matrix of action " + std::to_string(a) +
                        " is " + std::to_string(t.rows()) + "x" + std::to_string(t.cols()) +
                        ", expected " + std::to_string(s_) + "x" + std::to_string(s_));
    if (static_cast<std::size_t>(z.rows()) != s_ || static_cast<std::size_t>(z.cols()) != o_)
      throw ConfigError("POMDP model: observation matrix of action " + std::to_string(a) +
                        " is " + std::to_string(z.rows()) + "x" + std::to_string(z.cols()) +
                        ", expected " + std::to_string(s_) + "x" + std::to_string(o_));
    // Checked column by column (the storage order): row-order scans of a 3000-state model
    // took most of pomdp_solve's set-up time. The slow path names the offending entry.
    const bool tOk = (t.array() >= 0.0).all() && (t.array() <= 1.0 + kTolerance).all();
    const bool zOk = (z.array() >= 0.0).all() && (z.array() <= 1.0 + kTolerance).all();
    const Eigen::VectorXd tSum = t.rowwise().sum(), zSum = z.rowwise().sum();
    for (std::size_t s = 0; s < s_; ++s) {
      checkDenseRow(t, tOk, tSum, a, s, true);
      checkDenseRow(z, zOk, zSum, a, s, false);
    }
  }
  // Sparse rows of T, from the transpose's columns (contiguous), and of O.
  tt_.resize(a_);
  tRows_.assign(a_, SparseRows());
  zRows_.assign(a_, SparseRows());
  std::vector<Entry> row;
  for (std::size_t a = 0; a < a_; ++a) {
    checkTime();
    // Transposed in 64 x 64 tiles: a plain strided transpose of a 3000-state matrix misses
    // the cache on every store.
    tt_[a].resize(static_cast<Eigen::Index>(s_), static_cast<Eigen::Index>(s_));
    constexpr std::size_t kTile = 64;
    for (std::size_t c0 = 0; c0 < s_; c0 += kTile)
      for (std::size_t r0 = 0; r0 < s_; r0 += kTile) {
        const std::size_t c1 = std::min(s_, c0 + kTile), r1 = std::min(s_, r0 + kTile);
        for (std::size_t c = c0; c < c1; ++c)
          for (std::size_t r = r0; r < r1; ++r)
            tt_[a].data()[r * s_ + c] = t_[a].data()[c * s_ + r];
      }
    const Eigen::MatrixXd& tt = tt_[a];
    tRows_[a].cols = s_;
    for (std::size_t s = 0; s < s_; ++s) {
      if ((s & 255) == 255) checkTime();
      const double* col = tt.data() + s * s_;
      row.clear();
      for (std::size_t k = 0; k < s_; ++k)
        if (col[k] > 0.0) row.emplace_back(k, col[k]);
      tRows_[a].pushRow(row);
    }
    zRows_[a].cols = o_;
    for (std::size_t s = 0; s < s_; ++s) {
      row.clear();
      for (std::size_t o = 0; o < o_; ++o)
        if (z_[a](s, o) > 0.0) row.emplace_back(o, z_[a](s, o));
      zRows_[a].pushRow(row);
    }
  }
  finish(storage, timeLimit, clock.seconds());
}

Model::Model(std::vector<SparseRows> transitions, std::vector<SparseRows> observations,
             Eigen::MatrixXd rewards, double discount, double timeLimit, ModelStorage storage)
    : discount_(discount), r_(std::move(rewards)), tRows_(std::move(transitions)),
      zRows_(std::move(observations)) {
  const Stopwatch clock;
  a_ = tRows_.size();
  if (a_ == 0) throw ConfigError("POMDP model: no actions");
  s_ = tRows_[0].rows();
  if (s_ == 0) throw ConfigError("POMDP model: no states");
  if (zRows_.size() != a_)
    throw ConfigError("POMDP model: " + std::to_string(zRows_.size()) +
                      " observation tables for " + std::to_string(a_) + " actions");
  o_ = zRows_[0].cols;
  checkSizesAndRewards(discount);
  validateRows(timeLimit, 0.0);
  finish(storage, timeLimit, clock.seconds());
}

void Model::checkSizesAndRewards(double discount) const {
  if (o_ == 0) throw ConfigError("POMDP model: no observations");
  if (!(discount > 0.0 && discount <= 1.0))
    throw ConfigError("POMDP model: discount " + num(discount) + " outside (0, 1]");
  if (static_cast<std::size_t>(r_.rows()) != s_ || static_cast<std::size_t>(r_.cols()) != a_)
    throw ConfigError("POMDP model: reward matrix is " + std::to_string(r_.rows()) + "x" +
                      std::to_string(r_.cols()) + ", expected " + std::to_string(s_) + "x" +
                      std::to_string(a_) + " (states x actions)");
  if (!r_.allFinite()) throw ConfigError("POMDP model: reward matrix has non-finite entries");
  if (r_.size() > 0) {
    Eigen::Index s = 0, a = 0;
    const double worst = r_.cwiseAbs().maxCoeff(&s, &a);
    if (worst > kMaxAbsReward)
      throw ConfigError("POMDP model: reward R(s" + std::to_string(s) + ", a" +
                        std::to_string(a) + ") = " + num(r_(s, a)) + " is above the limit |R| <= " +
                        num(kMaxAbsReward) + " that keeps the bounds finite");
  }
}

void Model::validateRows(double timeLimit, double startSeconds) const {
  const Stopwatch clock;
  auto check = [&](const SparseRows& m, std::size_t a, std::size_t cols, bool isT) {
    const char* what = isT ? "transition" : "observation";
    if (m.rows() != s_ || m.cols != cols || m.start.back() != m.entries.size())
      throw ConfigError(std::string("POMDP model: ") + what + " table of action " +
                        std::to_string(a) + " is " + std::to_string(m.rows()) + "x" +
                        std::to_string(m.cols) + ", expected " + std::to_string(s_) + "x" +
                        std::to_string(cols));
    for (std::size_t s = 0; s < s_; ++s) {
      if ((s & 1023) == 1023 && timeLimit > 0.0 && startSeconds + clock.seconds() > timeLimit)
        throw ConfigError("POMDP model: construction stopped at its time limit of " +
                          num(timeLimit) + " s");
      double sum = 0.0;
      std::size_t prev = 0;
      bool first = true;
      for (const Entry& e : m.row(s)) {
        if (e.first >= cols || (!first && e.first <= prev))
          throw ConfigError(std::string("POMDP model: ") + what + " row of action " +
                            std::to_string(a) + ", state " + std::to_string(s) +
                            " has column " + std::to_string(e.first) +
                            " out of range or out of order");
        if (!(e.second >= 0.0 && e.second <= 1.0 + kTolerance))
          throw ConfigError(std::string("POMDP model: ") + (isT ? "T" : "O") + "(action " +
                            std::to_string(a) + ", " + (isT ? "state " : "next state ") +
                            std::to_string(s) + ", " + (isT ? "next " : "obs ") +
                            std::to_string(e.first) + ") = " + num(e.second) +
                            " is not a probability");
        sum += e.second;
        prev = e.first;
        first = false;
      }
      if (std::abs(sum - 1.0) > kTolerance)
        throw ConfigError(std::string("POMDP model: ") + what + " row of action " +
                          std::to_string(a) + (isT ? ", state " : ", next state ") +
                          std::to_string(s) + " sums to " + num(sum) + " (expected 1)");
    }
  };
  for (std::size_t a = 0; a < a_; ++a) {
    check(tRows_[a], a, s_, true);
    check(zRows_[a], a, o_, false);
  }
}

void Model::finish(ModelStorage storage, double timeLimit, double startSeconds) {
  const Stopwatch clock;
  auto checkTime = [&]() {
    if (timeLimit > 0.0 && startSeconds + clock.seconds() > timeLimit)
      throw ConfigError("POMDP model: construction stopped at its time limit of " +
                        num(timeLimit) + " s");
  };
  std::size_t nnz = 0;
  for (const auto& t : tRows_) nnz += t.entries.size();
  const double cells = static_cast<double>(a_) * static_cast<double>(s_) * static_cast<double>(s_);
  const double denseTBytes = 2.0 * cells * sizeof(double);
  const double denseZBytes = static_cast<double>(a_) * s_ * o_ * sizeof(double);
  switch (storage) {
    case ModelStorage::kDense:
      denseT_ = denseZ_ = true;
      break;
    case ModelStorage::kSparse:
      denseT_ = denseZ_ = false;
      break;
    case ModelStorage::kAuto:
      denseT_ = (s_ <= kDenseStates || static_cast<double>(nnz) >= kDenseDensity * cells) &&
                denseTBytes <= static_cast<double>(kDenseBytes);
      denseZ_ = denseZBytes <= static_cast<double>(kDenseBytes);
      break;
  }
  const auto S = static_cast<Eigen::Index>(s_);
  if (denseT_ && t_.empty()) {  // from sparse rows
    t_.assign(a_, Eigen::MatrixXd::Zero(S, S));
    tt_.assign(a_, Eigen::MatrixXd::Zero(S, S));
    for (std::size_t a = 0; a < a_; ++a) {
      checkTime();
      for (std::size_t s = 0; s < s_; ++s)
        for (const Entry& e : tRows_[a].row(s)) {
          t_[a](static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(e.first)) = e.second;
          tt_[a](static_cast<Eigen::Index>(e.first), static_cast<Eigen::Index>(s)) = e.second;
        }
    }
  } else if (!denseT_) {
    std::vector<Eigen::MatrixXd>().swap(t_);
    std::vector<Eigen::MatrixXd>().swap(tt_);
  }
  if (denseZ_ && z_.empty()) {
    z_.assign(a_, Eigen::MatrixXd::Zero(S, static_cast<Eigen::Index>(o_)));
    for (std::size_t a = 0; a < a_; ++a)
      for (std::size_t s = 0; s < s_; ++s)
        for (const Entry& e : zRows_[a].row(s))
          z_[a](static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(e.first)) = e.second;
  } else if (!denseZ_) {
    std::vector<Eigen::MatrixXd>().swap(z_);
  }
  // Structure flags.
  possibleObs_.assign(a_, {});
  identity_.assign(a_, 1);
  terminal_.assign(s_, 1);
  std::vector<char> seen(o_, 0);
  for (std::size_t a = 0; a < a_; ++a) {
    checkTime();
    std::fill(seen.begin(), seen.end(), 0);
    for (std::size_t s = 0; s < s_; ++s) {
      for (const Entry& e : zRows_[a].row(s)) seen[e.first] = 1;
      const bool stays = getTransitionProbability(s, a, s) == 1.0;
      if (!stays) identity_[a] = 0;
      if (!stays || r_(s, a) != 0.0) terminal_[s] = 0;
    }
    for (std::size_t o = 0; o < o_; ++o)
      if (seen[o]) possibleObs_[a].push_back(o);
  }
  b0_ = Belief::Constant(S, 1.0 / static_cast<double>(s_));
  stateNames_ = defaultNames("s", s_);
  actionNames_ = defaultNames("a", a_);
  obsNames_ = defaultNames("o", o_);
}

namespace {
/// @brief The value at column k of a sorted sparse row (0 when absent).
double rowValue(EntryRange row, std::size_t k) {
  const ModelEntry* it = std::lower_bound(
      row.begin(), row.end(), k, [](const ModelEntry& e, std::size_t c) { return e.first < c; });
  return it != row.end() && it->first == k ? it->second : 0.0;
}
}  // namespace

double Model::getTransitionProbability(std::size_t s, std::size_t a, std::size_t s1) const {
  if (denseT_) return t_[a](static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(s1));
  return rowValue(tRows_[a].row(s), s1);
}

double Model::getObservationProbability(std::size_t s1, std::size_t a, std::size_t o) const {
  if (denseZ_) return z_[a](static_cast<Eigen::Index>(s1), static_cast<Eigen::Index>(o));
  return rowValue(zRows_[a].row(s1), o);
}

std::size_t Model::storageBytes() const {
  std::size_t b = static_cast<std::size_t>(r_.size()) * sizeof(double);
  for (const auto* v : {&t_, &tt_, &z_})
    for (const auto& m : *v) b += static_cast<std::size_t>(m.size()) * sizeof(double);
  for (const auto* v : {&tRows_, &zRows_})
    for (const auto& m : *v)
      b += m.entries.capacity() * sizeof(Entry) + m.start.capacity() * sizeof(std::size_t);
  return b;
}

const Eigen::MatrixXd& Model::transitionMatrix(std::size_t a) const {
  if (!denseT_) throw std::logic_error("POMDP model: transitionMatrix() on sparse transitions");
  return t_[a];
}

const Eigen::MatrixXd& Model::transitionMatrixTransposed(std::size_t a) const {
  if (!denseT_)
    throw std::logic_error("POMDP model: transitionMatrixTransposed() on sparse transitions");
  return tt_[a];
}

const Eigen::MatrixXd& Model::observationMatrix(std::size_t a) const {
  if (!denseZ_)
    throw std::logic_error("POMDP model: observationMatrix() on sparse observations");
  return z_[a];
}

Eigen::MatrixXd Model::denseTransition(std::size_t a) const {
  if (denseT_) return t_[a];
  const auto S = static_cast<Eigen::Index>(s_);
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(S, S);
  for (std::size_t s = 0; s < s_; ++s)
    for (const Entry& e : tRows_[a].row(s))
      t(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(e.first)) = e.second;
  return t;
}

Eigen::MatrixXd Model::denseObservation(std::size_t a) const {
  if (denseZ_) return z_[a];
  Eigen::MatrixXd z = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(s_),
                                            static_cast<Eigen::Index>(o_));
  for (std::size_t s = 0; s < s_; ++s)
    for (const Entry& e : zRows_[a].row(s))
      z(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(e.first)) = e.second;
  return z;
}

Eigen::VectorXd Model::observationColumn(std::size_t a, std::size_t o) const {
  if (denseZ_) return z_[a].col(static_cast<Eigen::Index>(o));
  Eigen::VectorXd c = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(s_));
  for (std::size_t s = 0; s < s_; ++s) c(static_cast<Eigen::Index>(s)) = rowValue(zRows_[a].row(s), o);
  return c;
}

void Model::predict(std::size_t a, const Eigen::VectorXd& b, Eigen::VectorXd& out) const {
  applyTransition(a, b, out, true);
}

void Model::expectNext(std::size_t a, const Eigen::VectorXd& v, Eigen::VectorXd& out) const {
  applyTransition(a, v, out, false);
}

void Model::applyTransition(std::size_t a, const Eigen::VectorXd& v, Eigen::VectorXd& out,
                            bool transposed) const {
  if (identity_[a]) {
    out = v;
    return;
  }
  if (denseT_) {
    out.noalias() = (transposed ? tt_[a] : t_[a]) * v;
    return;
  }
  const SparseRows& t = tRows_[a];
  const Entry* e = t.entries.data();
  const double* x = v.data();
  if (transposed) {  // out(s1) = sum_s T(s, s1) v(s): scatter, skipping v(s) = 0
    out.setZero(static_cast<Eigen::Index>(s_));
    double* o = out.data();
    for (std::size_t s = 0; s < s_; ++s) {
      const double vs = x[s];
      if (vs == 0.0) continue;
      for (std::size_t k = t.start[s], end = t.start[s + 1]; k < end; ++k)
        o[e[k].first] += vs * e[k].second;
    }
  } else {  // out(s) = sum_s1 T(s, s1) v(s1): gather
    out.resize(static_cast<Eigen::Index>(s_));
    for (std::size_t s = 0; s < s_; ++s) {
      double acc = 0.0;
      for (std::size_t k = t.start[s], end = t.start[s + 1]; k < end; ++k)
        acc += e[k].second * x[e[k].first];
      out.data()[s] = acc;
    }
  }
}

void Model::weightByObservation(std::size_t a, std::size_t o, Eigen::VectorXd& v) const {
  if (denseZ_) {
    v.array() *= z_[a].col(static_cast<Eigen::Index>(o)).array();
    return;
  }
  for (std::size_t s = 0; s < s_; ++s) {
    double& x = v.data()[s];
    if (x != 0.0) x *= rowValue(zRows_[a].row(s), o);
  }
}

bool Model::hasTerminalStates() const {
  for (char c : terminal_)
    if (c) return true;
  return false;
}

namespace {
/// @brief Inverse-CDF draw of a column of a sparse distribution row (the last entry absorbs
/// rounding), one uniform draw per call.
std::size_t sampleRow(EntryRange row, Rng& rng) {
  double u = uniform01(rng);
  for (const auto& e : row) {
    if (u < e.second) return e.first;
    u -= e.second;
  }
  return row.back().first;
}
}  // namespace

std::tuple<std::size_t, std::size_t, double> Model::sampleSOR(std::size_t s, std::size_t a,
                                                              Rng& rng) const {
  const std::size_t s1 = sampleRow(tRows_[a].row(s), rng);
  const std::size_t o = sampleRow(zRows_[a].row(s1), rng);
  return {s1, o, r_(s, a)};
}

void Model::setInitialBelief(const Belief& b0) {
  if (static_cast<std::size_t>(b0.size()) != s_)
    throw ConfigError("POMDP model: initial belief has " + std::to_string(b0.size()) +
                      " entries, expected " + std::to_string(s_));
  for (Eigen::Index i = 0; i < b0.size(); ++i)
    if (!(b0(i) >= 0.0))
      throw ConfigError("POMDP model: initial belief entry " + std::to_string(i) + " = " +
                        num(b0(i)) + " is negative");
  if (std::abs(b0.sum() - 1.0) > kTolerance)
    throw ConfigError("POMDP model: initial belief sums to " + num(b0.sum()) +
                      " (expected 1)");
  b0_ = b0 / b0.sum();
}

void Model::setNames(std::vector<std::string> states, std::vector<std::string> actions,
                     std::vector<std::string> observations) {
  auto check = [](const std::vector<std::string>& v, std::size_t n, const char* kind) {
    if (v.size() != n)
      throw ConfigError(std::string("POMDP model: ") + std::to_string(v.size()) + " " + kind +
                        " names for " + std::to_string(n) + " " + kind + "s");
    std::set<std::string> seen;
    for (const auto& s : v)
      if (!seen.insert(s).second)
        throw ConfigError(std::string("POMDP model: duplicate ") + kind + " name '" + s + "'");
  };
  check(states, s_, "state");
  check(actions, a_, "action");
  check(observations, o_, "observation");
  stateNames_ = std::move(states);
  actionNames_ = std::move(actions);
  obsNames_ = std::move(observations);
}

std::size_t Model::stateIndex(const std::string& name) const {
  return lookup(stateNames_, name, "state");
}
std::size_t Model::actionIndex(const std::string& name) const {
  return lookup(actionNames_, name, "action");
}
std::size_t Model::observationIndex(const std::string& name) const {
  return lookup(obsNames_, name, "observation");
}

}  // namespace pomdp
}  // namespace krr
