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
 *  3. the dialog POMDP by reasoning (DialogKnowledge::buildSpec) and its turn-limited policy
 *     (solveDialogPolicy: the same builder, solver options and cache as dialog_node).
 *
 * One trial (deterministic per (seed, index): streams "delivery/request", "delivery/dialog",
 * "delivery/navigation" with the trial index; they do not depend on the condition or br, so
 * conditions are compared on the same requests and answers' random numbers) is one run of the
 * robot's DeliveryManager (runDelivery) with
 *  - a simulated person: the hidden request is drawn from the knowledge base's prior; every
 *    question is answered through the speech model (the model's observation probabilities);
 *    at the room the person confirms or names the request (the paper: the second dialog
 *    identifies it correctly);
 *  - simulated navigation: the robot starts at the shop (the pickup leg is empty) and drives
 *    every leg in the blockage simulator at the trial's br with the policy of the condition's
 *    knowledge; a leg that ends trapped or at the step limit ends the trial unfulfilled.
 * The recorded reward is deliveryReward(): +80 / -80, minus the questions' costs, the
 * navigation cost of the moves driven (+ failure_penalty if a leg failed) and the
 * wrong-delivery penalty: the terms of the serve reward (dialog_knowledge.h), realised.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "krr_core/experiments/delivery_learning.h"
#include "krr_core/dialog/delivery_manager.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "krr_core/dialog/dialog_policy.h"
#include "krr_core/experiments/nav_transfer.h"
#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/pomdp/turn_limited_policy.h"

namespace krr {
namespace experiments {

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
  /// Cache key of the navigation domain; empty until the CLI resolves the site's default
  /// domain (the experiment itself needs it named).
  std::string domain_name;
  /// @throws ConfigError naming the field (an empty domain_name is allowed here).
  void validate() const;
};

/// @brief One trial's record (see the file comment for what the reward sums).
struct DeliveryTrialResult {
  std::size_t trial = 0;
  std::size_t request = 0;        ///< hidden request index
  dialog::DeliveryRecord delivery;        ///< what the robot's delivery manager did
  bool correct = false;           ///< served == request (identification)
  bool fulfilled = false;         ///< the right request was delivered in the end
  dialog::DeliveryReward reward;
  /// E[reward | request, served] under the true world (the simulator's exact dynamics with
  /// the robot's policies) minus the realised QA cost: the trial's reward without the luck of
  /// navigation (decision theory's measure of the knowledge behind the serve).
  double expected_reward = 0.0;
};

/// @brief Timings and figures of the preparation.
struct PreparationReport {
  LearningReport learning;
  double knowledge_br = 0.0;       ///< br the knowledge was learned at
  double nav_model_seconds = 0.0;  ///< Procedure 2 + policies + P^N
  double dialog_model_seconds = 0.0;  ///< dialog knowledge reasoning + POMDP construction
  dialog::PolicyReport policy;             ///< how the dialog policy was obtained, its bounds
};

class DeliveryExperiment {
 public:
  /**
   * @brief Prepare everything (see the file comment). `domain` is referenced and must outlive
   * the experiment. Without solve_policy the dialog model is built but not solved: trials
   * need setPolicy() first (benchmarks of the solver).
   * @throws ConfigError / ParseError / IoError / UnknownSymbolError from the inputs.
   */
  DeliveryExperiment(const kb::NavDomain& domain, const dialog::DialogConfig& config,
                     const DeliveryExperimentOptions& options, bool solve_policy = true);

  /// @brief Run trial `index` (deterministic per (seed, index)); fixed_request >= 0 replaces
  /// the drawn hidden request (tests, per-room analyses).
  DeliveryTrialResult runTrial(std::size_t index, long fixed_request = -1,
                               dialog::DecisionMemo* memo = nullptr) const;
  /// @brief Trials begin..begin+count-1 on `threads` threads, in index order; results do not
  /// depend on threads.
  std::vector<DeliveryTrialResult> runTrials(std::size_t begin, std::size_t count,
                                             std::size_t threads) const;

  /// @brief Replace the solved policy (benchmarks, what-if analyses, tests).
  /// @throws ConfigError on a state-count or turn-limit mismatch.
  void setPolicy(const pomdp::TurnLimitedPolicy& policy);

  const dialog::DialogPomdp& dialog() const { return *dialog_; }
  /// @brief max over requests s and serve actions a of |R(s, serve a) of the robot's model -
  /// R(s, serve a) under the true world|: what the knowledge's P^N error does to the rewards.
  /// An optimal policy of the robot's model loses at most twice this against the true optimum.
  double rewardError() const;
  const pomdp::TurnLimitedPolicy& policy() const { return policy_; }
  const dialog::DeliveryNavigation& navigation() const { return *nav_; }
  /// @brief The trips of the robot's navigation policies in the true world at the trial's br.
  const dialog::TripTable& trueTrips() const { return true_trips_; }
  const dialog::DialogKnowledge& dialogKnowledge() const { return *knowledge_; }
  const PreparationReport& preparation() const { return prep_; }
  const DeliveryExperimentOptions& options() const { return options_; }
  const dialog::DialogConfig& config() const { return config_; }
  /// @brief The navigation knowledge base (with the condition's learned knowledge).
  kb::NavigationKnowledge& navigationKnowledge() { return *navKnowledge_; }

 private:
  const kb::NavDomain& domain_;
  dialog::DialogConfig config_;
  DeliveryExperimentOptions options_;
  std::unique_ptr<kb::NavigationKnowledge> navKnowledge_;
  std::unique_ptr<dialog::DialogKnowledge> knowledge_;
  std::unique_ptr<dialog::DeliveryNavigation> nav_;
  std::unique_ptr<dialog::DialogPomdp> dialog_;
  dialog::TripTable true_trips_;
  std::unique_ptr<dialog::DialogPomdp> true_dialog_;  // the serve rewards under true_trips_
  pomdp::TurnLimitedPolicy policy_;
  nav::Context context_;
  PreparationReport prep_;
};

/// @brief CSV header of delivery trial rows (trial index first).
std::string deliveryCsvHeader();
/// @brief One CSV row (no newline) of a trial; `policy` are the bounds of the policy used.
std::string deliveryCsvRow(const dialog::DialogPomdp& dialog, double rewardError,
                           const DeliveryTrialResult& r,
                           const pomdp::BoundsReport& policy);

}  // namespace experiments
}  // namespace krr
