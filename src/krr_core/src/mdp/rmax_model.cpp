#include "krr_core/common/format.h"
#include "krr_core/mdp/rmax_model.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

namespace {

std::string num(double v) { return formatNumber(v, 17); }

std::string pairName(StateId s, ActionId a) {
  return "(s=" + std::to_string(s) + ", a=" + std::to_string(a) + ")";
}

const Distribution kEmpty;

}  // namespace

const char* optimismName(Optimism optimism) {
  return optimism == Optimism::kSelfLoop ? "self_loop" : "terminal_bonus";
}

Optimism optimismFromName(const std::string& name) {
  if (name == "terminal_bonus") return Optimism::kTerminalBonus;
  if (name == "self_loop") return Optimism::kSelfLoop;
  throw ConfigError("unknown value '" + name + "' (expected terminal_bonus or self_loop)");
}

void RMaxTask::validate() const {
  if (num_states == 0 || num_actions == 0) {
    throw ConfigError("RMaxTask: num_states and num_actions must be positive, got " +
                      std::to_string(num_states) + " and " + std::to_string(num_actions));
  }
  if (action_reward.size() != num_states * num_actions || arrival_reward.size() != num_states ||
      terminal.size() != num_states) {
    throw ConfigError("RMaxTask: action_reward has " + std::to_string(action_reward.size()) +
                      " entries (expected S*A=" + std::to_string(num_states * num_actions) +
                      "), arrival_reward " + std::to_string(arrival_reward.size()) +
                      " and terminal " + std::to_string(terminal.size()) + " (expected S=" +
                      std::to_string(num_states) + ")");
  }
  for (std::size_t i = 0; i < action_reward.size(); ++i) {
    if (!std::isfinite(action_reward[i])) {
      throw ConfigError("RMaxTask.action_reward[" + std::to_string(i) + "] is " +
                        num(action_reward[i]));
    }
  }
  for (std::size_t i = 0; i < arrival_reward.size(); ++i) {
    if (!std::isfinite(arrival_reward[i])) {
      throw ConfigError("RMaxTask.arrival_reward[" + std::to_string(i) + "] is " +
                        num(arrival_reward[i]));
    }
  }
}

RMaxTask makeNavigationRMaxTask(std::size_t num_states, std::size_t num_actions,
                                const std::vector<StateId>& goals,
                                const std::vector<StateId>& failure_states,
                                const NavigationReward& reward) {
  reward.validate();
  RMaxTask t;
  t.num_states = num_states;
  t.num_actions = num_actions;
  t.action_reward.assign(num_states * num_actions, -reward.step_cost);
  t.arrival_reward.assign(num_states, 0.0);
  t.terminal.assign(num_states, 0);
  for (StateId g : goals) {
    if (g >= num_states) {
      throw ConfigError("makeNavigationRMaxTask: goal " + std::to_string(g) + " out of range");
    }
    t.arrival_reward[g] = reward.rmax;
    t.terminal[g] = 1;
  }
  for (StateId f : failure_states) {
    if (f >= num_states) {
      throw ConfigError("makeNavigationRMaxTask: failure state " + std::to_string(f) +
                        " out of range");
    }
    t.arrival_reward[f] = -reward.rmax;
    t.terminal[f] = 1;
  }
  return t;
}

