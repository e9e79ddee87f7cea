/**
 * @file dialog_session.h
 * @brief One live dialog: exact belief over requests, the robot's questions, the user's text.
 *
 * The session is what a dialog manager (the dialog_node, the dialog_script CLI) runs: the
 * robot asks what the policy (or a script) says, the user answers in free text, the language
 * front end turns the text into observations of the dialog POMDP and the session applies
 * them by exact Bayesian updates (a simulated person's answers come in as observations,
 * observe()). A turn is one robot question. With a policy that has plans
 * (TurnLimitedPolicy::next), the session follows the plan it is on: the answer to the plan's
 * question, alone in its utterance, leads to the plan's continuation in O(1); any other
 * content (extra slots, several answers, a question the plan did not ask) leaves the plan,
 * and the next decision scans the policy (decideDialog) and takes up the plan it finds. Either
 * way the robot earns at least the value of the plan it is on. This is the one place of the turn-limit rule:
 * once the model's turnLimit questions have been asked, nextAction() serves the most likely
 * request (paper: "in case a dialog does not end after 20 turns, the robot is forced to work
 * on the most likely delivery"); the policy is solved knowing that limit
 * (CertifiedDialogSolver), so it must itself serve there, and a policy that still asks is
 * reported as an error instead of being silently overridden. Nothing the user says can crash
 * the session: unknown words, ignored answers and observations the model deems impossible
 * are reported in the HearResult.
 */
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <unordered_map>
#include <vector>

#include "krr_core/dialog/language.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/pomdp/turn_limited_policy.h"

namespace krr {
namespace dialog {

/// @brief The outcome of one user utterance.
struct HearResult {
  std::string text;                              ///< what the user said
  std::vector<DialogObservation> applied;        ///< observations used to update the belief
  std::vector<std::string> unknownWords;         ///< words the front end did not know
  std::vector<std::string> notes;                ///< why content was ignored
  /// @brief True if the belief was updated.
  bool understood() const { return !applied.empty(); }
};

/// @brief Marginals of a belief in the paper's Figure 4 order, with its entropy.
struct BeliefSummary {
  Eigen::VectorXd items, persons, rooms;
  double entropy = 0.0;          ///< of the joint belief over requests, nats
  std::size_t mostLikely = 0;    ///< request index of the belief's mode
  double mostLikelyProbability = 0.0;
};

/// @brief A decision and the plan it starts: the policy vector whose plan begins with the
/// action (-1: none, e.g. a question the lookahead preferred, or the forced serve).
struct DialogDecision {
  std::size_t action = 0;
  long plan = -1;
};

/**
 * @brief decideDialog() remembered per (belief, turns) for one dialog model and policy. The
 * belief is a function of the questions and answers so far, so the deliveries of an experiment
 * revisit the same beliefs again and again; an exact key (the belief's bits) returns exactly
 * the decision decideDialog() would make. Not thread-safe: one per thread. Bounded: forgets
 * everything past `capacity` entries.
 */
class DecisionMemo {
 public:
  explicit DecisionMemo(std::size_t capacity = 1u << 16) : capacity_(capacity) {}
  DialogDecision decide(const DialogPomdp& dialog, const pomdp::TurnLimitedPolicy& policy,
                        const pomdp::Belief& b, int turns);
  std::size_t hits() const { return hits_; }
  std::size_t misses() const { return misses_; }

 private:
  std::size_t capacity_;
  std::unordered_map<std::string, DialogDecision> memo_;
  std::string key_;
  std::size_t hits_ = 0, misses_ = 0;
};

/// @brief A dialog in progress (see the file comment).
class DialogSession {
 public:
  /**
   * @param dialog the dialog model (referenced: it must outlive the session)
   * @param language the front end, or nullptr when answers come only as observations
   *        (referenced: it must outlive the session)
   * @param policy the policy choosing questions, or nullptr for scripted dialogs (then
   *        nextAction() is only available at the turn limit)
   * @throws ConfigError if the policy's state count or turn limit differs from the model's.
   */
  DialogSession(const DialogPomdp& dialog, const LanguageFrontEnd* language,
                const pomdp::TurnLimitedPolicy* policy = nullptr);

