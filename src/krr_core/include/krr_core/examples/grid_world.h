/**
 * @file grid_world.h
 * @brief A toy problem for tests and benchmarks: a navigation grid simulated from its true
 * dynamics, as an mdp::Environment (its true model is known, so learners can be checked
 * against it). Not used by library code (test/check_layering.py).
 */
#pragma once

#include <cstdint>
#include <vector>

#include "krr_core/common/random.h"
#include "krr_core/mdp/environment.h"
#include "krr_core/mdp/navigation_task.h"

namespace krr {
namespace examples {

/**
 * @brief A navigation grid simulated from its true dynamics. States are cells plus the failure
 * state W*H; rewards are realised: -step_cost per move, +Rmax on entering a goal, -Rmax on
 * being trapped.
 */
class GridWorldEnvironment : public mdp::Environment {
 public:
  /// @throws ConfigError when the dynamics are invalid or start/goals are out of range,
  /// blocked, or the start is a goal.
  GridWorldEnvironment(mdp::GridDynamics dynamics, mdp::StateId start,
                       std::vector<mdp::StateId> goals, const mdp::NavigationReward& reward);
  mdp::StateId reset() override;
  mdp::StepResult step(mdp::ActionId a, Rng& rng) override;
  std::size_t numStates() const override { return dyn_.numCells() + 1; }
  std::size_t numActions() const override { return 4; }
  const mdp::GridDynamics& dynamics() const { return dyn_; }
  mdp::StateId failureState() const { return static_cast<mdp::StateId>(dyn_.numCells()); }
  const std::vector<mdp::StateId>& goals() const { return goals_; }
  mdp::StateId start() const { return start_; }

 private:
  mdp::GridDynamics dyn_;
  mdp::StateId start_;
  std::vector<mdp::StateId> goals_;
  std::vector<std::uint8_t> goal_;
  mdp::NavigationReward reward_;
  mdp::StateId state_;
};

}  // namespace examples
}  // namespace krr
