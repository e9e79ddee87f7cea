/**
 * @file dialog_script.h
 * @brief Scripted dialogs: replay a list of user utterances and record the belief per turn
 * (as in the paper's Figure 4: a request in free text, then the answers).
 *
 * Turn 0 is the prior; the robot greets and the user speaks first (utterance 1, as in the
 * paper). Before every further utterance the robot acts: the next scripted question if one is
 * left, otherwise the policy's action. Each turn k >= 1 records the question the user
 * answered, the utterance, what was understood, and the marginals over items, persons and
 * rooms with the entropy of the joint belief after it. The action the robot takes next
 * (scripted or from the policy) is recorded in every row; if it is a serve, the dialog ends
 * and the remaining utterances are returned as unused.
 */
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "krr_core/dialog/delivery_manager.h"
#include "krr_core/dialog/dialog_session.h"

namespace krr {
namespace dialog {

/// @brief The action name meaning "the robot asks nothing" in a script (and the greeting).
constexpr const char* kNoQuestion = "none";

/// @brief One row of a scripted dialog.
struct ScriptTurn {
  int turn = 0;                 ///< 0 = prior
  std::string robotAction;      ///< the action the user answered ("none" for the greeting)
  std::string robotText;        ///< what the robot said
  std::string user;             ///< the utterance ("" at turn 0)
  HearResult heard;             ///< what was understood
  BeliefSummary belief;         ///< after the utterance
  std::string nextAction;       ///< what the robot does next ("" if unknown: no policy)
  std::string nextText;
};

/// @brief A scripted dialog.
struct ScriptResult {
  std::vector<ScriptTurn> turns;
  bool served = false;             ///< the robot decided to serve before or after the script
  std::size_t servedRequest = 0;   ///< request index of that serve
  std::vector<std::string> unusedUtterances;  ///< utterances after the robot served
};

/// @brief Model action index of an action name ("ask_item", "confirm_room_room2",
/// "serve_coke_room2_bob"); -1 for kNoQuestion. @throws ConfigError listing valid names.
long actionByName(const DialogPomdp& dialog, const std::string& name);

/**
 * @brief Run a scripted dialog (see the file comment).
 * @param policy may be nullptr if `questions` holds one question per utterance after the first.
 * @param questions robot actions by name, before utterances 2, 3, ... (kNoQuestion: none).
 * @throws ConfigError for unknown action names, no utterance, or a missing question without
 *         a policy (checked before running).
 */
ScriptResult runDialogScript(const DialogPomdp& dialog, const LanguageFrontEnd& language,
                             const pomdp::TurnLimitedPolicy* policy,
                             const std::vector<std::string>& questions,
                             const std::vector<std::string>& utterances);

/// @brief A scripted delivery: what the person says and how the legs end.
struct DeliveryScript {
  std::vector<std::string> utterances;  ///< the opening, then one answer per question
  std::vector<std::string> checks;      ///< what the person says at the room, in order
  std::vector<bool> legs;               ///< leg outcomes in order; missing ones arrive
};

/// @brief What the robot did on a scripted delivery.
struct ScriptedDelivery {
  bool completed = false;          ///< the delivery ended (the script did not run out first)
  DeliveryRecord record;
  std::vector<std::string> decisions;   ///< DeliveryManager::decisions()
  std::vector<std::string> unusedUtterances;
};

/**
 * @brief Run a scripted delivery through the robot's DeliveryManager (runDelivery): the same
 * class dialog_node drives from topics, so the two can be compared decision by decision.
 * @throws ConfigError for an empty script.
 */
ScriptedDelivery runScriptedDelivery(const DialogPomdp& dialog,
                                     const LanguageFrontEnd& language,
                                     const pomdp::TurnLimitedPolicy& policy,
                                     const DialogConfig& config, const DeliveryScript& script);
/// @brief {"completed": ..., "decisions": [...], "outcome": ..., "served": ..., ...}
std::string scriptedDeliveryToJson(const DialogPomdp& dialog, const ScriptedDelivery& d);

/**
 * @brief One CSV row per turn: turn, robot_action, robot_text, user, observations,
 * unknown_words, notes, item_<name>..., person_<name>..., room_<name>..., entropy,
 * most_likely, most_likely_p, next_action, next_text (RFC 4180 quoting, lists joined by ';').
 */
std::string scriptToCsv(const DialogPomdp& dialog, const ScriptResult& r);
/// @brief The same as one JSON object {"turns": [...], "served": ..., "unused_utterances": [...]}.
std::string scriptToJson(const DialogPomdp& dialog, const ScriptResult& r);
/// @brief A readable transcript with the marginals, for terminals.
std::string scriptToText(const DialogPomdp& dialog, const ScriptResult& r);

}  // namespace dialog
}  // namespace krr