  /// @brief Back to the prior, no question asked.
  void reset();
  /// @brief Remember nextAction()'s decisions in `memo` (not owned; nullptr: none).
  void setDecisionMemo(DecisionMemo* memo) { memo_ = memo; }
  /// @brief The policy's action at the current belief and turn, or serve(most likely request)
  /// at the turn limit. @throws ConfigError without a policy before the turn limit, when
  /// finished, or when the policy asks a question at the turn limit.
  std::size_t nextAction() const;
  /// @brief True when the turn limit has been reached.
  bool atTurnLimit() const { return turns_ >= dialog_.spec().turnLimit; }
  /// @brief The robot asks question a (counts a turn; yes / no now answer it) or serves
  /// (the dialog is finished). @throws ConfigError for an out-of-range action or when finished.
  void act(std::size_t a);
  /// @brief The user said `text`: understand it and update the belief. Never throws on text.
  /// @throws ConfigError without a language front end.
  HearResult hear(const std::string& text);
  /// @brief The answer to `question` was `observation` (a simulated person): exact update.
  /// @return false (belief unchanged) if the model deems it impossible now.
  /// @throws ConfigError for an action that is not a question or an unknown observation.
  bool observe(std::size_t question, std::size_t observation);

  const pomdp::Belief& belief() const { return belief_; }
  BeliefSummary summary() const;
  int turns() const { return turns_; }
  /// @brief The policy vector whose plan the next decision follows, -1 when it scans.
  long plan() const { return plan_; }
  /// @brief The last question asked, -1 if none yet.
  long lastQuestion() const { return lastQuestion_; }
  bool finished() const { return finished_; }
  /// @brief The request served (valid once finished()).
  std::size_t servedRequest() const { return served_; }
  const DialogPomdp& dialog() const { return dialog_; }

 private:
  const DialogPomdp& dialog_;
  const LanguageFrontEnd* language_;
  const pomdp::TurnLimitedPolicy* policy_;
  DecisionMemo* memo_ = nullptr;
  long plan_ = -1;                  ///< plan to follow at the current belief (-1: scan)
  long asked_ = -1;                 ///< plan whose question awaits its answer
  mutable DialogDecision pending_;  ///< nextAction()'s last decision
  /// @brief The answer o to question q was applied: move along the plan, or leave it.
  void advance(std::size_t q, std::size_t o);
  pomdp::Belief belief_;
  int turns_ = 0;
  long lastQuestion_ = -1;
  bool finished_ = false;
  std::size_t served_ = 0;
};

/**
 * @brief The robot's action at belief b after `turns` questions (the one decision rule of the
 * robot and the experiments): serve(most likely request) at the turn limit; otherwise the
 * policy's action, except that before serving the robot checks by a one-step lookahead on the
 * policy's values whether some question is worth more than that serve (the vectors of a
 * point-based policy are tight only near the beliefs the solver visited; the lookahead keeps
 * the robot from serving at beliefs it never planned for). Never worse than the policy's
 * guarantee, except at the turn limit: a person expects the most likely request there, and
 * the reward's best serve can be a cheap probe to a near room (seed 17 of
 * DialogKnowledge.EveryServeIsTheMostLikelyRequest: P 0.001 against 0.25), while the certified
 * plans assume the best-reward serve; on a 6-turn office model the executed value fell below
 * the exported one by up to 0.14 (CertifiedDialogSolver tests). A confirmation on a slot of two
 * values names the value the belief favours (the same experiment either way).
 * @throws ConfigError when the policy asks at the turn limit.
 */
DialogDecision decideDialog(const DialogPomdp& dialog, const pomdp::TurnLimitedPolicy& policy,
                            const pomdp::Belief& b, int turns);
/// @brief decideDialog()'s action.
inline std::size_t decideAction(const DialogPomdp& dialog, const pomdp::TurnLimitedPolicy& policy,
                                const pomdp::Belief& b, int turns) {
  return decideDialog(dialog, policy, b, turns).action;
}

/// @brief summary() of any belief of the dialog model.
BeliefSummary summarizeBelief(const DialogPomdp& dialog, const pomdp::Belief& b);

}  // namespace dialog
}  // namespace krr

