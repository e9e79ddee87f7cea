/**
 * @file new_circumstances.h
 * @brief The paper's last experiment (Sec. IV, "Generate controllers for new circumstances"):
 * navigation knowledge learned under different exogenous settings (times of day) is merged by
 * the reasoner into a controller for a setting the robot never experienced ("morning or noon,
 * time unknown"), against a baseline that picks one of the per-setting controllers at random.
 *
 * One trial (everything seeded by (seed, trial index) only):
 *  1. Learning. For every learned setting t (morning, noon, afternoon) Procedure 1 runs in the
 *     simulator under t (the simulator's per-area time_of_day multipliers, config/navigation.yaml)
 *     and writes the pairs R-Max knows into the knowledge base conditioned on curr_time = t
 *     (NavigationKnowledge::addLearned(pairs, t)).
 *  2. Controllers, all computed from models the reasoner builds from the knowledge base
 *     (Procedure 2): one per learned setting, buildModel({t}); and the merged one,
 *     buildModel(unknown_times): curr_time is an exogenous random attribute, the evidence says
 *     it is none of the other times, so P-log weighs each setting's dynamics by the KB's prior
 *     on curr_time restricted to the possible times. Nothing is averaged in code.
 *  3. Evaluation. The true setting is drawn uniformly from unknown_times; the baseline picks
 *     one of those settings' controllers uniformly at random. Both controllers (and, for
 *     reference, the true setting's own controller, the "oracle") drive one simulated episode
 *     from start to goal; their exact success probabilities under the true setting (absorbing
 *     chain of the simulator's true dynamics, within the domain's step limit) are recorded too.
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "krr_core/kb/nav_transfer.h"
#include "krr_core/mdp/rmax_agent.h"

namespace krr {
namespace kb {

/// @brief Parameters of the new-circumstances experiment (config/new_circumstances.yaml).
struct NewCircumstancesOptions {
  std::string domain = "office_30x30";  ///< navigation domain (used by the CLI to load it)
  std::string start = "shop";
  std::string goal = "room2";
  /// Settings the robot learns in (each its own time of day), in order.
  std::vector<std::string> learn_times{"morning", "noon", "afternoon"};
  /// The new circumstance: the robot is in one of these (learned) settings but does not know which.
  std::vector<std::string> unknown_times{"morning", "noon"};
  /// Simulated blocking rate (replaces every area's base rate; the time-of-day multipliers of
  /// config/navigation.yaml still apply). < 0: the simulator's own configuration.
  double blocking_rate = 0.1;
  /// Procedure 1 per setting: "fixed" practises start -> goal only; "least_known" lets the
  /// LeastKnownSelector pick among `places` (start excluded).
  std::string selector = "fixed";
  std::vector<std::string> places{"room1", "room2", "room3", "room4", "room5"};
  std::size_t learn_tasks = 1;            ///< tasks practised per setting
  std::size_t learn_episodes = 300;       ///< episode cap per task
  std::size_t convergence_episodes = 30;  ///< no newly known pair for this long = converged
  mdp::RMaxParams rmax;                   ///< learning (step_limit is taken from the domain)
  /// Controllers: value iteration on the KB model with the navigation reward below.
  double plan_discount = 0.99;
  double plan_step_cost = 0.2;
  double plan_rmax = 40.0;
  /// @throws ConfigError naming the field and value (unknown times are checked at run time).
  void validate() const;
};

/**
 * @brief Load options from a YAML file (every field optional, unknown fields are errors):
 * domain, start, goal, learn_times, unknown_times, blocking_rate, selector, places, learn_tasks,
 * learn_episodes, convergence_episodes, rmax {known_threshold, rmax, replan_every, discount,
 * step_cost, optimism: terminal_bonus | self_loop, refine_known}, plan {discount, step_cost, rmax}. Starts from `defaults`.
 * @throws ConfigError naming file, field and value; IoError when unreadable.
 */
NewCircumstancesOptions loadNewCircumstancesOptions(const std::string& path,
                                                    const NewCircumstancesOptions& defaults = {});

/// @brief Results of one trial.
struct NewCircumstancesTrial {
  std::size_t index = 0;
  std::string setting;           ///< true setting (time of day) of the evaluation
  std::string baseline_choice;   ///< setting whose controller the baseline picked
  bool success_merged = false, success_baseline = false, success_oracle = false;
  std::size_t steps_merged = 0, steps_baseline = 0;
  double p_merged = 0, p_baseline = 0, p_oracle = 0;  ///< exact success probabilities
  /// Exact success averaged over the draws of the evaluation (true setting uniform over
  /// unknown_times; for the baseline also its pick): the trial's expected success without the
  /// evaluation's sampling noise.
  double expected_merged = 0, expected_baseline = 0;
  /// Per learned setting (order of learn_times): the setting's controller's exact success
  /// probability in its own setting, and the number of pairs extracted into the KB.
  std::vector<double> p_self;
  std::vector<std::size_t> learned_pairs;
  /// Whether the merged controller's action at the start differs from each setting's.
  std::vector<std::uint8_t> differs_from;
};

/**
 * @brief Run trial `index`. `knowledge` is this worker's knowledge base; its learned part is
 * cleared first, so the trial depends only on (seed, index).
 * @throws ConfigError / UnknownSymbolError for invalid options.
 */
NewCircumstancesTrial runNewCircumstancesTrial(const NavDomain& domain,
                                               NavigationKnowledge& knowledge,
                                               const NewCircumstancesOptions& options,
                                               std::uint64_t seed, std::size_t index);

/**
 * @brief Trials [begin, begin + count) on `threads` workers (each with its own knowledge
 * base), in trial order. Deterministic for a seed whatever the number of threads or the split
 * into ranges.
 */
std::vector<NewCircumstancesTrial> runNewCircumstances(const NavDomain& domain,
                                                       const NewCircumstancesOptions& options,
                                                       std::uint64_t seed, std::size_t begin,
                                                       std::size_t count, std::size_t threads);

/// @brief Mean and 95% confidence half-width of a sample.
struct MeanCi {
  double mean = 0, ci95 = 0;
};
MeanCi meanCi(const std::vector<double>& x);

/// @brief CSV header of trialCsvRow (one line, no newline).
std::string newCircumstancesCsvHeader(const NewCircumstancesOptions& options);
/// @brief One CSV line (no newline): trial, setting, success_merged, success_baseline, ...
std::string newCircumstancesCsvRow(const NewCircumstancesTrial& t);

}  // namespace kb
}  // namespace krr
