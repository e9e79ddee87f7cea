/**
 * @file simulated_navigation.h
 * @brief The stochastic-blockage simulator seen as an RL environment over NavStateSpace states.
 *
 * R-Max (module mdp) learns in abstract states; the simulator (module nav) moves a robot
 * between grid cells. This adapter is the only place the two meet: it maps cells to states,
 * the trapped outcome to the absorbing failure state, and realises the paper's navigation
 * rewards (-step cost per move, +Rmax on reaching the goal, -Rmax when trapped).
 */
#pragma once

#include <vector>

#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/mdp/environment.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/nav/blockage_simulator.h"

namespace krr {
namespace kb {

/// @brief The simulator's exact dynamics under `context` over the states of `space` (free cells,
/// then the absorbing trapped state): what the robot's knowledge should converge to.
mdp::SparseModel trueDynamics(const nav::BlockageSimulator& sim, const NavStateSpace& space,
                              const nav::Context& context, double discount = 1.0);

class SimulatedNavigation : public mdp::Environment {
 public:
  /// @throws UnknownSymbolError for non-free start/goal cells, ConfigError when the start is a goal.
  SimulatedNavigation(const nav::BlockageSimulator& sim, const NavStateSpace& space,
                      int start_cell, const std::vector<int>& goal_cells,
                      const nav::Context& context, const mdp::NavigationReward& reward);

  mdp::StateId reset() override;
  mdp::StepResult step(mdp::ActionId a, Rng& rng) override;
  std::size_t numStates() const override { return space_.numStates(); }
  std::size_t numActions() const override { return 4; }

  /// @brief Goal states, for building the agent's task.
  const std::vector<mdp::StateId>& goals() const { return goals_; }
  /// @brief The exact dynamics of the simulator under this context, over the same states (for
  /// the "true model" baselines and tests).
  mdp::SparseModel trueModel(double discount) const;
  void setContext(const nav::Context& context) { context_ = context; }

 private:
  const nav::BlockageSimulator& sim_;
  const NavStateSpace& space_;
  mdp::StateId start_;
  std::vector<mdp::StateId> goals_;
  std::vector<std::uint8_t> is_goal_;
  nav::Context context_;
  mdp::NavigationReward reward_;
  int cell_ = -1;
};

}  // namespace kb
}  // namespace krr
