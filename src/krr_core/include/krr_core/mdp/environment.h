/**
 * @file environment.h
 * @brief Environment and agent interfaces, and the episode runner of the RL experiments.
 *
 * The real navigation simulator (module nav) is adapted to Environment by the knowledge-base
 * layer (kb/simulated_navigation.h); the toy grid world of the tests and benchmarks is
 * examples/grid_world.h. The runner applies the paper's step limit (200 / 300 steps) and its
 * -Rmax penalty when the limit is hit.
 */
#pragma once

#include <cstddef>
#include <vector>

#include "krr_core/common/random.h"
#include "krr_core/mdp/sparse_model.h"

namespace krr {
namespace mdp {

/// @brief Outcome of one environment step.
struct StepResult {
  StateId next = 0;
  double reward = 0.0;
  bool done = false;    ///< episode over (goal or failure)
  bool failed = false;  ///< ended in a failure (trapped)
};

/// @brief Something an agent acts in, one discrete step at a time.
class Environment {
 public:
  virtual ~Environment() = default;
  /// @brief Start a new episode; returns the start state.
  virtual StateId reset() = 0;
  /// @brief Apply action a; all randomness comes from rng.
  virtual StepResult step(ActionId a, Rng& rng) = 0;
  virtual std::size_t numStates() const = 0;
  virtual std::size_t numActions() const = 0;
};

/// @brief A learner or a fixed controller.
class Agent {
 public:
  virtual ~Agent() = default;
  /// @brief Action to take in s.
  virtual ActionId act(StateId s) = 0;
  /// @brief Feedback of the last action.
  virtual void observe(StateId s, ActionId a, double reward, StateId s1, bool done) = 0;
};

/// @brief Follows a fixed policy (e.g. from value iteration); learns nothing.
class FixedPolicyAgent : public Agent {
 public:
  explicit FixedPolicyAgent(std::vector<ActionId> policy) : policy_(std::move(policy)) {}
  ActionId act(StateId s) override { return policy_.at(s); }
  void observe(StateId, ActionId, double, StateId, bool) override {}

 private:
  std::vector<ActionId> policy_;
};

/**
 * @brief Any SparseModel as an environment: reward is the expected reward R(s,a); the episode
 * ends on a terminal state, which is a failure unless it is one of the goals.
 */
class ModelEnvironment : public Environment {
 public:
  ModelEnvironment(const SparseModel& model, StateId start, std::vector<StateId> goals);
  StateId reset() override;
  StepResult step(ActionId a, Rng& rng) override;
  std::size_t numStates() const override { return model_.getS(); }
  std::size_t numActions() const override { return model_.getA(); }

 private:
  const SparseModel& model_;
  StateId start_;
  std::vector<std::uint8_t> goal_;
  StateId state_;
};

/// @brief What happened in one episode.
struct EpisodeResult {
  double total_reward = 0.0;  ///< undiscounted, including the timeout penalty
  std::size_t steps = 0;
  bool success = false;    ///< ended in a goal
  bool failed = false;     ///< ended trapped
  bool timed_out = false;  ///< hit the step limit
};

/**
 * @brief Run one episode: reset, then act/step/observe until done or step_limit steps; hitting
 * the limit adds -timeout_penalty to the total (the paper's -Rmax).
 * @throws ConfigError when step_limit is 0 or the agent returns an action out of range.
 */
EpisodeResult runEpisode(Environment& env, Agent& agent, std::size_t step_limit,
                         double timeout_penalty, Rng& rng);

/// @brief runEpisode() n times with the same agent (which keeps learning across episodes).
std::vector<EpisodeResult> runEpisodes(Environment& env, Agent& agent, std::size_t episodes,
                                       std::size_t step_limit, double timeout_penalty, Rng& rng);

}  // namespace mdp
}  // namespace krr