RMaxModel::RMaxModel(RMaxTask task, double discount, std::uint32_t known_threshold, double rmax,
                     Optimism optimism, bool refine_known)
    : s_(task.num_states),
      a_(task.num_actions),
      discount_(discount),
      m_(known_threshold),
      rmax_(rmax),
      refine_(refine_known),
      task_((task.validate(), std::move(task))),
      counts_(s_, a_) {
  if (m_ == 0) throw ConfigError("RMaxModel: known_threshold (M) must be >= 1, got 0");
  if (!(rmax_ > 0.0) || !std::isfinite(rmax_)) {
    throw ConfigError("RMaxModel: rmax must be > 0, got " + num(rmax_));
  }
  if (!(discount_ >= 0.0 && discount_ <= 1.0)) {
    throw ConfigError("RMaxModel: discount must be in [0, 1], got " + num(discount_));
  }
  if (optimism == Optimism::kSelfLoop) {
    if (discount_ >= 1.0) {
      throw ConfigError("RMaxModel: Optimism::kSelfLoop needs discount < 1, got " +
                        num(discount_));
    }
    optimistic_reward_ = rmax_ / (1.0 - discount_);
  } else {
    optimistic_reward_ = rmax_;
  }
  const std::size_t ns = s_ + 1, pairs = ns * a_;
  next_.assign(pairs * cap_, 0);
  prob_.assign(pairs * cap_, 0.0);
  len_.assign(pairs, 1);
  reward_.assign(pairs, 0.0);
  terminal_.assign(ns, 0);
  known_.assign(pairs, 0);
  from_prior_.assign(pairs, 0);
  priors_.assign(s_ * a_, {});
  preds_.assign(ns, {});
  changed_flag_.assign(ns, 0);
  for (StateId s = 0; s < ns; ++s) {
    terminal_[s] = s == s_ ? 1 : task_.terminal[s];
    for (ActionId a = 0; a < a_; ++a) {
      const std::size_t i = pair(s, a);
      if (terminal_[s]) {
        next_[i * cap_] = s;  // absorbing self-loop, reward 0
        prob_[i * cap_] = 1.0;
      } else {
        next_[i * cap_] = optimisticState();
        prob_[i * cap_] = 1.0;
        reward_[i] = optimistic_reward_;
      }
    }
  }
}

double RMaxModel::getTransitionProbability(StateId s, ActionId a, StateId s1) const {
  for (Outcome o : successors(s, a)) {
    if (o.state == s1) return o.probability;
  }
  return 0.0;
}

void RMaxModel::grow(std::size_t capacity) {
  const std::size_t pairs = getS() * a_;
  std::vector<StateId> nx(pairs * capacity, 0);
  std::vector<double> pr(pairs * capacity, 0.0);
  for (std::size_t i = 0; i < pairs; ++i) {
    std::copy_n(next_.begin() + i * cap_, len_[i], nx.begin() + i * capacity);
    std::copy_n(prob_.begin() + i * cap_, len_[i], pr.begin() + i * capacity);
  }
  next_.swap(nx);
  prob_.swap(pr);
  cap_ = capacity;
}

void RMaxModel::markChanged(StateId s) {
  if (!changed_flag_[s]) {
    changed_flag_[s] = 1;
    changed_.push_back(s);
  }
}

std::vector<StateId> RMaxModel::takeChanged() {
  std::vector<StateId> out;
  out.swap(changed_);
  for (StateId s : out) changed_flag_[s] = 0;
  return out;
}

void RMaxModel::writeRow(StateId s, ActionId a, const Distribution& d) {
  if (d.size() > cap_) {
    std::size_t c = cap_;
    while (c < d.size()) c *= 2;
    grow(c);
  }
  const std::size_t i = pair(s, a);
  double r = task_.action_reward[i];
  for (std::size_t k = 0; k < d.size(); ++k) {
    next_[i * cap_ + k] = d[k].state;
    prob_[i * cap_ + k] = d[k].probability;
    r += d[k].probability * task_.arrival_reward[d[k].state];
    std::vector<StateId>& p = preds_[d[k].state];
    if (std::find(p.begin(), p.end(), s) == p.end()) p.push_back(s);
  }
  len_[i] = static_cast<std::uint32_t>(d.size());
  reward_[i] = r;
  if (!known_[i]) {
    known_[i] = 1;
    ++num_known_;
  }
  markChanged(s);
}

RMaxModel::Update RMaxModel::observe(StateId s, ActionId a, StateId s1) {
  if (s >= s_ || s1 >= s_ || a >= a_) {
    throw ConfigError("RMaxModel::observe: transition " + pairName(s, a) + " -> " +
                      std::to_string(s1) + " out of range (S=" + std::to_string(s_) +
                      ", A=" + std::to_string(a_) + ")");
  }
  if (terminal_[s]) return Update::kNone;
  counts_.add(s, a, s1);
  const std::size_t i = pair(s, a);
  const std::uint32_t n = counts_.count(s, a);
  if (!known_[i]) {
    if (n < m_) return Update::kNone;
    writeRow(s, a, counts_.empirical(s, a));
    return Update::kNewlyKnown;
  }
  if (from_prior_[i]) {
    if (n < m_) return Update::kNone;
    from_prior_[i] = 0;  // own data now outweighs the prior
    writeRow(s, a, counts_.empirical(s, a));
    return Update::kRefined;
  }
  if (refine_) {
    writeRow(s, a, counts_.empirical(s, a));
    return Update::kRefined;
  }
  return Update::kNone;
}

