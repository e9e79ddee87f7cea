#include "krr_core/common/format.h"
#include "krr_core/mdp/sparse_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

namespace {

std::string pairName(std::size_t s, std::size_t a) {
  return "(s=" + std::to_string(s) + ", a=" + std::to_string(a) + ")";
}

std::string num(double v) { return formatNumber(v, 17); }

void checkDiscount(double discount) {
  if (!(discount >= 0.0 && discount <= 1.0)) {
    throw ConfigError("MDP discount must be in [0, 1], got " + num(discount));
  }
}

}  // namespace

SparseModel::SparseModel(std::size_t num_states, std::size_t num_actions, double discount,
                         std::vector<std::uint32_t> row_start, std::vector<StateId> next,
                         std::vector<double> prob, std::vector<double> reward,
                         std::vector<std::uint8_t> terminal)
    : s_(num_states),
      a_(num_actions),
      discount_(discount),
      row_start_(std::move(row_start)),
      next_(std::move(next)),
      prob_(std::move(prob)),
      reward_(std::move(reward)),
      terminal_(std::move(terminal)) {
  if (s_ == 0 || a_ == 0) {
    throw ConfigError("MDP needs at least one state and one action, got S=" +
                      std::to_string(s_) + " A=" + std::to_string(a_));
  }
  if (s_ > std::numeric_limits<StateId>::max()) {
    throw ConfigError("MDP has too many states for 32-bit indices: " + std::to_string(s_));
  }
  checkDiscount(discount_);
  const std::size_t pairs = s_ * a_;
  if (row_start_.size() != pairs + 1 || reward_.size() != pairs || terminal_.size() != s_ ||
      next_.size() != prob_.size() || row_start_.front() != 0 ||
      row_start_.back() != next_.size()) {
    throw ConfigError("SparseModel: CSR array sizes disagree (S=" + std::to_string(s_) +
                      ", A=" + std::to_string(a_) + ", rows=" +
                      std::to_string(row_start_.size()) + ", nnz=" +
                      std::to_string(next_.size()) + ")");
  }
  for (std::size_t i = 0; i < pairs; ++i) {
    const std::size_t s = i / a_, a = i % a_;
    if (row_start_[i + 1] < row_start_[i]) {
      throw ConfigError("SparseModel: row " + pairName(s, a) + " has a negative length");
    }
    if (!std::isfinite(reward_[i])) {
      throw ConfigError("SparseModel: reward of " + pairName(s, a) + " is " + num(reward_[i]));
    }
    double sum = 0.0;
    for (std::uint32_t k = row_start_[i]; k < row_start_[i + 1]; ++k) {
      if (next_[k] >= s_) {
        throw ConfigError("SparseModel: row " + pairName(s, a) + " has next state " +
                          std::to_string(next_[k]) + " out of range [0, " +
                          std::to_string(s_) + ")");
      }
      if (k > row_start_[i] && next_[k] <= next_[k - 1]) {
        throw ConfigError("SparseModel: row " + pairName(s, a) +
                          " is not sorted by next state or has duplicates");
      }
      if (!(prob_[k] >= 0.0 && prob_[k] <= 1.0)) {
        throw ConfigError("SparseModel: probability T" + pairName(s, a) + "->" +
                          std::to_string(next_[k]) + " = " + num(prob_[k]) +
                          " is outside [0, 1]");
      }
      sum += prob_[k];
    }
    if (std::fabs(sum - 1.0) > kRowSumTolerance) {
      throw ConfigError("SparseModel: transition row " + pairName(s, a) + " sums to " +
                        num(sum) + " (expected 1 within 1e-9)");
    }
  }
}

double SparseModel::getTransitionProbability(StateId s, ActionId a, StateId s1) const {
  const std::size_t i = pair(s, a);
  const StateId* b = next_.data() + row_start_[i];
  const StateId* e = next_.data() + row_start_[i + 1];
  const StateId* it = std::lower_bound(b, e, s1);
  if (it == e || *it != s1) return 0.0;
  return prob_[static_cast<std::size_t>(it - next_.data())];
}

std::pair<StateId, double> SparseModel::sampleSR(StateId s, ActionId a, Rng& rng) const {
  if (isTerminal(s)) return {s, 0.0};
  const std::size_t i = pair(s, a);
  const std::uint32_t b = row_start_[i], e = row_start_[i + 1];
  double u = uniform01(rng);
  for (std::uint32_t k = b; k + 1 < e; ++k) {
    u -= prob_[k];
    if (u < 0.0) return {next_[k], reward_[i]};
  }
  return {next_[e - 1], reward_[i]};
}

SparseModelBuilder::SparseModelBuilder(std::size_t num_states, std::size_t num_actions,
                                       double discount)
    : s_(num_states), a_(num_actions), discount_(discount) {
  if (s_ == 0 || a_ == 0) {
    throw ConfigError("MDP needs at least one state and one action, got S=" +
                      std::to_string(s_) + " A=" + std::to_string(a_));
  }
  if (s_ * a_ > std::numeric_limits<std::uint32_t>::max()) {
    throw ConfigError("MDP too large: S*A=" + std::to_string(s_ * a_));
  }
  checkDiscount(discount);
  reward_.assign(s_ * a_, 0.0);
  terminal_.assign(s_, 0);
}

