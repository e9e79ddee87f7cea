#include "krr_core/common/format.h"
#include "krr_core/pomdp/model.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

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

}  // namespace

Model::Model(std::vector<Eigen::MatrixXd> transitions, std::vector<Eigen::MatrixXd> observations,
             Eigen::MatrixXd rewards, double discount, double timeLimit)
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
  if (o_ == 0) throw ConfigError("POMDP model: no observations");
  if (!(discount > 0.0 && discount <= 1.0))
    throw ConfigError("POMDP model: discount " + num(discount) + " outside (0, 1]");
  if (static_cast<std::size_t>(r_.rows()) != s_ || static_cast<std::size_t>(r_.cols()) != a_)
    throw ConfigError("POMDP model: reward matrix is " + std::to_string(r_.rows()) + "x" +
                      std::to_string(r_.cols()) + ", expected " + std::to_string(s_) + "x" +
                      std::to_string(a_) + " (states x actions)");
  if (!r_.allFinite()) throw ConfigError("POMDP model: reward matrix has non-finite entries");
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
      if (!tOk)
        for (std::size_t k = 0; k < s_; ++k)
          if (!(t(s, k) >= 0.0 && t(s, k) <= 1.0 + kTolerance))
            throw ConfigError("POMDP model: T(action " + std::to_string(a) + ", state " +
                              std::to_string(s) + ", next " + std::to_string(k) + ") = " +
                              num(t(s, k)) + " is not a probability");
      double sum = tSum(static_cast<Eigen::Index>(s));
      if (std::abs(sum - 1.0) > kTolerance)
        throw ConfigError("POMDP model: transition row of action " + std::to_string(a) +
                          ", state " + std::to_string(s) + " sums to " + num(sum) +
                          " (expected 1)");
      if (!zOk)
        for (std::size_t o = 0; o < o_; ++o)
          if (!(z(s, o) >= 0.0 && z(s, o) <= 1.0 + kTolerance))
            throw ConfigError("POMDP model: O(action " + std::to_string(a) + ", next state " +
                              std::to_string(s) + ", obs " + std::to_string(o) + ") = " +
                              num(z(s, o)) + " is not a probability");
      double zs = zSum(static_cast<Eigen::Index>(s));
      if (std::abs(zs - 1.0) > kTolerance)
        throw ConfigError("POMDP model: observation row of action " + std::to_string(a) +
                          ", next state " + std::to_string(s) + " sums to " + num(zs) +
                          " (expected 1)");
    }
  }
  // Derived sparse views and structure flags.
  tt_.resize(a_);
  succ_.assign(a_ * s_, {});
  obsRow_.assign(a_ * s_, {});
  possibleObs_.assign(a_, {});
  identity_.assign(a_, 1);
  terminal_.assign(s_, 1);
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
    std::vector<char> seen(o_, 0);
    // Successor lists from the transpose's columns (contiguous): sizes first, then entries.
    const Eigen::MatrixXd& tt = tt_[a];
    for (std::size_t s = 0; s < s_; ++s) {
      if ((s & 255) == 255) checkTime();
      const double* col = tt.data() + s * s_;
      std::size_t nz = 0;
      for (std::size_t k = 0; k < s_; ++k) nz += col[k] > 0.0;
      auto& list = succ_[a * s_ + s];
      list.reserve(nz);
      for (std::size_t k = 0; k < s_; ++k)
        if (col[k] > 0.0) list.emplace_back(k, col[k]);
    }
    for (std::size_t s = 0; s < s_; ++s) {
      for (std::size_t o = 0; o < o_; ++o)
        if (z_[a](s, o) > 0.0) {
          obsRow_[a * s_ + s].emplace_back(o, z_[a](s, o));
          seen[o] = 1;
        }
      if (t_[a](s, s) != 1.0) identity_[a] = 0;
      if (t_[a](s, s) != 1.0 || r_(s, a) != 0.0) terminal_[s] = 0;
    }
    for (std::size_t o = 0; o < o_; ++o)
      if (seen[o]) possibleObs_[a].push_back(o);
  }
  b0_ = Belief::Constant(static_cast<Eigen::Index>(s_), 1.0 / static_cast<double>(s_));
  stateNames_ = defaultNames("s", s_);
  actionNames_ = defaultNames("a", a_);
  obsNames_ = defaultNames("o", o_);
}

bool Model::hasTerminalStates() const {
  for (char c : terminal_)
    if (c) return true;
  return false;
}

std::tuple<std::size_t, std::size_t, double> Model::sampleSOR(std::size_t s, std::size_t a,
                                                              Rng& rng) const {
  const auto& row = succ_[a * s_ + s];
  double u = uniform01(rng);
  std::size_t s1 = row.back().first;
  for (const auto& e : row) {
    if (u < e.second) {
      s1 = e.first;
      break;
    }
    u -= e.second;
  }
  const auto& orow = obsRow_[a * s_ + s1];
  double v = uniform01(rng);
  std::size_t o = orow.back().first;
  for (const auto& e : orow) {
    if (v < e.second) {
      o = e.first;
      break;
    }
    v -= e.second;
  }
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
