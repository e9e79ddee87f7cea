/**
 * @file dialog_config.h
 * @brief Parameters of the dialog manager and of delivery trials (config/dialog.yaml).
 *
 * Question costs, delivery rewards and the turn limit are the paper's (Sec. IV): general
 * questions 2.0, confirming questions 1.5, +80 / -80 for a fulfilled / unfulfilled delivery,
 * a forced delivery after 20 turns. The speech model is *not* here: it is knowledge
 * (config/dialog.plog) and is obtained by reasoning. Every field is validated on load; a bad
 * value raises ConfigError naming the file, the field and the value.
 *
 * serve_cost: the serve reward's consequences beyond the paper's +-80 (the equation and why
 * are in dialog_knowledge.h, the one place that builds it):
 *   mode none      R(s, serve a) = 80 T^D - 80 (1 - T^D)                 (the paper's formula)
 *   mode expected  ... - weight E[navigation cost of the trips driven | s, a]
 *   wrong_delivery_penalty  ... - P_w [a != s]: a person waited and got the wrong item.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include <yaml-cpp/yaml.h>

#include "krr_core/mdp/rmax_agent.h"

namespace krr {
namespace dialog {

/// @brief How navigation costs enter the serve reward (see the file comment).
enum class ServeCostMode { kNone, kExpected };

/// @brief "none", "expected".
std::string toString(ServeCostMode mode);
/// @brief Inverse of toString. @throws ConfigError naming the value.
ServeCostMode serveCostModeFromString(const std::string& text);

/// @brief Everything config/dialog.yaml holds.
struct DialogConfig {
  // dialog:
  double general_cost = 2.0;     ///< "which item / room / person?"
  double confirm_cost = 1.5;     ///< "is it tea?"
  double success_reward = 80.0;  ///< fulfilled delivery
  double failure_reward = -80.0; ///< unfulfilled delivery
  int turn_limit = 20;           ///< questions before a forced delivery
  double discount = 0.99;        ///< of the dialog POMDP (not given in the paper), in (0, 1]
  int max_redeliveries = 1;      ///< redeliveries after a wrong delivery (paper: one)
  // serve_cost:
  ServeCostMode serve_cost_mode = ServeCostMode::kExpected;
  double serve_cost_weight = 1.0;
  double wrong_delivery_penalty = 120.0;  ///< P_w, charged when the served request is wrong
  // navigation:
  /// Place every delivery starts from: a place of the site's map, navigation.shop (required:
  /// no default name, the site names it).
  std::string shop;
  std::string time = "morning";    ///< time of day of the knowledge used and learned
  // The navigation task (knowledge.navigation: navigation.yaml `planning` and `rmax_learning`;
  // these defaults when the dialog config names no navigation config):
  double step_cost = 1.0;          ///< navigation reward: cost per move
  double rmax = 40.0;              ///< navigation reward: goal bonus / failure penalty (R-Max)
  double rmax_discount = 0.95;     ///< R-Max's planning discount
  std::uint32_t rmax_replan_every = 10;  ///< R-Max replans every E steps
  mdp::Optimism rmax_optimism = mdp::Optimism::kTerminalBonus;
  double failure_penalty = 40.0;   ///< cost of a failed trip (trapped or step limit)
  double nav_discount = 1.0;       ///< discount of the navigation task the policies solve
  // solver:
  double solver_precision = 0.5;   ///< target bound gap at the initial belief
  double solver_timeout = 600.0;   ///< seconds; a run stopped by it is not reproducible
  std::size_t solver_max_trials = 1000;  ///< trial budget (0: none): a reproducible stop
  // learning (Procedure 1 for the delivery routes; the rest of R-Max from the navigation config):
  std::uint32_t known_threshold = 30;  ///< R-Max M on the delivery routes
  bool refine_known = true;            ///< keep refining known pairs from all samples
  std::size_t max_episodes_per_task = 300;
  std::size_t convergence_episodes = 20;
  std::size_t learning_rounds = 1;     ///< passes over the 2 x rooms delivery routes
  /// What extraction writes back: "areas" (pooled per blocking area, kb/area_knowledge.h) or
  /// "pairs" (each known (cell, move) pair, for comparison).
  std::string learning_mode = "areas";
  // knowledge: (absolute after loading; relative paths are resolved against the YAML's dir)
  std::string office_plog = "office.plog";  ///< people, items, rooms, request prior
  std::string speech_plog = "dialog.plog";  ///< speech understanding model
  std::string navigation_config;            ///< navigation.yaml of the task ("" = none given)

  /// @brief R-Max parameters for learning (step cost and Rmax of the navigation reward).
  mdp::RMaxParams rmaxParams() const;
  /// @brief The inverse of rmaxParams(): takes p's reward and R-Max settings (an experiment's
  /// overrides); R-Max fields a DialogConfig does not hold (step_limit, epsilon, ...) are ignored.
  void setRMaxParams(const mdp::RMaxParams& p);
  /// @throws ConfigError naming the field and value (same checks as the loader).
  void validate() const;
};

/// @brief Load and validate a dialog.yaml. Unknown fields are errors.
/// @throws ConfigError naming file, field and value (also for unreadable or broken YAML).
DialogConfig loadDialogConfig(const std::string& path);

/// @brief A `solver` block (precision, timeout, max_trials) read over c's: config/dialog.yaml's,
/// or an experiment file's override of it (its own fields only; unknown fields are errors).
/// @throws ConfigError naming file, field and value.
void readSolverSettings(const YAML::Node& node, const std::string& path, DialogConfig& c);

}  // namespace dialog
}  // namespace krr
