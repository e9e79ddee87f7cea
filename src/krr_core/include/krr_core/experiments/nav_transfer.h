/**
 * @file nav_transfer.h
 * @brief The paper's navigation experiment (Sec. IV, Fig. "Navigation tasks"): learn in the
 * start -> source task, extract the knowledge into P-log, apply it to the start -> target task
 * (the paper's office, config/experiments/nav_transfer.yaml: from the shop to room1, then to
 * room2).
 *
 * One trial:
 *  1. Procedure 1: R-Max learns start -> source from scratch in the simulator until it has
 *     converged (no newly known pair for `convergence_episodes` episodes) or `source_episodes`
 *     have run; the known pairs are written into the knowledge base (extraction).
 *  2. Procedure 2: the start -> target model is built from the knowledge base by the reasoner;
 *     the pairs backed by learned knowledge start known ("with extraction").
 *  3. R-Max learns start -> target for `target_episodes`, with those priors and, from the same
 *     random stream, without them ("without extraction").
 * Trials are independent and seeded by (seed, trial index), so results do not depend on how
 * many threads run them.
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "krr_core/kb/nav_domain.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/kb/navigation_learning.h"
#include "krr_core/mdp/rmax_agent.h"

namespace krr {
namespace experiments {

/// @brief Parameters of the transfer experiment.
struct NavTransferOptions {
  // Places of the site's map, no default names: the options file names them (the paper's
  // office: config/experiments/nav_transfer.yaml) and nav_transfer defaults the start to the
  // site's shop (dialog.yaml navigation.shop).
  std::string start;   ///< where every episode starts
  std::string source;  ///< the task learned first, its knowledge extracted
  std::string target;  ///< the task learned with and without that knowledge
  std::string time = "morning";       ///< time of day the robot learns and acts in
  double blocking_rate = 0.3;         ///< br of the simulated world (paper default 0.3)
  std::size_t source_episodes = 300;  ///< cap on source-task learning
  std::size_t convergence_episodes = 20;  ///< episodes without a newly known pair = converged
  std::size_t target_episodes = 100;
  mdp::RMaxParams rmax;               ///< step_limit is taken from the domain
  /// @throws ConfigError naming the field and value.
  void validate() const;
};

/**
 * @brief Load options from an experiment YAML (config/experiments/nav_transfer.yaml; every
 * field optional, unknown fields are errors). Its own section nav_transfer {start, source,
 * target, source_episodes, convergence_episodes, target_episodes}; overrides of its base
 * (../navigation.yaml when the file is in an `experiments` directory, else `defaults`):
 * planning {step_cost, rmax}, rmax_learning {known_threshold, discount, replan_every, optimism,
 * refine_known}, simulator {blocking_rate}, context {time}.
 * @throws ConfigError naming file, field and value; IoError when unreadable.
 */
NavTransferOptions loadNavTransferOptions(const std::string& path,
                                          const NavTransferOptions& defaults = {});

/// @brief Results of one trial.
struct NavTransferTrial {
  std::size_t index = 0;  ///< trial index (its random streams are (seed, index))
  std::vector<double> reward_with, reward_without;       ///< per target episode
  std::vector<std::uint8_t> success_with, success_without;
  std::size_t source_episodes_run = 0;
  std::size_t learned_pairs = 0;  ///< pairs written to the KB by extraction
  std::size_t prior_pairs = 0;    ///< target pairs that started known from the KB
};

/**
 * @brief Run trial `index`. `knowledge` is this worker's knowledge base: its learned part is
 * replaced by this trial's extraction (kb::NavigationKnowledge::replaceLearned), so a worker reuses
 * one parsed and grounded program across trials.
 */
NavTransferTrial runNavTransferTrial(const kb::NavDomain& domain,
                                     kb::NavigationKnowledge& knowledge,
                                     const NavTransferOptions& options, std::uint64_t seed,
                                     std::size_t index);

/// @brief Per-episode means over trials, with 95% confidence half-widths.
struct NavTransferSummary {
  std::vector<double> mean_with, mean_without, ci_with, ci_without;
  std::vector<double> success_with, success_without;
  std::size_t trials = 0;
  double mean_learned_pairs = 0, mean_prior_pairs = 0, mean_source_episodes = 0;
};

/**
 * @brief Run `trials` trials on `threads` worker threads (each with its own knowledge base)
 * and summarise. Deterministic for a seed whatever the number of threads.
 */
NavTransferSummary runNavTransfer(const kb::NavDomain& domain, const NavTransferOptions& options,
                                  std::uint64_t seed, std::size_t trials, std::size_t threads);

/**
 * @brief Trials [begin, begin + count) on `threads` workers, in trial order. Trial i depends
 * only on (seed, i), so ranges run in different processes concatenate to the same results.
 */
std::vector<NavTransferTrial> runNavTransferTrials(const kb::NavDomain& domain,
                                                   const NavTransferOptions& options,
                                                   std::uint64_t seed, std::size_t begin,
                                                   std::size_t count, std::size_t threads);

/// @brief Per-episode means over the trials (all with the same number of episodes).
NavTransferSummary summarizeNavTransfer(const std::vector<NavTransferTrial>& trials);

}  // namespace experiments
}  // namespace krr
