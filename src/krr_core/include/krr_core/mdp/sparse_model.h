/**
 * @file sparse_model.h
 * @brief The general MDP model every solver and R-Max consume (AI-Toolbox style interface).
 *
 * Transitions are stored in compressed sparse rows: one row per (s, a) pair, with contiguous
 * next-state indices and probabilities. Robot MDPs have a handful of outcomes per action, so
 * this is both compact and fast to sweep. Rewards are expected rewards R(s,a); a reward that
 * depends on the next state, R(s,a,s'), is folded into R(s,a) by the builder.
 *
 * Terminal states are absorbing and worth 0: solvers never update them, so a bonus for
 * reaching a goal (or a penalty for a failure) belongs to the reward of the transition that
 * enters the terminal state.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "krr_core/common/random.h"
#include "krr_core/mdp/types.h"

namespace krr {
namespace mdp {

/// @brief Non-owning view of one CSR row: the successors of a state-action pair.
class SuccessorRange {
 public:
  SuccessorRange(const StateId* next, const double* prob, std::size_t n)
      : next_(next), prob_(prob), n_(n) {}
  std::size_t size() const { return n_; }
  StateId state(std::size_t i) const { return next_[i]; }
  double probability(std::size_t i) const { return prob_[i]; }

  /// @brief Iterator yielding Outcome values, so `for (Outcome o : model.successors(s, a))` works.
  class Iterator {
   public:
    Iterator(const StateId* n, const double* p) : n_(n), p_(p) {}
    Outcome operator*() const { return Outcome{*n_, *p_}; }
    Iterator& operator++() {
      ++n_;
      ++p_;
      return *this;
    }
    bool operator!=(const Iterator& o) const { return n_ != o.n_; }

   private:
    const StateId* n_;
    const double* p_;
  };
  Iterator begin() const { return Iterator(next_, prob_); }
  Iterator end() const { return Iterator(next_ + n_, prob_ + n_); }

 private:
  const StateId* next_;
  const double* prob_;
  std::size_t n_;
};

/**
 * @brief Immutable MDP with CSR transitions, expected rewards and terminal flags.
 *
 * Row of pair (s, a) is index s*A + a; its entries are [rowStart[i], rowStart[i+1]) and are
 * sorted by next state with no duplicates. Construct it with SparseModelBuilder, or directly
 * from CSR arrays (validated the same way).
 */
class SparseModel {
 public:
  SparseModel() = default;

  /**
   * @brief Take ownership of CSR arrays after validating them.
   * @throws ConfigError naming (s, a) and the offending value when a probability is outside
   * [0,1], a row does not sum to 1 within 1e-9, an index is out of range, a row is unsorted,
   * the discount is outside [0,1] or array sizes disagree.
   */
  SparseModel(std::size_t num_states, std::size_t num_actions, double discount,
              std::vector<std::uint32_t> row_start, std::vector<StateId> next,
              std::vector<double> prob, std::vector<double> reward,
              std::vector<std::uint8_t> terminal);

  std::size_t getS() const { return s_; }
  std::size_t getA() const { return a_; }
  double getDiscount() const { return discount_; }

  /// @brief T(s, a, s1), found by binary search in the row (0 when s1 is not a successor).
  double getTransitionProbability(StateId s, ActionId a, StateId s1) const;
  /// @brief R(s, a), expected over next states.
  double getExpectedReward(StateId s, ActionId a) const { return reward_[pair(s, a)]; }
  /// @brief Successors of (s, a) with their probabilities, without copying.
  SuccessorRange successors(StateId s, ActionId a) const {
    std::size_t i = pair(s, a);
    return SuccessorRange(next_.data() + row_start_[i], prob_.data() + row_start_[i],
                          row_start_[i + 1] - row_start_[i]);
  }
  /// @brief Sample a next state and the expected reward R(s,a) (terminal: stays, reward 0).
  std::pair<StateId, double> sampleSR(StateId s, ActionId a, Rng& rng) const;
  /// @brief Absorbing, zero-value state (goal, failure, ...).
  bool isTerminal(StateId s) const { return terminal_[s] != 0; }

  /// @brief Number of stored transitions (non-zeros).
  std::size_t numTransitions() const { return next_.size(); }

  /// @name Raw CSR access for solvers (read-only).
  /// @{
  const std::uint32_t* rowStart() const { return row_start_.data(); }
  const StateId* nextStates() const { return next_.data(); }
  const double* probabilities() const { return prob_.data(); }
  const double* rewards() const { return reward_.data(); }
  const std::vector<std::uint8_t>& terminalFlags() const { return terminal_; }
  /// @}

 private:
  std::size_t pair(StateId s, ActionId a) const {
    return static_cast<std::size_t>(s) * a_ + a;
  }

  std::size_t s_ = 0;
  std::size_t a_ = 0;
  double discount_ = 0.95;
  std::vector<std::uint32_t> row_start_{0};
  std::vector<StateId> next_;
  std::vector<double> prob_;
  std::vector<double> reward_;
  std::vector<std::uint8_t> terminal_;
};

/**
 * @brief Accumulates transitions and rewards, then validates and packs them into a SparseModel.
 *
 * Index and probability-range errors are reported when added; row sums when built. A terminal
 * state with no transitions gets a self-loop, as absorbing states need no dynamics.
 */
