/**
 * @file new_circumstances.h
 * @brief The paper's last experiment (Sec. IV, "Generate controllers for new circumstances"):
 * navigation knowledge learned under different exogenous settings (times of day) is merged by
 * the reasoner into a controller for a setting the robot never experienced ("morning or noon,
 * time unknown"), against a baseline that picks one of the per-setting controllers at random.
 *
 * Settings: the times of day of `learn_times` (morning, noon, afternoon: the simulator's per-area
 * time_of_day multipliers, config/navigation.yaml). The paper: "the robot does not know which
 * setting it is in (out of two that are randomly selected)".
 *
 * Learning (one *learning run*, a function of (seed, run) only). For every setting t,
 * Procedure 1 runs in the simulator under t and writes what it learned into the knowledge base
 * conditioned on curr_time = t (extraction "areas", the robot's learner: walker and trap rates
 * per blocking area and the move noise, NavigationKnowledge::setLearnedAreas; "pairs": each pair
 * R-Max knows, addLearned(pairs, t)); knowledge of
 * one time never enters the model of another, so each setting's knowledge is a function of
 * (seed, t, run). Controllers are computed from models the reasoner builds out of the knowledge
 * base (Procedure 2): one per setting, buildModel({t}) (the setting's "own" controller), and one
 * per possible set of settings S (every unordered pair, for unknown_count 2), buildModel(S):
 * curr_time is an exogenous random attribute, the evidence says it is none of the other times,
 * so P-log weighs each setting's dynamics by the KB's prior on curr_time restricted to S.
 * Nothing is averaged in code. The run also records every controller's exact success
 * probability in every setting (absorbing chain of the simulator's true dynamics, within the
 * domain's step limit).
 *
 * Trial i (a function of (seed, i) only):
 *  1. Its learning run: r = i mod learning_runs (learning_runs 0: r = i, a fresh run per trial).
 *     Runs are learned once per process and reused by every trial that uses them.
 *  2. The draw (stream "new_circumstances/setting", i): a set S of unknown_count distinct
 *     settings uniformly among all such sets, then the true setting uniformly from S, then the
 *     baseline's pick uniformly from S (independent of the truth).
 *  3. Controllers, each driving one simulated episode from start to goal in the true setting,
 *     all from the same random stream ("new_circumstances/episode", i: common random numbers):
 *     the merged controller of S, the random pick (the own controller of the pick), the oracle
 *     (the own controller of the true setting) and every setting's own controller, whatever the
 *     truth. Success = reaching the goal within the domain's step limit (the paper's office:
 *     from the shop to room2 on the small domain, 200 steps, as in the navigation experiments).
 *
 * Reusing learning runs keeps every trial's distribution: trial i's knowledge is one learning
 * run of the same procedure, from a stream derived from (seed, run), so each trial is
 * distributed exactly as with per-trial learning (learning_runs 0, which gives identical rows
 * for i < learning_runs). Trials sharing a run are independent given the run; the spread between
 * runs (large for the afternoon, where learning often ends with little knowledge) is why there
 * are several runs instead of one per seed (test_new_circumstances.cpp checks the equivalence).
 */
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "krr_core/kb/free_time_learner.h"
#include "krr_core/experiments/nav_transfer.h"
#include "krr_core/mdp/rmax_agent.h"

