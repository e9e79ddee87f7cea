/**
 * @file delivery_manager.h
 * @brief One delivery, from the person's first words to the end (paper, Sec. III-B, Fig. 2):
 * the dialog turns under the turn limit, the serve, the navigation legs, the check at the
 * room and the redelivery rule. The robot (dialog_node: topics and the Navigate action) and
 * the experiments (DeliveryExperiment: a simulated person and the blockage simulator) drive
 * this same class, so Table I measures the code the robot runs.
 *
 * Phases: kIdle -> start() -> kDialog -> decide() serves -> kNavigating (legs: to the shop to
 * pick the item up, then to the served room) -> kAwaitCheck at the room -> the person
 * confirms (kDone, fulfilled) or names what they asked for: back to the shop and to the right
 * room (the paper's redelivery rule, at most max_redeliveries times), then the check again.
 * A leg that does not arrive ends the delivery as failed; a check nobody answers ends it as
 * unconfirmed (or failed if the person had said it was wrong).
 *
 * Every decision is logged in a fixed vocabulary (decisions()): the model's action names
 * ("ask_item", "confirm_room_room2", "serve_coke_room2_bob"), "navigate <place>",
 * "check yes" / "check <request>", and the outcome ("fulfilled", "failed", "unconfirmed").
 * Drivers are checked against each other on this log.
 */
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "krr_core/dialog/dialog_config.h"
#include "krr_core/dialog/dialog_session.h"
#include "krr_core/dialog/language.h"
#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/pomdp/turn_limited_policy.h"

namespace krr {
namespace dialog {

enum class DeliveryPhase { kIdle, kDialog, kNavigating, kAwaitCheck, kDone };
enum class DeliveryOutcome { kNone, kFulfilled, kFailed, kUnconfirmed };
/// @brief "fulfilled", "failed", "unconfirmed" ("" for kNone).
std::string toString(DeliveryOutcome o);

/// @brief A navigation leg the manager asks for.
struct Leg {
  enum class Kind { kPickup, kToRoom, kReturn };
  Kind kind = Kind::kPickup;
  std::string place;  ///< where to go: the shop or a room name
  std::size_t room = 0;  ///< kToRoom: the destination room; kReturn: the room left (index)
};

/// @brief A leg as driven.
struct LegRecord {
  Leg leg;
  bool reached = false;
  std::size_t moves = 0;
  std::string why;  ///< why it did not arrive
};

/// @brief Everything a delivery did (what trials record and dialog_node reports).
struct DeliveryRecord {
  std::size_t served = 0;        ///< request of the serve (the dialog's decision)
  std::size_t delivering = 0;    ///< request being delivered now (after corrections)
  bool forced = false;           ///< the serve was forced by the turn limit
  int turns = 0;                 ///< questions asked
  double qa_cost = 0.0;          ///< their costs
  double entropy = 0.0;          ///< belief entropy (nats) when serving
  double served_probability = 0.0;  ///< belief in the served request when serving
  double max_probability = 0.0;  ///< belief in the most likely request when serving
  int attempts = 0;              ///< trips to a room with the item (1 + redeliveries)
  bool redelivered = false;
  std::vector<LegRecord> legs;
  DeliveryOutcome outcome = DeliveryOutcome::kNone;
  std::string message;           ///< why it ended so
  std::size_t navMoves() const;
  bool navFailed() const;        ///< a leg did not arrive
};

/// @brief What the person's words at the room did.
enum class CheckResult {
  kConfirmed,     ///< fulfilled
  kRedelivering,  ///< a different request was named: back to the shop
  kUnclear,       ///< nothing usable (ask again); the delivery goes on waiting
  kFailed,        ///< wrong, and no redelivery left
};

class DeliveryManager {
 public:
  /**
   * @param dialog, policy, language referenced (they must outlive the manager); language may
   *        be nullptr when answers come only as observations (simulated persons)
   * @throws ConfigError if the policy does not fit the model, or for a bad max_redeliveries.
   */
  DeliveryManager(const DialogPomdp& dialog, const pomdp::TurnLimitedPolicy& policy,
                  const LanguageFrontEnd* language, const DialogConfig& config);

