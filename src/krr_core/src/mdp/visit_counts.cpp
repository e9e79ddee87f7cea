#include "krr_core/mdp/visit_counts.h"

#include <algorithm>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

VisitCounts::VisitCounts(std::size_t num_states, std::size_t num_actions)
    : s_(num_states), a_(num_actions) {
  if (s_ == 0 || a_ == 0) {
    throw ConfigError("VisitCounts: S and A must be positive, got S=" + std::to_string(s_) +
                      " A=" + std::to_string(a_));
  }
  total_.assign(s_ * a_, 0);
  outcomes_.assign(s_ * a_, {});
}

void VisitCounts::add(StateId s, ActionId a, StateId s1, std::uint32_t n) {
  if (s >= s_ || s1 >= s_ || a >= a_) {
    throw ConfigError("VisitCounts::add: transition (" + std::to_string(s) + ", " +
                      std::to_string(a) + ") -> " + std::to_string(s1) +
                      " out of range (S=" + std::to_string(s_) + ", A=" + std::to_string(a_) +
                      ")");
  }
  const std::size_t i = pair(s, a);
  total_[i] += n;
  std::vector<OutcomeCount>& v = outcomes_[i];
  auto it = std::lower_bound(v.begin(), v.end(), s1,
                             [](const OutcomeCount& o, StateId x) { return o.state < x; });
  if (it != v.end() && it->state == s1) {
    it->count += n;
  } else {
    v.insert(it, OutcomeCount{s1, n});
  }
}

std::uint32_t VisitCounts::count(StateId s, ActionId a, StateId s1) const {
  for (const OutcomeCount& o : outcomes_[pair(s, a)]) {
    if (o.state == s1) return o.count;
  }
  return 0;
}

Distribution VisitCounts::empirical(StateId s, ActionId a) const {
  Distribution d;
  const std::uint32_t n = count(s, a);
  if (n == 0) return d;
  for (const OutcomeCount& o : outcomes(s, a)) {
    d.push_back(Outcome{o.state, static_cast<double>(o.count) / n});
  }
  return d;
}

void VisitCounts::reset() {
  std::fill(total_.begin(), total_.end(), 0);
  for (auto& v : outcomes_) v.clear();
}

void VisitCounts::merge(const VisitCounts& other) {
  if (other.s_ != s_ || other.a_ != a_) {
    throw ConfigError("VisitCounts::merge: sizes differ (" + std::to_string(s_) + "x" +
                      std::to_string(a_) + " vs " + std::to_string(other.s_) + "x" +
                      std::to_string(other.a_) + ")");
  }
  for (StateId s = 0; s < s_; ++s) {
    for (ActionId a = 0; a < a_; ++a) {
      for (const OutcomeCount& o : other.outcomes(s, a)) add(s, a, o.state, o.count);
    }
  }
}

}  // namespace mdp
}  // namespace krr