void RMaxModel::setPrior(StateId s, ActionId a, const Distribution& distribution, bool known) {
  if (s >= s_ || a >= a_) {
    throw ConfigError("RMaxModel::setPrior: pair " + pairName(s, a) + " out of range (S=" +
                      std::to_string(s_) + ", A=" + std::to_string(a_) + ")");
  }
  if (task_.terminal[s]) {
    throw ConfigError("RMaxModel::setPrior: state " + std::to_string(s) +
                      " is terminal; its pairs have no dynamics to learn");
  }
  Distribution d = distribution;
  std::sort(d.begin(), d.end(),
            [](const Outcome& x, const Outcome& y) { return x.state < y.state; });
  Distribution merged;
  double sum = 0.0;
  for (const Outcome& o : d) {
    if (o.state >= s_) {
      throw ConfigError("RMaxModel::setPrior: pair " + pairName(s, a) + " next state " +
                        std::to_string(o.state) + " out of range [0, " + std::to_string(s_) +
                        ")");
    }
    if (!(o.probability >= 0.0 && o.probability <= 1.0)) {
      throw ConfigError("RMaxModel::setPrior: pair " + pairName(s, a) + " probability of " +
                        std::to_string(o.state) + " is " + num(o.probability));
    }
    sum += o.probability;
    if (o.probability == 0.0) continue;
    if (!merged.empty() && merged.back().state == o.state) {
      merged.back().probability += o.probability;
    } else {
      merged.push_back(o);
    }
  }
  if (std::fabs(sum - 1.0) > kRowSumTolerance) {
    throw ConfigError("RMaxModel::setPrior: distribution of pair " + pairName(s, a) +
                      " sums to " + num(sum) + " (expected 1 within 1e-9)");
  }
  const std::size_t i = pair(s, a);
  priors_[i] = merged;
  if (!known) return;
  if (known_[i] && !from_prior_[i]) return;  // own samples already made it known
  from_prior_[i] = 1;
  writeRow(s, a, merged);
}

const Distribution& RMaxModel::prior(StateId s, ActionId a) const {
  if (s >= s_ || a >= a_) return kEmpty;
  return priors_[pair(s, a)];
}

Distribution RMaxModel::distribution(StateId s, ActionId a) const {
  Distribution d;
  if (s >= s_ || a >= a_ || !isKnown(s, a)) return d;
  for (Outcome o : successors(s, a)) d.push_back(o);
  return d;
}

std::vector<KnownPair> RMaxModel::knownPairs() const {
  std::vector<KnownPair> out;
  out.reserve(num_known_);
  for (StateId s = 0; s < s_; ++s) {
    for (ActionId a = 0; a < a_; ++a) {
      if (!isKnown(s, a)) continue;
      KnownPair k;
      k.state = s;
      k.action = a;
      k.distribution = distribution(s, a);
      k.samples = counts_.count(s, a);
      k.from_prior = from_prior_[pair(s, a)] != 0;
      out.push_back(std::move(k));
    }
  }
  return out;
}

SparseModel RMaxModel::toSparse() const {
  SparseModelBuilder b(getS(), a_, discount_);
  for (StateId s = 0; s < getS(); ++s) {
    if (terminal_[s]) {
      b.setTerminal(s);
      continue;
    }
    for (ActionId a = 0; a < a_; ++a) {
      for (Outcome o : successors(s, a)) b.addTransition(s, a, o.state, o.probability);
      b.addReward(s, a, getExpectedReward(s, a));
    }
  }
  return b.build();
}

}  // namespace mdp
}  // namespace krr
