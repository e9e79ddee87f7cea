/**
 * @file visit_counts.h
 * @brief Transition counts n(s,a) and n(s,a,s') gathered by model-based RL.
 *
 * Robot actions have a handful of outcomes, so n(s,a,.) is a small vector sorted by next state
 * per pair rather than a dense S x A x S table. Counts from several runs (or workers) merge.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "krr_core/mdp/sparse_model.h"

namespace krr {
namespace mdp {

/// @brief One observed next state of a pair and how often it was seen.
struct OutcomeCount {
  StateId state = 0;
  std::uint32_t count = 0;
};

/// @brief Sparse visit counts of an S x A model.
class VisitCounts {
 public:
  /// @throws ConfigError when S or A is 0.
  VisitCounts(std::size_t num_states, std::size_t num_actions);

  std::size_t getS() const { return s_; }
  std::size_t getA() const { return a_; }

  /// @brief Record n transitions (s, a) -> s1. @throws ConfigError on an index out of range.
  void add(StateId s, ActionId a, StateId s1, std::uint32_t n = 1);
  /// @brief n(s, a).
  std::uint32_t count(StateId s, ActionId a) const { return total_[pair(s, a)]; }
  /// @brief n(s, a, s1).
  std::uint32_t count(StateId s, ActionId a, StateId s1) const;
  /// @brief Observed outcomes of (s, a), sorted by next state.
  const std::vector<OutcomeCount>& outcomes(StateId s, ActionId a) const {
    return outcomes_[pair(s, a)];
  }
  /// @brief Maximum-likelihood distribution n(s,a,s')/n(s,a) (empty when never tried).
  Distribution empirical(StateId s, ActionId a) const;
  /// @brief Forget everything.
  void reset();
  /// @brief Add another run's counts. @throws ConfigError when the sizes differ.
  void merge(const VisitCounts& other);

 private:
  std::size_t pair(StateId s, ActionId a) const { return static_cast<std::size_t>(s) * a_ + a; }
  std::size_t s_, a_;
  std::vector<std::uint32_t> total_;
  std::vector<std::vector<OutcomeCount>> outcomes_;
};

}  // namespace mdp
}  // namespace krr