  /// @brief A new delivery: the prior, no question asked, an empty record and log.
  void start();
  /// @brief Back to kIdle, forgetting a delivery that had not got anywhere (e.g. the first
  /// words were not understood).
  void reset();
  /// @brief The person spoke during the dialog (kDialog). When nothing was understood, the
  /// next decide() asks the last question again (no new turn, no cost): a repair, not a
  /// question of the model. @throws ConfigError in another phase.
  HearResult hear(const std::string& text);
  /// @brief The answer to `question` was `observation` (kDialog). @return false if impossible.
  bool observe(std::size_t question, std::size_t observation);
  /**
   * @brief The robot's next dialog action (kDialog): a question, now asked (a turn), or the
   * serve (forced at the turn limit), after which the phase is kNavigating with the pickup leg.
   */
  std::size_t decide();
  /// @brief The leg to drive now (kNavigating). @throws ConfigError in another phase.
  const Leg& leg() const;
  /// @brief The current leg ended: next leg, the check at the room, or failed.
  void legDone(bool reached, std::size_t moves, const std::string& why = "");
  /**
   * @brief The person's words at the room (kAwaitCheck): "yes", or what they asked for ("no, water
   * for Erin to the studio"; only what differs is needed). `reply` receives what the robot
   * should say when the result is kUnclear.
   */
  CheckResult check(const std::string& text, std::string* reply = nullptr);
  /// @brief The person names the request they asked for (kAwaitCheck; simulated persons).
  CheckResult checkRequest(std::size_t request);
  /// @brief Nobody answered the check (kAwaitCheck): unconfirmed, or failed after a "no".
  void checkTimedOut();
  /// @brief End the delivery as failed (e.g. no navigation server); no-op once done.
  void fail(const std::string& why);

  DeliveryPhase phase() const { return phase_; }
  const DialogSession& session() const { return session_; }
  /// @brief Remember the dialog decisions in `memo` (not owned; one per thread; nullptr: none).
  void setDecisionMemo(DecisionMemo* memo) { session_.setDecisionMemo(memo); }
  const DialogPomdp& dialog() const { return dialog_; }
  const DeliveryRecord& record() const { return record_; }
  const std::vector<std::string>& decisions() const { return decisions_; }
  /// @brief {item, room, person} names of a request.
  std::vector<std::string> requestNames(std::size_t request) const;

 private:
  void requirePhase(DeliveryPhase p, const char* what) const;
  void beginLegs(std::vector<Leg> legs);
  void finish(DeliveryOutcome o, const std::string& message);

  const DialogPomdp& dialog_;
  const LanguageFrontEnd* language_;
  std::string shop_;
  int maxRedeliveries_;
  DialogSession session_;
  DeliveryPhase phase_ = DeliveryPhase::kIdle;
  DeliveryRecord record_;
  std::vector<Leg> plan_;
  std::size_t next_ = 0;   // index of the current leg in plan_
  bool saidWrong_ = false; // the person said "no" at the current check
  bool repeat_ = false;    // nothing understood: ask the last question again
  std::vector<std::string> decisions_;
};

/// @brief The person a delivery serves, as a synchronous driver sees them.
class DeliveryPerson {
 public:
  virtual ~DeliveryPerson() = default;
  /// @brief First words before any question (default: none).
  virtual void open(DeliveryManager&) {}
  /// @brief Answer the robot's question. @return false if the person has nothing to say.
  virtual bool answer(DeliveryManager& m, std::size_t question) = 0;
  /// @brief Check the delivery at the room. @return false if the person says nothing.
  virtual bool check(DeliveryManager& m) = 0;
};

/// @brief Drives the legs for a synchronous driver.
class DeliveryNavigator {
 public:
  virtual ~DeliveryNavigator() = default;
  virtual LegRecord drive(const Leg& leg) = 0;
};

/**
 * @brief Run one delivery to its end with a synchronous person and navigator (trials,
 * scripted deliveries): start, the person's opening, questions and answers, legs, checks.
 * @return false if the person fell silent during the dialog (the dialog is left unfinished).
 */
bool runDelivery(DeliveryManager& m, DeliveryPerson& person, DeliveryNavigator& nav);

/// @brief The reward of a finished delivery of `request` (the terms of dialog_knowledge.h):
/// +-80, question costs, step_cost per move and failure_penalty if a leg failed (weighted by
/// serve_cost.weight when its mode is expected), and wrong_delivery_penalty if the served
/// request was not `request`.
struct DeliveryReward {
  double delivery = 0.0, qa = 0.0, navigation = 0.0, penalty = 0.0;
  double total() const { return delivery - qa - navigation - penalty; }
};
DeliveryReward deliveryReward(const DeliveryRecord& r, std::size_t request, const DialogConfig& c);

}  // namespace dialog
}  // namespace krr
