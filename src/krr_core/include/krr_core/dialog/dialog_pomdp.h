/**
 * @file dialog_pomdp.h
 * @brief The delivery-dialog POMDP of the KRR-RL paper (Sec. III-B, IV), parametrised.
 *
 * Hidden state: the service request <item, room, person> (|I| |R| |P| states, 30 in the
 * paper) plus one absorbing terminal state entered by every serve action. Actions: three
 * general questions ("which item / room / person?", cost 2.0), one confirming question per
 * value ("is it tea?", cost 1.5), and serve(I,R,P) for every request. Serving request a when
 * the true request is s is fulfilled with probability T^D(s, a) (the paper's delivery
 * equation, computed by the knowledge base from navigation reach probabilities): reward +80
 * if fulfilled, -80 otherwise, so R(s, serve a) = 80 T^D - 80 (1 - T^D) (minus serveCost(s, a)
 * when DialogSpec::serveCost is given). Observations: the
 * item / room / person names (answers to general questions, correct with p_general, otherwise
 * uniform over the other values), yes / no (answers to confirming questions, correct with
 * p_yesno) and none (after serving). All numbers are inputs: the KB feeds them later.
 *
 * Domain code of the dialog module, built on the generic POMDP machinery of pomdp/. The
 * solvers' tests and benchmarks also use it as their structured test model.
 */
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "krr_core/pomdp/belief.h"
#include "krr_core/pomdp/model.h"

namespace krr {
namespace dialog {

/// @brief Everything the dialog model is built from. Request index:
/// s = (item * |R| + room) * |P| + person. The names have no default: they are a building's
/// (dialogSpecFromKnowledge reads them from its knowledge base), and DialogPomdp refuses empty
/// lists; placeholderNames() gives generic ones where only the counts matter.
struct DialogSpec {
  std::vector<std::string> items;
  std::vector<std::string> rooms;
  std::vector<std::string> persons;
  Eigen::VectorXd prior;     ///< over requests; empty = uniform
  Eigen::MatrixXd delivery;  ///< T^D(s, a): requests x serve actions; empty = all 1
  /// Extra cost subtracted from R(s, serve a) (requests x serve actions, finite); empty = 0.
  /// The knowledge base uses it for the navigation cost of the trips a delivery implies.
  Eigen::MatrixXd serveCost;
  double pGeneral = 0.8;     ///< accuracy of answers to general questions
  double pYesNo = 0.8;       ///< accuracy of yes/no answers
  double generalCost = 2.0;
  double confirmCost = 1.5;
  double successReward = 80.0;
  double failureReward = -80.0;
  double discount = 0.99;  ///< not given in the paper; questions already carry costs
  int turnLimit = 20;  ///< questions allowed before a serve is forced (solved with the limit)
};

/**
 * @brief `spec` with generic names item_1.., room_1.., person_1.. for the given counts, for
 * models where only the sizes matter (benchmarks).
 */
DialogSpec placeholderNames(DialogSpec spec, std::size_t items, std::size_t rooms,
                            std::size_t persons);

/// @brief Kind of a dialog action.
enum class DialogActionKind {
  kAskItem, kAskRoom, kAskPerson, kConfirmItem, kConfirmRoom, kConfirmPerson, kServe
};

/**
 * @brief T^D from navigation reach probabilities, by the paper's delivery equation:
 * T^D(s, a) = P^N(shop, room(s)) if a = s, else P^N(shop, room(a)) P^N(room(a), shop)
 * P^N(shop, room(s)). reachBack empty means P^N(room, shop) = P^N(shop, room).
 * @throws ConfigError on sizes or values outside [0, 1].
 */
Eigen::MatrixXd deliveryMatrix(std::size_t numItems, const Eigen::VectorXd& reachFromShop,
                               std::size_t numPersons,
                               const Eigen::VectorXd& reachBack = Eigen::VectorXd());

/// @brief Prior where person p asks for delivery to ownRoom[p] with probability pOwn (the
/// paper's pr(curr_room(P)=R | place(P,R)) = 8/10), the other rooms uniformly, items and
/// persons uniformly.
Eigen::VectorXd ownOfficePrior(std::size_t numItems, std::size_t numRooms,
                               const std::vector<std::size_t>& ownRoom, double pOwn);

/// @brief The dialog POMDP and its index bookkeeping.
class DialogPomdp {
 public:
  /// @throws ConfigError naming the field (sizes, probabilities, names, costs).
  explicit DialogPomdp(DialogSpec spec);

  const pomdp::Model& model() const { return model_; }
  const DialogSpec& spec() const { return spec_; }
  std::size_t numRequests() const { return nReq_; }
  std::size_t terminalState() const { return nReq_; }
  std::size_t requestIndex(std::size_t item, std::size_t room, std::size_t person) const;
  /// @brief {item, room, person} of a request index.
  std::array<std::size_t, 3> requestParts(std::size_t request) const;
  std::string requestName(std::size_t request) const;

  DialogActionKind actionKind(std::size_t a) const;
  bool isServe(std::size_t a) const { return a >= firstServe_; }
  bool isQuestion(std::size_t a) const { return a < firstServe_; }
  std::size_t serveAction(std::size_t request) const { return firstServe_ + request; }
  std::size_t requestOfServe(std::size_t a) const { return a - firstServe_; }
  std::size_t askItem() const { return 0; }
  std::size_t askRoom() const { return 1; }
  std::size_t askPerson() const { return 2; }
  std::size_t confirmItem(std::size_t i) const { return 3 + i; }
  std::size_t confirmRoom(std::size_t r) const { return 3 + nI_ + r; }
  std::size_t confirmPerson(std::size_t p) const { return 3 + nI_ + nR_ + p; }
  std::size_t obsItem(std::size_t i) const { return i; }
  std::size_t obsRoom(std::size_t r) const { return nI_ + r; }
  std::size_t obsPerson(std::size_t p) const { return nI_ + nR_ + p; }
  std::size_t obsYes() const { return nI_ + nR_ + nP_; }
  std::size_t obsNo() const { return obsYes() + 1; }
  std::size_t obsNone() const { return obsYes() + 2; }

  /// @brief Marginals of a belief over items, rooms and persons (terminal mass ignored).
  std::array<Eigen::VectorXd, 3> marginals(const pomdp::Belief& b) const;
  /// @brief The model in Cassandra .pomdp format (for SARSOP comparisons).
  std::string exportCassandra() const;

 private:
  DialogSpec spec_;
  std::size_t nI_, nR_, nP_, nReq_, firstServe_;
  std::vector<int> itemOf_, roomOf_, personOf_;
  pomdp::Model model_;
  pomdp::Model build();
};

}  // namespace dialog
}  // namespace krr
