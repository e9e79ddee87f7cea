/**
 * @file rmax_model.h
 * @brief The known/optimistic model of R-Max (Brafman & Tennenholtz 2002).
 *
 * A pair (s, a) is "known" once it has been tried M times (n(s,a) >= M), or when the knowledge
 * base supplies its distribution (setPrior, the paper's "with extraction" condition). Known
 * pairs use their estimated distribution; every unknown pair leads with probability 1 to a
 * fictitious optimistic state O (index S, terminal) and earns the optimistic reward:
 *  - Optimism::kTerminalBonus (default): Rmax, i.e. an unknown pair is worth as much as
 *    reaching the goal at once. Navigation returns never exceed Rmax, so this is optimistic
 *    and keeps exploration local (cheaper than the original construction).
 *  - Optimism::kSelfLoop: Rmax / (1 - gamma), the value of the original construction where O
 *    self-loops with reward Rmax forever (folded into the entering reward so O can be terminal
 *    and the solvers never have to iterate its value up). Needs gamma < 1.
 * By default a known pair's distribution is frozen at its first M samples, as in R-Max; with
 * refine_known it keeps following all samples (better estimates to write back to the KB).
 *
 * The reward structure of the task (step cost, goal bonus, failure penalty) is known to the
 * agent; only transition probabilities are learned, as in the paper.
 *
 * The model is a view with the SparseModel interface (getS, getA, getDiscount, successors,
 * getExpectedReward, getTransitionProbability, isTerminal), stored as fixed-capacity rows so
 * a pair that becomes known is patched in place instead of rebuilding the model; toSparse()
 * exports it.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "krr_core/mdp/model_concept.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/sparse_model.h"
#include "krr_core/mdp/visit_counts.h"

namespace krr {
namespace mdp {

/// @brief How unknown pairs are made optimistic (see the file comment).
enum class Optimism { kTerminalBonus, kSelfLoop };

/// @brief The configuration name of an optimism ("terminal_bonus", "self_loop"): the one
/// spelling used by navigation.yaml, the experiment files and the learned-knowledge cache keys.
const char* optimismName(Optimism optimism);
/// @brief The optimism called `name`.
/// @throws ConfigError "unknown value '<name>' (expected terminal_bonus or self_loop)".
Optimism optimismFromName(const std::string& name);

/// @brief The reward structure and terminal states the agent knows in advance.
struct RMaxTask {
  std::size_t num_states = 0;
  std::size_t num_actions = 0;
  std::vector<double> action_reward;   ///< S*A: reward of taking a in s (e.g. -step cost)
  std::vector<double> arrival_reward;  ///< S: reward of entering s (e.g. +Rmax goal, -Rmax failure)
  std::vector<std::uint8_t> terminal;  ///< S: absorbing states (goals, failure)
  /// @throws ConfigError when sizes disagree or a value is not finite.
  void validate() const;
};

/// @brief The navigation task of the paper: -step_cost per move, +Rmax on a goal, -Rmax on failure.
RMaxTask makeNavigationRMaxTask(std::size_t num_states, std::size_t num_actions,
                                const std::vector<StateId>& goals,
                                const std::vector<StateId>& failure_states,
                                const NavigationReward& reward);

/// @brief A known pair and its distribution, as written back to the knowledge base.
struct KnownPair {
  StateId state = 0;
  ActionId action = 0;
  Distribution distribution;
  std::uint32_t samples = 0;  ///< own samples n(s,a)
  bool from_prior = false;    ///< distribution came from setPrior, not from samples
};

/// @brief R-Max's known/optimistic model; see the file comment.
class RMaxModel {
 public:
  /// @brief What an observation changed.
  enum class Update { kNone, kNewlyKnown, kRefined };

  /**
   * @throws ConfigError naming the field when known_threshold is 0, rmax <= 0, the discount is
   * outside [0, 1] (or 1 with kSelfLoop) or the task is malformed.
   */
  RMaxModel(RMaxTask task, double discount, std::uint32_t known_threshold, double rmax,
            Optimism optimism = Optimism::kTerminalBonus, bool refine_known = false);

  /// @name SparseModel interface of the planning model (S + 1 states: O is the last).
  /// @{
  std::size_t getS() const { return s_ + 1; }
  std::size_t getA() const { return a_; }
  double getDiscount() const { return discount_; }
  bool isTerminal(StateId s) const { return terminal_[s] != 0; }
  double getExpectedReward(StateId s, ActionId a) const { return reward_[pair(s, a)]; }
  SuccessorRange successors(StateId s, ActionId a) const {
    const std::size_t i = pair(s, a);
    return SuccessorRange(next_.data() + i * cap_, prob_.data() + i * cap_, len_[i]);
  }
  double getTransitionProbability(StateId s, ActionId a, StateId s1) const;
  /// @}

  /// @brief The fictitious optimistic state O.
  StateId optimisticState() const { return static_cast<StateId>(s_); }
  /// @brief Reward of an unknown pair (Rmax or Rmax / (1 - gamma)).
  double optimisticReward() const { return optimistic_reward_; }
  std::uint32_t knownThreshold() const { return m_; }

  /// @brief Count (s, a) -> s1 and update the pair's row if it becomes known (or is refined).
  /// @throws ConfigError on an index out of range.
  Update observe(StateId s, ActionId a, StateId s1);
  bool isKnown(StateId s, ActionId a) const { return known_[pair(s, a)] != 0; }
  std::size_t numKnown() const { return num_known_; }

  /**
   * @brief Pre-load a distribution from the knowledge base. known = true makes the pair known
   * at once (it is replaced by the empirical distribution when the pair has M samples of its
   * own). known = false only records the prior (reported by prior()); the pair stays
   * optimistic until it has M samples.
   * @throws ConfigError naming (s, a) when an index is out of range, s is terminal, or the
   * distribution is not a distribution (probability outside [0,1], sum not 1 within 1e-9).
   */
  void setPrior(StateId s, ActionId a, const Distribution& distribution, bool known = true);
  /// @brief The prior set for (s, a), empty if none.
  const Distribution& prior(StateId s, ActionId a) const;

  /// @brief Estimated distribution of (s, a) (empty when unknown).
  Distribution distribution(StateId s, ActionId a) const;
  /// @brief All known pairs with their distributions (for the knowledge-base update).
  std::vector<KnownPair> knownPairs() const;
  const VisitCounts& counts() const { return counts_; }

  /// @brief States with a known pair that can lead to s (for incremental replanning).
  const std::vector<StateId>& predecessors(StateId s) const { return preds_[s]; }
  /// @brief States whose rows changed since the last call, then forgets them.
  std::vector<StateId> takeChanged();

  /// @brief The planning model in the general layout.
  SparseModel toSparse() const;

 private:
  std::size_t pair(StateId s, ActionId a) const { return static_cast<std::size_t>(s) * a_ + a; }
  void writeRow(StateId s, ActionId a, const Distribution& d);
  void markChanged(StateId s);
  void grow(std::size_t capacity);

  std::size_t s_, a_;
  double discount_;
  std::uint32_t m_;
  double rmax_;
  double optimistic_reward_;
  bool refine_;
  RMaxTask task_;
  VisitCounts counts_;
  std::size_t cap_ = 1;
  std::vector<StateId> next_;
  std::vector<double> prob_;
  std::vector<std::uint32_t> len_;
  std::vector<double> reward_;
  std::vector<std::uint8_t> terminal_;
  std::vector<std::uint8_t> known_;
  std::vector<std::uint8_t> from_prior_;
  std::vector<Distribution> priors_;  // empty unless setPrior was used
  std::size_t num_known_ = 0;
  std::vector<std::vector<StateId>> preds_;
  std::vector<StateId> changed_;
  std::vector<std::uint8_t> changed_flag_;
};

// R-Max plans on this view with the generic solvers (valueIterationView, bellmanBackup).
static_assert(is_successor_model_v<RMaxModel>,
              "RMaxModel must satisfy mdp::SuccessorModel (krr_core/mdp/model_concept.h)");

}  // namespace mdp
}  // namespace krr