class SparseModelBuilder {
 public:
  /// @throws ConfigError when S or A is 0 or the discount is outside [0, 1].
  SparseModelBuilder(std::size_t num_states, std::size_t num_actions, double discount);

  /**
   * @brief Add probability p to T(s, a, s1) (duplicates accumulate) and, when
   * reward_on_arrival is non-zero, fold R(s,a,s1) into R(s,a) as p * reward_on_arrival.
   */
  void addTransition(StateId s, ActionId a, StateId s1, double p, double reward_on_arrival = 0.0);
  /// @brief Add r to the expected reward R(s, a).
  void addReward(StateId s, ActionId a, double r);
  /// @brief Mark s absorbing with value 0.
  void setTerminal(StateId s, bool terminal = true);

  /// @throws ConfigError "row (s=.., a=..) sums to X" when a row does not sum to 1 within 1e-9.
  SparseModel build() const;

 private:
  void checkPair(StateId s, ActionId a, const char* what) const;

  struct Entry {
    std::uint32_t pair;
    StateId next;
    double prob;
  };
  std::size_t s_, a_;
  double discount_;
  std::vector<Entry> entries_;
  std::vector<double> reward_;
  std::vector<std::uint8_t> terminal_;
};

/// @brief Tolerance on the sum of each transition row.
constexpr double kRowSumTolerance = 1e-9;

/**
 * @brief Solver layout of a SparseModel for fast value iteration ("sweep layout").
 *
 * Per state s: the sorted union N(s) of its non-terminal successors over all actions, padded
 * to K = successorsPerState() entries, and a dense K x L block of discounted probabilities
 * gamma T(s, a, N(s)_k) (L = actionLanes(): the actions rounded up to 4, padding 0), plus the
 * rewards R(s, a) (padding lanes -infinity). Terminal successors are dropped (they are worth
 * 0) and terminal states get an all-zero row, so a backup of state s is
 *   V(s) = max_a (R(s, a) + sum_k P[s][k][a] V(N(s)_k))
 * with no branch and no index per (s, a): the values of the successors are read once per
 * state and shared by all actions, which the solver evaluates together in SIMD registers.
 * Navigation models have the same few successors for all actions, so the layout is about as
 * compact as the CSR rows; suitable() says when it is not.
 *
 * P is the storage type of probabilities and rewards (double, or float for half the memory
 * traffic on models larger than the caches; values are always computed in double).
 */
template <class P>
class BasicSweepModel {
 public:
  /// @brief Largest padded successor count and action count the layout supports.
  static constexpr std::size_t kMaxSuccessors = 8;
  static constexpr std::size_t kMaxActions = 8;

  /// @throws ConfigError when a state has more than kMaxSuccessors non-terminal successors or
  /// the model has more than kMaxActions actions (use the CSR solver for those).
  explicit BasicSweepModel(const SparseModel& model);

  /// @brief True when the layout applies and stores at most 3 values per CSR non-zero.
  static bool suitable(const SparseModel& model);
  /// @brief The layout when suitable(model), else nullptr (one pass over the model).
  static std::unique_ptr<BasicSweepModel> tryBuild(const SparseModel& model);

  std::size_t getS() const { return s_; }
  std::size_t getA() const { return a_; }
  double getDiscount() const { return discount_; }
  bool isTerminal(StateId s) const { return terminal_[s] != 0; }
  /// @brief K: successors stored per state (padding repeats the state with probability 0).
  std::size_t successorsPerState() const { return k_; }
  /// @brief L: action lanes per successor (4 or 8).
  std::size_t actionLanes() const { return lanes_; }
  /// @brief max |s' - s| over stored successors: how far a backup reaches in the state order.
  std::size_t bandwidth() const { return bandwidth_; }

  /// @name Raw arrays for the solvers.
  /// @{
  const std::uint32_t* successorIndices() const { return succ_.data(); }  ///< S x K
  const P* probabilityBlocks() const { return prob_.data(); }            ///< S x K x L
  const P* rewardRows() const { return reward_.data(); }                 ///< S x L
  const std::vector<std::uint8_t>& terminalFlags() const { return terminal_; }
  /// @brief Bytes a sweep reads.
  std::size_t bytes() const {
    return succ_.size() * sizeof(std::uint32_t) + (prob_.size() + reward_.size()) * sizeof(P);
  }
  /// @}

 private:
  BasicSweepModel() = default;
  /// Fills the layout; on an unsuitable model returns false (strict: throws ConfigError).
  bool build(const SparseModel& model, bool strict);

  std::size_t s_ = 0, a_ = 0, k_ = 0, lanes_ = 0, bandwidth_ = 0;
  double discount_ = 0.0;
  std::vector<std::uint32_t> succ_;
  std::vector<P> prob_;
  std::vector<P> reward_;
  std::vector<std::uint8_t> terminal_;
};

using SweepModel = BasicSweepModel<double>;
using SweepModelF = BasicSweepModel<float>;

extern template class BasicSweepModel<double>;
extern template class BasicSweepModel<float>;

}  // namespace mdp
}  // namespace krr