void SparseModelBuilder::checkPair(StateId s, ActionId a, const char* what) const {
  if (s >= s_) {
    throw ConfigError(std::string("SparseModelBuilder::") + what + ": state " +
                      std::to_string(s) + " out of range [0, " + std::to_string(s_) + ")");
  }
  if (a >= a_) {
    throw ConfigError(std::string("SparseModelBuilder::") + what + ": action " +
                      std::to_string(a) + " out of range [0, " + std::to_string(a_) + ")");
  }
}

void SparseModelBuilder::addTransition(StateId s, ActionId a, StateId s1, double p,
                                       double reward_on_arrival) {
  checkPair(s, a, "addTransition");
  if (s1 >= s_) {
    throw ConfigError("SparseModelBuilder::addTransition: next state " + std::to_string(s1) +
                      " of " + pairName(s, a) + " out of range [0, " + std::to_string(s_) +
                      ")");
  }
  if (!(p >= 0.0 && p <= 1.0)) {
    throw ConfigError("SparseModelBuilder::addTransition: probability T" + pairName(s, a) +
                      "->" + std::to_string(s1) + " = " + num(p) + " is outside [0, 1]");
  }
  if (!std::isfinite(reward_on_arrival)) {
    throw ConfigError("SparseModelBuilder::addTransition: reward of " + pairName(s, a) +
                      "->" + std::to_string(s1) + " is " + num(reward_on_arrival));
  }
  if (p == 0.0) return;
  const std::uint32_t i = static_cast<std::uint32_t>(static_cast<std::size_t>(s) * a_ + a);
  entries_.push_back(Entry{i, s1, p});
  reward_[i] += p * reward_on_arrival;
}

void SparseModelBuilder::addReward(StateId s, ActionId a, double r) {
  checkPair(s, a, "addReward");
  if (!std::isfinite(r)) {
    throw ConfigError("SparseModelBuilder::addReward: reward of " + pairName(s, a) + " is " +
                      num(r));
  }
  reward_[static_cast<std::size_t>(s) * a_ + a] += r;
}

void SparseModelBuilder::setTerminal(StateId s, bool terminal) {
  checkPair(s, 0, "setTerminal");
  terminal_[s] = terminal ? 1 : 0;
}

SparseModel SparseModelBuilder::build() const {
  const std::size_t pairs = s_ * a_;
  // Counting sort of the entries by pair, then sort + merge duplicates inside each row.
  std::vector<std::uint32_t> count(pairs + 1, 0);
  for (const Entry& e : entries_) ++count[e.pair + 1];
  // Terminal states with an empty row get a self-loop.
  for (std::size_t i = 0; i < pairs; ++i) {
    if (count[i + 1] == 0 && terminal_[i / a_]) count[i + 1] = 1;
  }
  for (std::size_t i = 0; i < pairs; ++i) count[i + 1] += count[i];
  std::vector<std::pair<StateId, double>> tmp(count[pairs]);
  std::vector<std::uint32_t> fill(count.begin(), count.end() - 1);
  for (const Entry& e : entries_) tmp[fill[e.pair]++] = {e.next, e.prob};
  for (std::size_t i = 0; i < pairs; ++i) {
    if (fill[i] == count[i] && count[i + 1] > count[i]) {
      tmp[fill[i]++] = {static_cast<StateId>(i / a_), 1.0};  // terminal self-loop
    }
  }
  std::vector<std::uint32_t> row_start(pairs + 1, 0);
  std::vector<StateId> next;
  std::vector<double> prob;
  next.reserve(tmp.size());
  prob.reserve(tmp.size());
  for (std::size_t i = 0; i < pairs; ++i) {
    auto b = tmp.begin() + count[i], e = tmp.begin() + count[i + 1];
    std::sort(b, e, [](const auto& x, const auto& y) { return x.first < y.first; });
    double sum = 0.0;
    for (auto it = b; it != e; ++it) {
      sum += it->second;
      if (!next.empty() && next.size() > row_start[i] && next.back() == it->first) {
        prob.back() += it->second;
      } else {
        next.push_back(it->first);
        prob.push_back(it->second);
      }
    }
    for (std::size_t k = row_start[i]; k < prob.size(); ++k) {
      if (prob[k] > 1.0) prob[k] = 1.0;  // merged duplicates may round just above 1
    }
    if (std::fabs(sum - 1.0) > kRowSumTolerance) {
      throw ConfigError("SparseModelBuilder: transition row " + pairName(i / a_, i % a_) +
                        " sums to " + num(sum) + " (expected 1 within 1e-9)");
    }
    row_start[i + 1] = static_cast<std::uint32_t>(next.size());
  }
  return SparseModel(s_, a_, discount_, std::move(row_start), std::move(next), std::move(prob),
                     reward_, terminal_);
}

