/**
 * @file dialog_knowledge.h
 * @brief The dialog POMDP constructed by reasoning (paper, Sec. III-B "Constructing (PO)MDP
 * controllers" and Sec. IV "Learn from navigation and applied to delivery").
 *
 * Every number of the model comes from a knowledge source, none is written in code:
 *  - requests <item, room, person> and the initial belief: P(request(I, R, P)) for every
 *    request, by P-log reasoning over config/office.plog (people request deliveries to their
 *    own offices with probability 0.8, ...);
 *  - the speech model: config/dialog.plog, queried for every request:
 *      P(heard_item = w | do(curr_person=P), do(curr_item(P)=I), do(curr_room(P)=R)), and the
 *      same for heard_room and heard_person (answers to general questions);
 *      P(yes_item = true | do(asked_item = v), <request>), and yes_room / yes_person (answers
 *      to confirming questions).
 *    The tables must have the form the dialog POMDP uses (the true value heard with one
 *    accuracy p_general, the others evenly; yes / no right with one accuracy p_yesno); any
 *    other shape is reported as a ConfigError naming the request and value;
 *  - costs, rewards, turn limit: config/dialog.yaml (DialogConfig);
 *  - T^D(s, a): the paper's delivery equation over P^N(shop, room) and P^N(room, shop) of the
 *    navigation model built from the current knowledge base (DeliveryNavigation);
 *  - serve costs (our extension, DialogConfig::serve_cost_mode): the navigation cost of the
 *    trips a delivery implies (C from DeliveryNavigation), in the serve reward.
 *
 * Why the extension. With the paper's R(s, serve a) = 80 T^D - 80 (1 - T^D) alone, the regret
 * of serving a when the request is s is 160 P^N(shop, s) (1 - P^N(shop, a) P^N(a, shop)). On the
 * office map room1 and room4 are never blocked (P^N = 1), so serving any room1 / room4 request
 * loses nothing: T^D(s, a) = P^N(shop, s) = T^D(s, s) for every s. The optimal dialog policy
 * then asks nothing at all and always serves such a request, using the redelivery rule ("go
 * back, learn the request, deliver again") as a free oracle; "harder room -> more questions"
 * cannot hold. For same-room confusions (item or person misheard) the regret is
 * 160 q (1 - q^2), q = P^N(shop, room) = P^N(room, shop): it vanishes for q -> 1 and q -> 0.
 * Charging the navigation tasks the delivery equation names (ServeCostMode::kTasks: one task
 * for a right delivery, three for a wrong one, each at its expected cost C = step_cost x moves
 * + failure_penalty x P(fail), the paper's navigation reward without the goal bonus) adds
 * C(a, shop) + C(shop, s) to every wrong delivery, which grows as navigation gets harder.
 * ServeCostMode::kExpected instead charges the exact expected navigation cost of the executed
 * trial (a later trip only if the earlier ones arrived): consistent with the cost a trial
 * records, but it multiplies the redelivery cost by P^N(shop, a) again, so it fades for very
 * hard rooms.
 */
#pragma once

#include <string>

#include <Eigen/Dense>

#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/plog/reasoner.h"
#include "krr_core/pomdp/dialog_pomdp.h"

namespace krr {
namespace dialog {

/// @brief Accuracies of speech understanding, as reasoned from the knowledge base.
struct SpeechModel {
  double p_general = 0.0;  ///< P(the true value is heard) for general questions
  double p_yesno = 0.0;    ///< P(the right yes / no is heard) for confirming questions
};

/// @brief Dialog knowledge: office + speech model, and the POMDP built from it.
class DialogKnowledge {
 public:
  /**
   * @brief Load the office knowledge and the speech model (in that order) into a reasoner and
   * reason out the prior and the speech accuracies.
   * @throws ParseError / UnknownSymbolError / IoError from loading, ConfigError when the
   *         speech model has a shape the dialog POMDP cannot represent or misses an attribute.
   */
  DialogKnowledge(const std::string& office_plog, const std::string& speech_plog);

  /// @brief Items, rooms, persons, prior (DialogSpec request order), from the reasoner.
  const pomdp::DialogSpec& base() const { return base_; }
  const SpeechModel& speech() const { return speech_; }
  const Eigen::VectorXd& prior() const { return base_.prior; }
  std::size_t numRequests() const { return static_cast<std::size_t>(base_.prior.size()); }
  /// @brief Room index of request s.
  std::size_t roomOf(std::size_t s) const { return (s / base_.persons.size()) % base_.rooms.size(); }

  /**
   * @brief Serve costs K(s, a) (requests x requests), before weighting:
   * kNone: 0; kTasks: C(shop, a) + [a != s] (C(a, shop) + C(shop, s));
   * kExpected: C(shop, a) + [a != s] P^N(shop, a) (C(a, shop) + P^N(a, shop) C(shop, s)),
   * rooms written for the requests' rooms. @throws ConfigError if the rooms differ.
   */
  Eigen::MatrixXd serveCosts(const DeliveryNavigation& nav, ServeCostMode mode) const;

  /**
   * @brief The dialog POMDP's specification: base() + speech model + costs / rewards / turn
   * limit of `config` + T^D from `nav` by the delivery equation + weighted serve costs.
   * @throws ConfigError if nav's rooms are not the knowledge base's rooms (same order).
   */
  pomdp::DialogSpec buildSpec(const DeliveryNavigation& nav, const DialogConfig& config) const;

  plog::Reasoner& reasoner() { return reasoner_; }

 private:
  void reasonSpeech();
  void checkRooms(const DeliveryNavigation& nav) const;

  plog::Reasoner reasoner_;
  std::string names_;  // the files, for messages
  pomdp::DialogSpec base_;
  SpeechModel speech_;
};

}  // namespace dialog
}  // namespace krr
