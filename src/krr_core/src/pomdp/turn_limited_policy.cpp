#include "krr_core/pomdp/turn_limited_policy.h"

#include <algorithm>
#include <limits>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "policy_text.h"

namespace krr {
namespace pomdp {

TurnLimitedPolicy::TurnLimitedPolicy(std::size_t numStates, int turnLimit)
    : s_(numStates), limit_(turnLimit) {
  if (turnLimit < 0)
    throw ConfigError("turn-limited policy: turn limit " + std::to_string(turnLimit) + " < 0");
  by_stage_.resize(static_cast<std::size_t>(turnLimit) + 1);
}

void TurnLimitedPolicy::add(const Eigen::VectorXd& alpha, std::size_t action, int stage) {
  if (static_cast<std::size_t>(alpha.size()) != s_)
    throw ConfigError("alpha vector has " + std::to_string(alpha.size()) + " entries, policy has " +
                      std::to_string(s_) + " states");
  if (!alpha.allFinite()) throw ConfigError("alpha vector has non-finite entries");
  if (stage < 0 || stage > limit_)
    throw ConfigError("alpha vector stage " + std::to_string(stage) + " outside [0, " +
                      std::to_string(limit_) + "]");
  StageGroup& g = by_stage_[static_cast<std::size_t>(stage)];
  g.rows.insert(g.rows.end(), alpha.data(), alpha.data() + alpha.size());
  g.ids.push_back(alphas_.size());
  alphas_.push_back(alpha);
  actions_.push_back(action);
  stages_.push_back(stage);
}

void TurnLimitedPolicy::setPlans(std::size_t numObservations, std::vector<long> next) {
  const std::size_t n = alphas_.size();
  if (numObservations == 0 || next.size() / numObservations != n || next.size() % numObservations != 0)
    throw ConfigError("turn-limited policy: " + std::to_string(next.size()) +
                      " continuations for " + std::to_string(n) + " vectors and " +
                      std::to_string(numObservations) + " observations");
  for (std::size_t k = 0; k < next.size(); ++k) {
    const long j = next[k];
    if (j == -1) continue;
    const std::size_t i = k / numObservations;
    if (j < 0 || static_cast<std::size_t>(j) >= n)
      throw ConfigError("turn-limited policy: vector " + std::to_string(i) +
                        " continues with vector " + std::to_string(j) + ", out of range");
    if (stages_[static_cast<std::size_t>(j)] < std::min(stages_[i] + 1, limit_))
      throw ConfigError("turn-limited policy: vector " + std::to_string(i) + " (stage " +
                        std::to_string(stages_[i]) + ") continues with vector " +
                        std::to_string(j) + " of stage " +
                        std::to_string(stages_[static_cast<std::size_t>(j)]) +
                        ", not usable one turn later");
  }
  obs_ = numObservations;
  next_ = std::move(next);
}

std::size_t TurnLimitedPolicy::bestIndex(const Belief& b, int turns) const {
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("belief has " + std::to_string(b.size()) + " entries, policy has " +
                      std::to_string(s_) + " states");
  const int t = std::clamp(turns, 0, limit_);
  // One matrix-vector product per stage group (vectors usable after t turns: stages >= t);
  // the highest value wins, the lowest index on ties.
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  std::size_t best = alphas_.size();
  double bv = 0.0;
  Eigen::VectorXd v;
  for (std::size_t st = static_cast<std::size_t>(t); st < by_stage_.size(); ++st) {
    const StageGroup& g = by_stage_[st];
    if (g.ids.empty()) continue;
    const Eigen::Map<const RowMajor> m(g.rows.data(), static_cast<Eigen::Index>(g.ids.size()),
                                       static_cast<Eigen::Index>(s_));
    v.noalias() = m * b;
    for (std::size_t j = 0; j < g.ids.size(); ++j) {
      const double x = v(static_cast<Eigen::Index>(j));
      if (best == alphas_.size() || x > bv || (x == bv && g.ids[j] < best)) {
        bv = x;
        best = g.ids[j];
      }
    }
  }
  if (best == alphas_.size())
    throw ConfigError("turn-limited policy has no vector usable after " + std::to_string(t) +
                      " turns");
  return best;
}

double TurnLimitedPolicy::value(const Belief& b, int turns) const {
  return alphas_[bestIndex(b, turns)].dot(b);
}

Eigen::VectorXd TurnLimitedPolicy::values(const Eigen::MatrixXd& beliefs, int turns) const {
  if (static_cast<std::size_t>(beliefs.rows()) != s_)
    throw ConfigError("beliefs have " + std::to_string(beliefs.rows()) + " entries, policy has " +
                      std::to_string(s_) + " states");
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const int t = std::clamp(turns, 0, limit_);
  Eigen::VectorXd best = Eigen::VectorXd::Constant(beliefs.cols(),
                                                   -std::numeric_limits<double>::infinity());
  bool any = false;
  Eigen::MatrixXd v;
  for (std::size_t st = static_cast<std::size_t>(t); st < by_stage_.size(); ++st) {
    const StageGroup& g = by_stage_[st];
    if (g.ids.empty()) continue;
    any = true;
    const Eigen::Map<const RowMajor> m(g.rows.data(), static_cast<Eigen::Index>(g.ids.size()),
                                       static_cast<Eigen::Index>(s_));
    v.noalias() = m * beliefs;
    best = best.cwiseMax(v.colwise().maxCoeff().transpose());
  }
  if (!any)
    throw ConfigError("turn-limited policy has no vector usable after " + std::to_string(t) +
                      " turns");
  return best;
}

double TurnLimitedPolicy::lookahead(const Model& m, const Belief& b, std::size_t a, int turns,
                                    bool ends) const {
  if (ends) {
    if (a >= m.getA() || m.getS() != s_)
      throw ConfigError("turn-limited policy: lookahead of action " + std::to_string(a) +
                        " on a model with " + std::to_string(m.getA()) + " actions and " +
                        std::to_string(m.getS()) + " states");
    return m.rewardMatrix().col(static_cast<Eigen::Index>(a)).dot(b);
  }
  return lookahead(m, b, std::vector<std::size_t>{a}, turns).front();
}

std::vector<double> TurnLimitedPolicy::lookahead(const Model& m, const Belief& b,
                                                 const std::vector<std::size_t>& actions,
                                                 int turns) const {
  if (m.getS() != s_)
    throw ConfigError("turn-limited policy: lookahead on a model with " +
                      std::to_string(m.getS()) + " states, policy has " + std::to_string(s_));
  // Every successor belief of every action in one matrix: one product per stage group for all
  // of them (the policy's vectors are read once per decision, not once per successor).
  std::vector<double> q(actions.size(), 0.0);
  std::vector<std::pair<std::size_t, double>> weight;  // (action slot, gamma P(o | b, a))
  std::vector<Belief> children;
  for (std::size_t k = 0; k < actions.size(); ++k) {
    const std::size_t a = actions[k];
    if (a >= m.getA())
      throw ConfigError("turn-limited policy: lookahead of action " + std::to_string(a) +
                        " on a model with " + std::to_string(m.getA()) + " actions");
    q[k] = m.rewardMatrix().col(static_cast<Eigen::Index>(a)).dot(b);
    Belief pred;
    m.predict(a, b, pred);
    for (std::size_t o : m.possibleObservations(a)) {
      Belief child = pred;
      m.weightByObservation(a, o, child);
      const double p = child.sum();
      if (!(p > 0.0)) continue;
      child /= p;
      weight.emplace_back(k, m.getDiscount() * p);
      children.push_back(std::move(child));
    }
  }
  if (children.empty()) return q;
  Eigen::MatrixXd all(static_cast<Eigen::Index>(s_), static_cast<Eigen::Index>(children.size()));
  for (std::size_t c = 0; c < children.size(); ++c) all.col(static_cast<Eigen::Index>(c)) = children[c];
  const Eigen::VectorXd v = values(all, turns + 1);
  for (std::size_t c = 0; c < children.size(); ++c)
    q[weight[c].first] += weight[c].second * v(static_cast<Eigen::Index>(c));
  return q;
}

std::string TurnLimitedPolicy::toText() const {
  std::ostringstream ss;
  ss << "krr-turn-limited-policy " << (obs_ > 0 ? 2 : 1) << "\nstates " << s_ << "\nturn_limit " << limit_ << "\nvectors "
     << alphas_.size() << "\n";
  for (std::size_t i = 0; i < alphas_.size(); ++i) {
    ss << stages_[i] << ' ' << actions_[i];
    for (Eigen::Index k = 0; k < alphas_[i].size(); ++k) ss << ' ' << detail::fmt(alphas_[i](k));
    ss << '\n';
  }
  if (obs_ > 0) {
    ss << "plans " << obs_ << "\n";
    for (std::size_t i = 0; i < alphas_.size(); ++i) {
      for (std::size_t o = 0; o < obs_; ++o) ss << (o ? " " : "") << next_[i * obs_ + o] + 1;
      ss << '\n';
    }
  }
  return ss.str();
}

namespace {

/// @brief Version 2's "plans O" section (see toText).
void readPlans(detail::TokenReader& in, TurnLimitedPolicy& p, const std::string& text,
               const std::string& file) {
  in.keyword("plans");
  const detail::Tok& ot = in.need("observation count");
  const long obs = detail::parseInt(ot, text, file);
  if (obs < 1 || obs > 1000000) throw in.errorAt(ot, "observation count " + ot.text + " outside [1, 1000000]");
  const std::size_t total = p.size() * static_cast<std::size_t>(obs);
  std::vector<long> next;  // grown as read: a declared size the file cannot hold allocates nothing
  for (std::size_t k = 0; k < total; ++k) {
    const detail::Tok& t = in.need("continuation");
    const long j = detail::parseInt(t, text, file);
    if (static_cast<std::size_t>(j) > p.size())
      throw in.errorAt(t, "continuation " + t.text + " exceeds the vector count " + std::to_string(p.size()));
    next.push_back(j - 1);
  }
  p.setPlans(static_cast<std::size_t>(obs), std::move(next));
}

}  // namespace

TurnLimitedPolicy TurnLimitedPolicy::fromText(const std::string& text, const std::string& file) {
  detail::TokenReader in(text, file);
  in.keyword("krr-turn-limited-policy");
  const detail::Tok& ver = in.need("version");
  const long version = detail::parseInt(ver, text, file);
  if (version != 1 && version != 2)
    throw in.errorAt(ver, "unsupported version '" + ver.text + "'");
  in.keyword("states");
  const auto s = static_cast<std::size_t>(in.count("state count"));
  in.keyword("turn_limit");
  const detail::Tok& lim = in.need("turn limit");
  const long limit = detail::parseInt(lim, text, file);
  if (limit > 1000000) throw in.errorAt(lim, "turn limit " + lim.text + " is too large");
  in.keyword("vectors");
  const auto n = static_cast<std::size_t>(in.count("vector count"));
  TurnLimitedPolicy p(s, static_cast<int>(limit));
  for (std::size_t v = 0; v < n; ++v) {
    const detail::Tok& st = in.need("stage");
    const long stage = detail::parseInt(st, text, file);
    if (stage > limit) throw in.errorAt(st, "stage " + st.text + " exceeds the turn limit");
    const auto a = static_cast<std::size_t>(in.integer("action"));
    Eigen::VectorXd alpha(static_cast<Eigen::Index>(s));
    for (std::size_t k = 0; k < s; ++k) alpha(static_cast<Eigen::Index>(k)) = in.number("value");
    p.add(alpha, a, static_cast<int>(stage));
  }
  if (version == 2) readPlans(in, p, text, file);
  in.finish();
  return p;
}

void TurnLimitedPolicy::save(const std::string& path) const { writeFileAtomic(path, toText()); }

TurnLimitedPolicy TurnLimitedPolicy::load(const std::string& path) {
  return fromText(readFile(path), path);
}

}  // namespace pomdp
}  // namespace krr