namespace krr {
namespace experiments {

/// @brief Parameters of the new-circumstances experiment (config/experiments/new_circumstances.yaml).
struct NewCircumstancesOptions {
  std::string domain;  ///< navigation domain (the CLI loads it; empty: the site's default)
  // Places of the site's map, no default names: the options file names them (the paper's
  // office: config/experiments/new_circumstances.yaml) and new_circumstances defaults the start
  // to the site's shop (dialog.yaml navigation.shop).
  std::string start;  ///< where every episode starts
  std::string goal;   ///< success: reaching it within the domain's step limit
  /// The settings (times of day): each has its own learned knowledge and controller.
  std::vector<std::string> learn_times{"morning", "noon", "afternoon"};
  /// The robot is in one of this many settings, drawn per trial among learn_times (paper: 2).
  std::size_t unknown_count = 2;
  /// Learning runs per seed: trial i uses run i mod learning_runs (0: a fresh run per trial).
  std::size_t learning_runs = 20;
  /// Simulated blocking rate (replaces every area's base rate; the time-of-day multipliers of
  /// config/navigation.yaml still apply). < 0: the simulator's own configuration.
  double blocking_rate = 0.1;
  /// Procedure 1 per setting: "fixed" practises start -> goal only; "least_known" lets the
  /// LeastKnownSelector pick among `places` (start excluded; empty: every place of the map).
  std::string selector = "fixed";
  std::vector<std::string> places;
  /// Procedure 1's knowledge extraction: "areas" (pooled per blocking area, kb/area_knowledge.h;
  /// what the robot's learner writes) or "pairs" (each known (cell, move) pair, the paper's
  /// literal Procedure 1, kept for comparison).
  std::string extraction = kb::toString(kb::FreeTimeOptions().extraction);
  std::size_t learn_tasks = 1;            ///< tasks practised per setting
  std::size_t learn_episodes = 300;       ///< episode cap per task
  std::size_t convergence_episodes = 30;  ///< no newly known pair for this long = converged
  mdp::RMaxParams rmax;                   ///< learning (step_limit is taken from the domain)
  /// Controllers: value iteration on the KB model with the navigation reward below.
  double plan_discount = 0.99;
  double plan_step_cost = 0.2;
  double plan_rmax = 40.0;
  /// @throws ConfigError naming the field and value (times the domain lacks are checked when
  /// the experiment runs: UnknownSymbolError).
  void validate() const;
};

/**
 * @brief Load options from an experiment YAML (config/experiments/new_circumstances.yaml;
 * every field optional, unknown fields are errors). Its own section new_circumstances {domain,
 * start, goal, learn_times, unknown_count, learning_runs, selector, places, extraction,
 * learn_tasks, learn_episodes, convergence_episodes, controller_step_cost}; overrides of its base
 * (../navigation.yaml when the file is in an `experiments` directory, else `defaults`):
 * planning {step_cost, rmax, discount} (rmax and discount: the controllers'; step_cost: R-Max's),
 * rmax_learning {known_threshold, discount, replan_every, optimism: terminal_bonus | self_loop,
 * refine_known}, simulator {blocking_rate}.
 * @throws ConfigError naming file, field and value; IoError when unreadable.
 */
NewCircumstancesOptions loadNewCircumstancesOptions(const std::string& path,
                                                    const NewCircumstancesOptions& defaults = {});

/// @brief The possible sets of settings (indices into learn_times, ascending), in lexicographic
/// order: for 3 settings and unknown_count 2, {0,1}, {0,2}, {1,2}.
std::vector<std::vector<std::size_t>> possibleSettingSets(const NewCircumstancesOptions& options);

/// @brief The learning run of trial `index` (index mod learning_runs; index if 0).
std::size_t learningRunOf(const NewCircumstancesOptions& options, std::size_t index);

/// @brief Trial `index`'s draw (indices into learn_times / possibleSettingSets()).
struct SettingDraw {
  std::size_t set = 0;    ///< index into possibleSettingSets()
  std::size_t truth = 0;  ///< the true setting (a member of the set)
  std::size_t pick = 0;   ///< the random-pick baseline's setting (a member of the set)
};
/// @brief Draw the set, the true setting and the baseline's pick from (seed, index) only.
SettingDraw drawSettings(const NewCircumstancesOptions& options, std::uint64_t seed,
                         std::size_t index);

/// @brief What one learning run produced (a function of (seed, run) only).
struct LearnedControllers {
  std::size_t run = 0;
  std::vector<std::size_t> learned_pairs;              ///< per setting: pairs written to the KB
  std::vector<std::vector<mdp::ActionId>> own;         ///< per setting: its own controller
  std::vector<std::vector<mdp::ActionId>> merged;      ///< per possible set
  std::vector<std::vector<double>> p_own;     ///< [controller's setting][true setting]
  std::vector<std::vector<double>> p_merged;  ///< [possible set][true setting]
};

/**
 * @brief Learning run `run`: Procedure 1 in every setting, the own and merged controllers, and
 * their exact success probabilities in every setting. `knowledge`'s learned part is cleared.
 * @throws ConfigError / UnknownSymbolError for invalid options.
 */
LearnedControllers learnControllers(const kb::NavDomain& domain, kb::NavigationKnowledge& knowledge,
                                    const NewCircumstancesOptions& options, std::uint64_t seed,
                                    std::size_t run);

/// @brief One controller's episode.
struct EpisodeOutcome {
  bool success = false;
  std::size_t steps = 0;
};
/**
 * @brief Drive `policy` for one episode from start to goal in setting learn_times[setting],
 * from trial `index`'s episode stream: every controller of a trial meets the same random
 * numbers (common random numbers), so identical controllers have identical episodes.
 */
EpisodeOutcome runControllerEpisode(const kb::NavDomain& domain,
                                    const NewCircumstancesOptions& options,
                                    const std::vector<mdp::ActionId>& policy, std::size_t setting,
                                    std::uint64_t seed, std::size_t index);

/// @brief Results of one trial (per-setting vectors in the order of learn_times).
struct NewCircumstancesTrial {
  std::size_t index = 0;
  std::size_t learning_run = 0;
  std::vector<std::string> possible;  ///< the settings the robot may be in (drawn)
  std::string setting;                ///< true setting of the evaluation
  std::string baseline_choice;        ///< setting whose controller the baseline picked
  bool success_merged = false, success_baseline = false, success_oracle = false;
  std::vector<std::uint8_t> success_own;  ///< every setting's own controller, in the truth
  std::size_t steps_merged = 0, steps_baseline = 0, steps_oracle = 0;
  /// Exact success probabilities in the true setting.
  double p_merged = 0, p_baseline = 0, p_oracle = 0;
  std::vector<double> p_own;
  /// Per setting, of this trial's learning run: own controller in its own setting; pairs learned.
  std::vector<double> p_self;
  std::vector<std::size_t> learned_pairs;
};

/// @brief Evaluate trial `index` with the controllers of its learning run.
/// @throws ConfigError when `learned` is not the trial's run or does not fit the options.
NewCircumstancesTrial evaluateNewCircumstancesTrial(const kb::NavDomain& domain,
                                                    const NewCircumstancesOptions& options,
                                                    const LearnedControllers& learned,
                                                    std::uint64_t seed, std::size_t index);

/**
 * @brief Run trial `index` on its own: learn its run with `knowledge` (learned part cleared
 * first), then evaluate it. Depends only on (seed, index).
 * @throws ConfigError / UnknownSymbolError for invalid options.
 */
NewCircumstancesTrial runNewCircumstancesTrial(const kb::NavDomain& domain,
                                               kb::NavigationKnowledge& knowledge,
                                               const NewCircumstancesOptions& options,
                                               std::uint64_t seed, std::size_t index);

/**
 * @brief Trials [begin, begin + count) on `threads` workers (each with its own knowledge
 * base), in trial order. Every learning run is learned once and shared by the workers.
 * Deterministic for a seed whatever the number of threads or the split into ranges.
 */
std::vector<NewCircumstancesTrial> runNewCircumstances(const kb::NavDomain& domain,
                                                       const NewCircumstancesOptions& options,
                                                       std::uint64_t seed, std::size_t begin,
                                                       std::size_t count, std::size_t threads);

/// @brief Mean and 95% confidence half-width of a sample.
struct MeanCi {
  double mean = 0, ci95 = 0;
};
MeanCi meanCi(const std::vector<double>& x);

/// @brief CSV header of newCircumstancesCsvRow (one line, no newline): trial, learning_run,
/// possible_settings ("morning+noon"), true_setting, baseline_pick, success_merged,
/// success_baseline, success_oracle, success_own_<t>..., steps_merged, steps_baseline,
/// steps_oracle, p_merged, p_baseline, p_oracle, p_own_<t>... (exact, in the true setting),
/// p_self_<t>... (own controller in its own setting), learned_pairs_<t>...
std::string newCircumstancesCsvHeader(const NewCircumstancesOptions& options);
/// @brief One CSV line (no newline), columns as in the header.
std::string newCircumstancesCsvRow(const NewCircumstancesTrial& t);

}  // namespace experiments
}  // namespace krr
