/**
 * @file delivery_experiment.h
 * @brief Delivery tasks end to end in the core (paper, Sec. IV, Table I): dialog to identify
 * the request, navigation to deliver it, the redelivery rule, with knowledge that is either
 * learned at the trial's blocking rate or outdated (learned at br = 0.3).
 *
 * Preparation (once per experiment, i.e. per condition, br and seed):
 *  1. the navigation knowledge base: config/navigation.plog + the domain geometry + knowledge
 *     learned on the delivery routes (prepareLearnedKnowledge: at the trial's br for
 *     "learned", at outdated_rate for "outdated"; cached as a P-log file);
 *  2. Procedure 2: the navigation model by reasoning (NavigationKnowledge::buildModel), the
 *     robot's navigation policies and P^N (DeliveryNavigation);
 *  3. the dialog POMDP by reasoning (DialogKnowledge::buildSpec: prior, speech model, T^D by
 *     the delivery equation, serve costs) and its policy (PointBasedSolver with the config's
 *     precision and time budget; with a cache directory the policy is saved under a hash of
 *     the exact model and reused).
 *
 * One trial (deterministic per (seed, index): streams "delivery/request", "delivery/dialog",
 * "delivery/navigation" with the trial index; they do not depend on the condition or br, so
 * conditions are compared on the same requests and answers' random numbers):
 *  - the hidden request is drawn from the knowledge base's prior;
 *  - the simulated person answers every question through the speech model (the model's
 *    observation probabilities); the DialogController picks questions by the policy and
 *    forces serve(most likely request) after turn_limit questions;
 *  - the served request is delivered by driving shop -> served room in the blockage
 *    simulator at the trial's br with the policy of the condition's knowledge. Redelivery
 *    rule (paper): if the served request was wrong and the robot arrived, it drives back to
 *    the shop, learns the correct request (no further dialog) and drives to the right room.
 *    A trip that ends trapped or at the step limit ends the trial unfulfilled.
 *  - recorded reward (undiscounted): reward = delivery_reward - qa_cost - nav_cost, where
 *    delivery_reward = +80 if fulfilled else -80, qa_cost = 2.0 per general and 1.5 per
 *    confirming question asked, nav_cost = step_cost x moves driven (all trips) +
 *    failure_penalty if a trip failed (the paper's navigation reward without the goal bonus).
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "krr_core/dialog/delivery_learning.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "krr_core/kb/nav_transfer.h"
#include "krr_core/pomdp/alpha_policy.h"
#include "krr_core/pomdp/dialog_pomdp.h"
#include "krr_core/pomdp/point_based_solver.h"

namespace krr {
namespace dialog {

/// @brief Which navigation knowledge the robot has (Table I's two column groups).
enum class KnowledgeCondition {
  kLearned,   ///< learned at the trial's blocking rate ("with extraction")
  kOutdated,  ///< learned at outdated_rate, 0.3 ("without extraction")
};

/// @brief "learned" / "outdated".
std::string toString(KnowledgeCondition c);
/// @throws ConfigError naming the value.
KnowledgeCondition conditionFromString(const std::string& text);

/// @brief Parameters of one delivery experiment.
struct DeliveryExperimentOptions {
  double blocking_rate = 0.3;  ///< br of the simulated world
  KnowledgeCondition condition = KnowledgeCondition::kLearned;
  double outdated_rate = 0.3;  ///< br the outdated knowledge was learned at (paper: 0.3)
  std::uint64_t seed = 1;      ///< root seed of learning and of every trial
  std::string cache_dir;       ///< learned knowledge and solved policies; empty: no cache
  std::string domain_name = "office_30x30";  ///< cache key of the navigation domain
  /// @throws ConfigError naming the field.
  void validate() const;
};

/// @brief One trial's record (see the file comment for what the reward sums).
struct DeliveryTrialResult {
  std::size_t trial = 0;
  std::size_t request = 0;        ///< hidden request index
  std::size_t served = 0;         ///< request served by the dialog
  bool correct = false;           ///< served == request
  int turns = 0;                  ///< questions asked
  bool forced = false;            ///< the serve was forced by the turn limit
  double qa_cost = 0.0;
  double entropy = 0.0;           ///< belief entropy (nats) when serving
  double served_probability = 0.0;  ///< belief in the served request when serving
  int trips = 0;                  ///< navigation tasks started
  std::size_t nav_moves = 0;      ///< moves over all trips
  bool nav_failed = false;        ///< a trip ended trapped or at the step limit
  bool redelivered = false;       ///< the redelivery rule was applied (wrong, first trip arrived)
  bool fulfilled = false;         ///< the right request was delivered in the end
  double delivery_reward = 0.0;   ///< +80 / -80
  double nav_cost = 0.0;
  double reward = 0.0;            ///< delivery_reward - qa_cost - nav_cost
};

/// @brief Timings and figures of the preparation.
struct PreparationReport {
  LearningReport learning;
  double knowledge_br = 0.0;       ///< br the knowledge was learned at
  double nav_model_seconds = 0.0;  ///< Procedure 2 + policies + P^N
  double dialog_model_seconds = 0.0;  ///< dialog knowledge reasoning + POMDP construction
  double solve_seconds = 0.0;
  bool policy_from_cache = false;
  std::string policy_file;
  bool converged = false;          ///< solver reached the precision
  /// The solve stopped at the precision or the trial budget, not at the timeout: the policy
  /// is reproducible (same model, same options -> same policy).
  bool reproducible = false;
  pomdp::BoundsReport bounds;      ///< at the initial belief (zeros when loaded from cache)
};

class DeliveryExperiment {
 public:
  /**
   * @brief Prepare everything (see the file comment). `domain` is referenced and must outlive
   * the experiment.
   * @throws ConfigError / ParseError / IoError / UnknownSymbolError from the inputs.
   */
  DeliveryExperiment(const kb::NavDomain& domain, const DialogConfig& config,
                     const DeliveryExperimentOptions& options);

  /// @brief Run trial `index` (deterministic per (seed, index)); fixed_request >= 0 replaces
  /// the drawn hidden request (tests, per-room analyses).
  DeliveryTrialResult runTrial(std::size_t index, long fixed_request = -1) const;
  /// @brief Trials begin..begin+count-1 on `threads` threads, in index order; results do not
  /// depend on threads.
  std::vector<DeliveryTrialResult> runTrials(std::size_t begin, std::size_t count,
                                             std::size_t threads) const;

  /// @brief Replace the solved policy (what-if analyses, tests). @throws ConfigError on a
  /// state-count mismatch.
  void setPolicy(const pomdp::AlphaVectorPolicy& policy);

  const pomdp::DialogPomdp& dialog() const { return *dialog_; }
  const pomdp::AlphaVectorPolicy& policy() const { return policy_; }
  const DeliveryNavigation& navigation() const { return *nav_; }
  const DialogKnowledge& dialogKnowledge() const { return *knowledge_; }
  const PreparationReport& preparation() const { return prep_; }
  const DeliveryExperimentOptions& options() const { return options_; }
  const DialogConfig& config() const { return config_; }
  /// @brief The navigation knowledge base (with the condition's learned knowledge).
  kb::NavigationKnowledge& navigationKnowledge() { return *navKnowledge_; }

 private:
  const kb::NavDomain& domain_;
  DialogConfig config_;
  DeliveryExperimentOptions options_;
  std::unique_ptr<kb::NavigationKnowledge> navKnowledge_;
  std::unique_ptr<DialogKnowledge> knowledge_;
  std::unique_ptr<DeliveryNavigation> nav_;
  std::unique_ptr<pomdp::DialogPomdp> dialog_;
  pomdp::AlphaVectorPolicy policy_;
  nav::Context context_;
  PreparationReport prep_;
};

/**
 * @brief Solve a dialog POMDP with the config's precision, trial budget and timeout (FIB
 * initialisation bounded by iterations, not time, so a run that stops at the precision or the
 * trial budget is reproducible). The solver's alpha vectors are completed with the exact
 * serve-at-once vectors R(., serve a) (valid lower-bound vectors that point-based pruning may
 * drop), so that serving is compared with asking correctly at any belief.
 * With a cache directory a reproducible policy is saved to
 * policy_<hash>.txt there, and loaded on later runs; the hash covers the exact model (its
 * Cassandra text), the solver options and a fingerprint of the solver's behaviour (its policy
 * on Tiger after 25 trials), so a changed model or solver never reuses a stale policy.
 */
pomdp::AlphaVectorPolicy solveDialogPolicy(const pomdp::DialogPomdp& dialog,
                                           const DialogConfig& config,
                                           const std::string& cache_dir,
                                           PreparationReport* report = nullptr);

/// @brief CSV header of delivery trial rows (trial index first).
std::string deliveryCsvHeader();
/// @brief One CSV row (no newline) of a trial.
std::string deliveryCsvRow(const pomdp::DialogPomdp& dialog, const DeliveryTrialResult& r);

}  // namespace dialog
}  // namespace krr
