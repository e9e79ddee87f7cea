/**
 * @file rmax_agent.h
 * @brief R-Max planner and policy (Brafman & Tennenholtz 2002; paper Sec. III-B).
 *
 * The agent acts greedily with respect to the value function of its RMaxModel. It replans
 * when a pair becomes newly known and every E steps (the paper's "recompute the action policy
 * after E action steps"), lazily at the next act(). Replanning is always warm-started from the
 * previous value function, never from scratch:
 *  - local_replanning (default): an asynchronous Gauss-Seidel worklist starts from the states
 *    whose rows changed and pushes the predecessors of every state whose value moved by more
 *    than the stopping threshold, so a local model change costs local work;
 *  - otherwise: full warm-started value iteration sweeps until the residual bound holds.
 * Only the first plan is a full (cold) solve.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "krr_core/mdp/environment.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/rmax_model.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {

/// @brief R-Max parameters (paper: M, Rmax, E; navigation: step cost, step limit).
struct RMaxParams {
  std::uint32_t known_threshold = 5;  ///< M: samples before a pair is known (>= 1)
  double rmax = 40.0;                 ///< reward bound, goal bonus and failure penalty (> 0)
  std::uint32_t replan_every = 10;    ///< E: replan every E steps (0: only on newly known pairs)
  double discount = 0.95;             ///< in (0, 1]
  double step_cost = 1.0;             ///< cost of a move (>= 0, < rmax)
  std::uint32_t step_limit = 300;     ///< episode step limit (200 small / 300 large domain)
  double epsilon = 1e-2;              ///< planning accuracy (> 0), see solvers.h
  std::size_t max_sweeps = 100000;    ///< cap on full sweeps (or S-backup equivalents) per plan
  Optimism optimism = Optimism::kTerminalBonus;
  bool refine_known = false;          ///< keep updating known pairs from all samples
  bool local_replanning = true;       ///< worklist replanning instead of full sweeps
  /// @throws ConfigError naming the field and its value.
  void validate() const;
  /// @brief Reward structure of the navigation task these parameters describe.
  NavigationReward navigationReward() const { return NavigationReward{step_cost, rmax}; }
};

/// @brief Planning statistics, for benchmarks and tests.
struct RMaxStats {
  std::size_t replans = 0;          ///< plans computed (the first one included)
  std::size_t sweeps = 0;           ///< full value-iteration sweeps over all plans
  std::size_t backups = 0;          ///< single-state Bellman backups over all plans
  std::size_t last_plan_backups = 0;
  std::size_t steps = 0;            ///< observed transitions
};

/// @brief The R-Max learner; see the file comment.
class RMaxAgent : public Agent {
 public:
  /// @throws ConfigError when params or task are invalid.
  RMaxAgent(RMaxTask task, const RMaxParams& params);

  /// @brief Greedy action of the current plan (replans first if due).
  ActionId act(StateId s) override;
  /// @brief Count the transition; schedules a replan on a newly known pair or every E steps.
  /// The reward is not learned (the task's reward structure is known).
  void observe(StateId s, ActionId a, double reward, StateId s1, bool done) override;

  /// @brief Pre-load knowledge-base probabilities (see RMaxModel::setPrior).
  void setPrior(StateId s, ActionId a, const Distribution& d, bool known = true);
  /// @brief Replan now (no-op on an unchanged model when local replanning).
  void replan();
  /// @brief Solve the current model from scratch (cold start), e.g. for comparisons.
  Solution solveCold() const;

  const RMaxModel& model() const { return model_; }
  const RMaxParams& params() const { return params_; }
  const RMaxStats& stats() const { return stats_; }
  /// @brief Current value function over the S + 1 planning states (replans first if due).
  const std::vector<double>& values();
  /// @brief Current greedy policy (replans first if due).
  const std::vector<ActionId>& policy();

 private:
  void replanLocal(const std::vector<StateId>& changed);

  RMaxParams params_;
  RMaxModel model_;
  std::vector<double> values_;
  std::vector<ActionId> policy_;
  bool planned_ = false;
  bool due_ = true;
  RMaxStats stats_;
  std::vector<StateId> queue_;
  std::vector<std::uint8_t> queued_;
};

}  // namespace mdp
}  // namespace krr
