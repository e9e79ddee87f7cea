/**
 * @file blockage_simulator.h
 * @brief The simulated world of the navigation experiments: noisy grid moves and walkers that
 * block (and sometimes trap) the robot inside blocking areas.
 *
 * R-Max learns the navigation model from this simulator, and the true model it should converge
 * to is trueDistribution(): the exact outcome distribution that step() samples from, so the
 * learner can be tested against the truth. Dynamics of a move from cell c towards t:
 *  - t is off the grid or behind a wall / not free: the robot stays (probability 1);
 *  - t lies in a blocking area with rate b (under the context; in on_entry mode only if c is
 *    not in that area): with probability b the robot is blocked and stays, and a blocked robot
 *    is trapped (episode failure) with probability q;
 *  - otherwise: reach t with move_success, stay with slip_stay, slip to each lateral neighbour
 *    with slip_lateral / 2 (staying instead if that neighbour is not reachable).
 */
#pragma once

#include <cstdint>
#include <utility>
#include <optional>
#include <vector>

#include "krr_core/common/random.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/navigation_config.h"

namespace krr {
namespace nav {

/// @brief Exogenous variables of one step: they change blocking rates but not the cell.
/// Validated once, at construction (the simulator reads it on every step).
class Context {
 public:
  /**
   * @param time_of_day index into SimulatorConfig::times_of_day; -1: unspecified (the
   *        simulator refuses an index beyond its times)
   * @param blocking_rate replaces every area's base rate (the experiments' br); none: the
   *        configured rates
   * @throws ConfigError for a time below -1 or a rate outside [0, 1] (blocking_rate.h's rule).
   */
  explicit Context(int time_of_day = -1, std::optional<double> blocking_rate = std::nullopt);
  /// @brief A context from a setting whose negative rate means "not set" (RateUnset::kAllowed).
  static Context withRate(int time_of_day, double rate_or_unset);
  int timeOfDay() const { return time_of_day_; }
  const std::optional<double>& blockingRate() const { return blocking_rate_; }

 private:
  int time_of_day_;
  std::optional<double> blocking_rate_;
};

/// @brief The result of one simulated move.
struct Outcome {
  int cell = -1;         ///< cell after the move (the same cell if blocked, trapped or bumped)
  bool blocked = false;  ///< walkers blocked the move
  bool trapped = false;  ///< blocked and trapped: the episode ends in failure
};

/**
 * @brief Seeded simulator of the office navigation world. Thread-compatible (const after
 * construction; each thread passes its own Rng).
 */
class BlockageSimulator {
 public:
  /// @throws ConfigError for invalid parameters, UnknownSymbolError for an area override that
  /// names no blocking area of the grid.
  BlockageSimulator(const NavGrid& grid, const SimulatorConfig& config);

  /// @brief Sample one move. No heap allocation. Moving from a non-free cell leaves it in place.
  Outcome step(int cell, int move, const Context& context, Rng& rng) const;

  /// @brief The exact distribution step() samples from: (next state, probability) pairs with
  /// distinct states and positive probabilities summing to 1; the trapped outcome is the state
  /// trappedState().
  std::vector<std::pair<int, double>> trueDistribution(int cell, int move,
                                                       const Context& context) const;

  /// @brief Index of the absorbing "trapped" outcome in trueDistribution: numCells().
  int trappedState() const { return grid_.numCells(); }

  /// @brief Blocking rate of a move into `cell` under the context (max over its areas; 0
  /// outside blocking areas).
  double blockingRate(int cell, const Context& context) const;
  /// @brief Blocking rate of the move from `from` into its neighbour `to`: blockingRate(to) in
  /// per_cell mode; in on_entry mode the max over the areas of `to` that `from` is not in.
  double moveBlockingRate(int from, int to, const Context& context) const;
  /// @brief Per-blocked-step trap probability on this grid (after cell-size scaling).
  double trapProbability() const { return trap_; }
  /// @brief Index of a time-of-day name; ConfigError if the configuration does not define it.
  int timeOfDayIndex(const std::string& name) const;
  /// @brief Index of the area a `simulator.areas` override names; ConfigError naming the
  /// config file and field otherwise (a map's areas and the config's overrides are kept apart).
  int areaOfOverride(const std::string& name) const;

  const NavGrid& grid() const { return grid_; }
  const SimulatorConfig& config() const { return config_; }

 private:
  double areaRate(int area, const Context& context) const;

  NavGrid grid_;  // a copy: the simulator outlives whatever built it
  SimulatorConfig config_;
  double trap_ = 0.0;
  int num_times_ = 0;
  std::vector<double> base_rate_;  // per area: configured base rate
  std::vector<double> factor_;     // [area * (num_times + 1) + time + 1]
};

/// @brief Results of running a fixed policy for many episodes.
struct EpisodeStats {
  long episodes = 0;
  long successes = 0;  ///< reached the goal within the step limit
  long trapped = 0;    ///< ended by a trap
  long timeouts = 0;   ///< step limit reached (or no move defined for the cell)
  double mean_steps_success = 0.0;  ///< mean moves of successful episodes
  double successRate() const { return episodes ? static_cast<double>(successes) / episodes : 0.0; }
};

/**
 * @brief Monte-Carlo evaluation of a stationary policy (a move per cell, -1 = none) from start
 * to goal with at most step_limit moves per episode. Used to calibrate the blocking parameters
 * against the paper's success rates and as a baseline for learned policies.
 */
EpisodeStats runPolicy(const BlockageSimulator& sim, const std::vector<std::int8_t>& policy,
                       int start, int goal, int step_limit, const Context& context, long episodes,
                       Rng& rng);

}  // namespace nav
}  // namespace krr