namespace {

/// Sorted union of the non-terminal successors of s over all actions, by insertion into
/// out[0..cap); returns its size, or cap + 1 as soon as it has more than cap entries.
std::size_t successorUnion(const SparseModel& m, StateId s, StateId* out, std::size_t cap) {
  std::size_t n = 0;
  if (m.isTerminal(s)) return 0;
  const std::uint32_t* rs = m.rowStart();
  const StateId* nx = m.nextStates();
  const std::vector<std::uint8_t>& term = m.terminalFlags();
  const std::size_t i0 = static_cast<std::size_t>(s) * m.getA();
  for (std::size_t i = i0; i < i0 + m.getA(); ++i) {
    for (std::uint32_t k = rs[i]; k < rs[i + 1]; ++k) {
      const StateId x = nx[k];
      if (term[x]) continue;
      std::size_t pos = n;
      while (pos > 0 && out[pos - 1] > x) --pos;
      if (pos > 0 && out[pos - 1] == x) continue;
      if (n == cap) return cap + 1;
      for (std::size_t j = n; j > pos; --j) out[j] = out[j - 1];
      out[pos] = x;
      ++n;
    }
  }
  return n;
}

}  // namespace

template <class P>
bool BasicSweepModel<P>::suitable(const SparseModel& m) {
  return tryBuild(m) != nullptr;
}

template <class P>
std::unique_ptr<BasicSweepModel<P>> BasicSweepModel<P>::tryBuild(const SparseModel& m) {
  std::unique_ptr<BasicSweepModel<P>> out(new BasicSweepModel<P>());
  return out->build(m, false) ? std::move(out) : nullptr;
}

template <class P>
BasicSweepModel<P>::BasicSweepModel(const SparseModel& m) {
  build(m, true);
}

template <class P>
bool BasicSweepModel<P>::build(const SparseModel& m, bool strict) {
  s_ = m.getS();
  a_ = m.getA();
  discount_ = m.getDiscount();
  if (a_ > kMaxActions) {
    if (!strict) return false;
    throw ConfigError("SweepModel: " + std::to_string(a_) + " actions, at most " +
                      std::to_string(kMaxActions) + " supported (use the CSR solver)");
  }
  lanes_ = a_ <= 4 ? 4 : 8;
  // One pass computes every state's successor union (kMaxSuccessors slots per state).
  std::vector<StateId> uni(s_ * kMaxSuccessors);
  std::vector<std::uint8_t> count(s_);
  k_ = 1;
  for (StateId s = 0; s < s_; ++s) {
    const std::size_t n = successorUnion(m, s, &uni[s * kMaxSuccessors], kMaxSuccessors);
    if (n > kMaxSuccessors) {
      if (!strict) return false;
      throw ConfigError("SweepModel: state " + std::to_string(s) + " has more than " +
                        std::to_string(kMaxSuccessors) +
                        " distinct non-terminal successors (use the CSR solver)");
    }
    count[s] = static_cast<std::uint8_t>(n);
    k_ = std::max(k_, n);
  }
  // Padded to a count the solver has a kernel for.
  k_ = k_ <= 2 ? 2 : k_ == 3 ? 4 : k_ == 7 ? 8 : k_;
  if (!strict && s_ * k_ * lanes_ > 3 * std::max<std::size_t>(m.numTransitions(), s_)) {
    return false;  // actions reach different states: the CSR rows are more compact
  }
  terminal_ = m.terminalFlags();
  succ_.assign(s_ * k_, 0);
  prob_.assign(s_ * k_ * lanes_, P(0));
  reward_.assign(s_ * lanes_, P(0));
  const std::uint32_t* rs = m.rowStart();
  const StateId* nx = m.nextStates();
  const double* pr = m.probabilities();
  const double* rw = m.rewards();
  bandwidth_ = 0;
  for (StateId s = 0; s < s_; ++s) {
    const StateId* u = &uni[s * kMaxSuccessors];
    const std::size_t nu = count[s];
    for (std::size_t k = 0; k < k_; ++k) {
      const StateId n = k < nu ? u[k] : s;
      succ_[s * k_ + k] = n;
      bandwidth_ = std::max<std::size_t>(bandwidth_, n > s ? n - s : s - n);
    }
    P* rrow = &reward_[s * lanes_];
    for (std::size_t a = a_; a < lanes_; ++a) rrow[a] = -std::numeric_limits<P>::infinity();
    if (terminal_[s]) continue;  // all-zero row: the backup is 0
    P* block = &prob_[s * k_ * lanes_];
    for (std::size_t a = 0; a < a_; ++a) {
      const std::size_t i = static_cast<std::size_t>(s) * a_ + a;
      rrow[a] = static_cast<P>(rw[i]);
      for (std::uint32_t j = rs[i]; j < rs[i + 1]; ++j) {
        if (terminal_[nx[j]]) continue;
        std::size_t k = 0;
        while (u[k] != nx[j]) ++k;
        block[k * lanes_ + a] = static_cast<P>(discount_ * pr[j]);
      }
    }
  }
  return true;
}

template class BasicSweepModel<double>;
template class BasicSweepModel<float>;

}  // namespace mdp
}  // namespace krr
