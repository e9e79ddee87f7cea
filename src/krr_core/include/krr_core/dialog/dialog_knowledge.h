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
 *    navigation model built from the current knowledge base (TripTable);
 *  - the serve reward's consequences (below), from the same trips and config/dialog.yaml.
 *
 * The serve reward (the one place it is defined; DeliveryExperiment records the same terms
 * per trial, so E[trial reward | s, a] = R(s, serve a) - QA cost):
 *
 *   R(s, serve a) = 80 T^D(s, a) - 80 (1 - T^D(s, a))          paper: +-80 on T^D
 *                   - w N(s, a)                               serve_cost.mode expected
 *                   - P_w [a != s]                            serve_cost.wrong_delivery_penalty
 *   N(s, a) = C(shop, a) + [a != s] P^N(shop, a) (C(a, shop) + P^N(a, shop) C(shop, s))
 *   C(x, y) = step_cost M(x, y) + failure_penalty (1 - P^N(x, y))
 *
 * N is the exact expected navigation cost of the trips actually driven: the first trip; after
 * a wrong delivery that arrived, back to the shop and, if that arrived, to the right room (the
 * paper's redelivery rule); M the expected moves and P^N the reach probability of a trip under
 * the robot's policy (DeliveryNavigation). Rooms are those of the requests.
 *
 * Why more than the paper's formula. With +-80 alone, a wrong delivery to a room the robot
 * always reaches costs nothing: T^D(s, a) = P^N(shop, a) P^N(a, shop) P^N(shop, s) =
 * P^N(shop, s) = T^D(s, s) when P^N(shop, a) = P^N(a, shop) = 1 (a room beside the shop
 * with no blocking area on the way). The optimal policy then serves such a room at once,
 * whatever was asked for, and uses the redelivery rule as a free oracle (a request for a far
 * room served to that near room). Charging the trips driven makes the probe cost two trips,
 * still cheap next to questions; the penalty
 * P_w charges what the person experiences: they waited and got the wrong item. With the
 * default P_w (dialog.yaml) the robot serves only a request it believes, and the request it
 * serves is the most likely one (tested in test_dialog_knowledge and the dialog rostests).
 */
#pragma once

#include <string>

#include <Eigen/Dense>

#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/plog/reasoner.h"
#include "krr_core/dialog/dialog_pomdp.h"

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
  const DialogSpec& base() const { return base_; }
  const SpeechModel& speech() const { return speech_; }
  const Eigen::VectorXd& prior() const { return base_.prior; }
  std::size_t numRequests() const { return static_cast<std::size_t>(base_.prior.size()); }
  /// @brief Room index of request s.
  std::size_t roomOf(std::size_t s) const { return (s / base_.persons.size()) % base_.rooms.size(); }

  /**
   * @brief Navigation costs N(s, a) of the file comment (requests x requests), unweighted;
   * zero for ServeCostMode::kNone. @throws ConfigError if the rooms differ.
   */
  Eigen::MatrixXd serveCosts(const TripTable& trips, ServeCostMode mode) const;

  /**
   * @brief The dialog POMDP's specification: base() + speech model + costs / rewards / turn
   * limit of `config` + T^D by the delivery equation + the serve reward's other terms (file
   * comment). The one builder of the robot's and the experiments' dialog models.
   * @throws ConfigError if the trips' rooms are not the knowledge base's rooms (same order).
   */
  DialogSpec buildSpec(const TripTable& trips, const DialogConfig& config) const;

  plog::Reasoner& reasoner() { return reasoner_; }

 private:
  void reasonSpeech();
  void checkRooms(const TripTable& trips) const;

  plog::Reasoner reasoner_;
  std::string names_;  // the files, for messages
  DialogSpec base_;
  SpeechModel speech_;
};

}  // namespace dialog
}  // namespace krr
