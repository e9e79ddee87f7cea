/**
 * @file navigation_config.h
 * @brief The navigation layer's parameters (config/navigation.yaml), validated on load.
 *
 * Nothing about the world (blocking rates, time-of-day effects, per-area overrides, move noise,
 * robot size, planner budgets) is compiled in: it all comes from this file, and every field is
 * checked so that a typo or an out-of-range value fails at start-up with a ConfigError naming
 * the file, the field and the value, instead of silently skewing an experiment.
 */
#pragma once

#include <map>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "krr_core/mdp/rmax_agent.h"

namespace krr {
namespace nav {

/// @brief Per-blocking-area overrides.
struct AreaConfig {
  double rate = -1.0;                        ///< base blocking rate; < 0: the global default
  std::map<std::string, double> time_factor;  ///< per time of day; absent: the global factor
};

/// @brief Where walkers can block a move.
enum class BlockingMode {
  kPerCell,  ///< every move into a blocking-area cell (risk grows with the area's depth)
  kOnEntry,  ///< only moves entering an area from outside it (one risk per crossing)
};

/// @brief Parameters of the stochastic-blockage simulator.
struct SimulatorConfig {
  double move_success = 0.92;  ///< P(reach the intended free neighbour) when not blocked
  double slip_stay = 0.04;     ///< P(stay in place) when not blocked
  double slip_lateral = 0.04;  ///< P(slip to one of the two lateral neighbours), split evenly
  double blocking_rate = 0.3;  ///< default br of every blocking area
  BlockingMode blocking_mode = BlockingMode::kPerCell;  ///< config: per_cell | on_entry
  double trap_probability = 0.18;  ///< P(trapped | blocked) at the reference cell size
  /// Cell size (m) at which trap_probability applies; on a grid of cell size s the per-step
  /// probability is 1 - (1 - trap_probability)^(s / ref), so the risk of crossing an area of
  /// given length hardly depends on the grid resolution. <= 0 disables the scaling.
  double trap_reference_cell_size = 0.5;
  /// Names of the times of day, in the order Context::time_of_day indexes them.
  std::vector<std::string> times_of_day{"morning", "noon", "afternoon"};
  /// Multiplier of every area's rate at each time of day (same order); result clamped to [0,1].
  std::vector<double> time_factors{1.0, 1.0, 1.0};
  std::map<std::string, AreaConfig> areas;  ///< per-area overrides, by area name
  /// @brief The file these settings were read from ("" when built in code), so that an override
  /// naming an area the map does not have can say where to fix it.
  std::string source;
};

/// @brief Parameters of the OMPL motion planner.
struct PlannerConfig {
  double robot_radius = 0.2;        ///< m; a state is valid iff no non-free cell is closer
  std::string algorithm = "rrtconnect";  ///< "rrtconnect" or "prm"
  double timeout = 0.05;            ///< s per query
  double range = 0.0;               ///< RRTConnect step length (m); 0: OMPL's default
  double interpolation_step = 0.05;  ///< m between waypoints of returned paths
  bool simplify = true;             ///< shortcut and reduce vertices before interpolating
};

/// @brief One navigation domain (grid size and episode length).
struct DomainConfig {
  std::string name;  ///< the key of the config's domains (the office's: "office_30x30")
  int cols = 30;
  int rows = 30;
  int step_limit = 200;  ///< moves allowed per navigation episode
};

/// @brief The navigation task the robot plans on (navigation.yaml `planning`): the paper's
/// reward (-step_cost per move, +rmax at the goal, -rmax when trapped) and discounts.
struct PlanningConfig {
  double step_cost = 1.0;        ///< cost of a move (>= 0, < rmax)
  double rmax = 40.0;            ///< goal bonus / failure penalty (R-Max's Rmax, > 0)
  double discount = 0.99;        ///< value iteration on the navigation task, in (0, 1]
  double model_discount = 0.95;  ///< of models built for requests naming none, in (0, 1]
};

/// @brief R-Max (Procedure 1) on the navigation task (navigation.yaml `rmax_learning`); its
/// reward is the task's (PlanningConfig step_cost, rmax).
struct RMaxLearningConfig {
  int known_threshold = 5;                  ///< M: samples before a (cell, move) pair is known
  double discount = 0.95;                   ///< of R-Max's plans, in (0, 1]
  int replan_every = 10;                    ///< replan every E steps (0: on newly known pairs)
  std::string optimism = "terminal_bonus";  ///< terminal_bonus or self_loop
  bool refine_known = false;                ///< keep refining known pairs from later samples
};

/// @brief The whole navigation.yaml.
struct NavigationConfig {
  std::string map;     ///< map_server YAML (absolute, resolved against the config's directory)
  std::string places;  ///< places / blocking areas YAML (absolute or resolved)
  double max_blocked_fraction = 0.25;  ///< NavGrid cell freeness threshold
  std::vector<DomainConfig> domains;
  SimulatorConfig simulator;
  PlannerConfig planner;
  PlanningConfig planning;
  RMaxLearningConfig rmax_learning;
  /// @brief context.time: the time of day of tasks, learning and deliveries that name none
  /// (one of simulator.time_of_day): the one home of the robot's default context.
  std::string time = "morning";

  /// @brief The domain called `name`; UnknownSymbolError if absent.
  const DomainConfig& domain(const std::string& name) const;
  /// @brief The domain programs use when none is named: the first of `domains`, so that the
  /// default is the site's own and never a name written in code. @throws ConfigError if none.
  const DomainConfig& defaultDomain() const;
};

/// @brief `base` with the navigation task's reward (planning: step_cost, rmax) and R-Max
/// settings (rmax_learning); its other fields (step_limit, epsilon, ...) kept. The one mapping
/// from navigation.yaml to R-Max, used by the learner node, the dialog config and experiments.
mdp::RMaxParams rmaxParamsOf(const PlanningConfig& planning, const RMaxLearningConfig& learning,
                             mdp::RMaxParams base = {});
/// @brief The inverse of rmaxParamsOf: writes p's reward and R-Max settings into the sections
/// (planning.discount and model_discount, which R-Max does not have, are kept).
void storeRMaxParams(const mdp::RMaxParams& p, PlanningConfig& planning,
                     RMaxLearningConfig& learning);

/// @brief The `domains` mapping of a navigation config (or a site's site.yaml), validated;
/// `field` names it in errors. @throws ConfigError naming file, field and value.
std::vector<DomainConfig> readDomains(const YAML::Node& node, const std::string& path,
                                      const std::string& field);
/// @brief The per-area simulator overrides (`simulator.areas` of a navigation config, `areas`
/// of a site.yaml), validated against the times of day. @throws ConfigError.
std::map<std::string, AreaConfig> readAreas(const YAML::Node& node, const std::string& path,
                                            const std::string& field,
                                            const std::vector<std::string>& times_of_day);

/// @brief Load and validate navigation.yaml. Paths in it are relative to the file's directory.
/// @throws ConfigError naming file, field and value (unknown fields are errors too).
NavigationConfig loadNavigationConfig(const std::string& path);

/// @brief Validate a simulator configuration built in code (same checks as the loader).
/// @throws ConfigError naming the field and the value.
void validate(const SimulatorConfig& config);

}  // namespace nav
}  // namespace krr
