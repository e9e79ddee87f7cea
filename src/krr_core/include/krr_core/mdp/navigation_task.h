/**
 * @file navigation_task.h
 * @brief Navigation-task MDPs with the paper's reward structure (Sec. III-B).
 *
 * Every move costs a fixed small amount; entering a goal cell earns +Rmax; being trapped
 * (entering the absorbing failure state) costs -Rmax. The -Rmax at the step limit (200 steps
 * in the small domain, 300 in the large one) is not a transition and is applied by the
 * episode runner (environment.h). Goal and failure states are terminal (value 0), so their
 * bonus or penalty is folded into the reward of the transition that enters them.
 */
#pragma once

#include <cstdint>
#include <vector>

#include "krr_core/common/random.h"
#include "krr_core/mdp/grid_model.h"
#include "krr_core/mdp/sparse_model.h"

namespace krr {
namespace mdp {

/// @brief Rewards of a navigation task.
struct NavigationReward {
  double step_cost = 1.0;  ///< paid on every move (>= 0)
  double rmax = 40.0;      ///< goal bonus, and failure / step-limit penalty (> 0)
  /// @throws ConfigError naming the field and value.
  void validate() const;
  /// @brief Realised reward of a move that ends in s1.
  double arrival(bool goal, bool failed) const {
    return -step_cost + (goal ? rmax : 0.0) - (failed ? rmax : 0.0);
  }
};

/**
 * @brief True dynamics of a 4-connected grid: obstacles and, per (cell, action), the
 * probabilities of {stay, up, down, left, right, fail} (GridModel slot order).
 */
struct GridDynamics {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::vector<std::uint8_t> blocked;  ///< W*H, 1 = obstacle (never entered)
  std::vector<double> outcomes;       ///< W*H*4*6, index ((cell*4)+a)*6+k

  /// @brief Allocate a W x H grid with no obstacles where every action stays in place.
  GridDynamics(std::uint32_t w, std::uint32_t h);
  GridDynamics() = default;
  std::size_t numCells() const { return static_cast<std::size_t>(width) * height; }
  double& p(StateId c, ActionId a, unsigned k) { return outcomes[(c * 4u + a) * 6u + k]; }
  double p(StateId c, ActionId a, unsigned k) const { return outcomes[(c * 4u + a) * 6u + k]; }
  /// @brief Next cell of slot k from c: moves off the grid or into an obstacle stay in place;
  /// kFail maps to W*H (the failure state).
  StateId target(StateId c, unsigned k) const;
  /// @throws ConfigError naming the cell and action when sizes or probabilities are wrong.
  void validate() const;
};

/// @brief Options of a random navigation grid (for tests and benchmarks).
struct RandomGridOptions {
  double obstacle_density = 0.15;  ///< fraction of cells blocked
  double p_intended = 0.7;         ///< the intended move
  double p_side = 0.1;             ///< each perpendicular move
  double p_back = 0.05;            ///< the opposite move
  // stay gets 1 - p_intended - 2 p_side - p_back
  std::uint32_t trap_areas = 4;    ///< square "blocking areas" where the robot can be trapped
  std::uint32_t trap_size = 3;     ///< side of a blocking area, in cells
  double p_trap = 0.1;             ///< failure probability per move inside a blocking area
};

/**
 * @brief Random obstacles and stochastic moves; cells in keep_free (start, goals) are never
 * blocked. Connectivity is not guaranteed: check with reachable().
 */
GridDynamics makeRandomGridDynamics(std::uint32_t width, std::uint32_t height,
                                    const RandomGridOptions& options,
                                    const std::vector<StateId>& keep_free, Rng& rng);

/// @brief Cells reachable from start with positive probability (1 = reachable).
std::vector<std::uint8_t> reachable(const GridDynamics& dyn, StateId start);

/**
 * @brief The navigation task on the grid layout: moves into obstacles stay in place, goals and
 * obstacles are terminal, R(s,a) = -step_cost + Rmax P(goal) - Rmax P(fail).
 * @throws ConfigError when a goal is out of range or an obstacle.
 */
GridModel makeNavigationGridModel(const GridDynamics& dyn, const std::vector<StateId>& goals,
                                  const NavigationReward& reward, double discount);
/// @brief Same, with float storage (half the memory traffic).
GridModelF makeNavigationGridModelF(const GridDynamics& dyn, const std::vector<StateId>& goals,
                                    const NavigationReward& reward, double discount);

/**
 * @brief A navigation task on top of any transition model: its rewards are replaced by
 * R(s,a) = -step_cost + Rmax P(goal | s,a) - Rmax P(failure | s,a); goals and failure states
 * become terminal (its own terminal states stay terminal).
 */
SparseModel makeNavigationTask(const SparseModel& dynamics, const std::vector<StateId>& goals,
                               const std::vector<StateId>& failure_states,
                               const NavigationReward& reward);

}  // namespace mdp
}  // namespace krr
