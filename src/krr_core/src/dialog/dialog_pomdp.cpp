#include "krr_core/dialog/dialog_pomdp.h"

#include <cmath>
#include <set>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/cassandra_io.h"

namespace krr {
namespace dialog {

namespace {

void checkProb(double p, const std::string& field) {
  if (!(p >= 0.0 && p <= 1.0))
    throw ConfigError("dialog POMDP: " + field + " = " + std::to_string(p) +
                      " is not a probability");
}

void checkNames(const std::vector<std::string>& v, const std::string& field) {
  if (v.empty())
    throw ConfigError("dialog POMDP: " + field + " is empty (the names are the building's: "
                      "from its knowledge base, or placeholderNames)");
  std::set<std::string> seen;
  for (const auto& n : v) {
    if (n.empty()) throw ConfigError("dialog POMDP: empty name in " + field);
    if (!seen.insert(n).second)
      throw ConfigError("dialog POMDP: duplicate name '" + n + "' in " + field);
  }
}

}  // namespace

Eigen::MatrixXd deliveryMatrix(std::size_t numItems, const Eigen::VectorXd& reachFromShop,
                               std::size_t numPersons, const Eigen::VectorXd& reachBack) {
  const std::size_t nR = static_cast<std::size_t>(reachFromShop.size());
  if (numItems == 0 || nR == 0 || numPersons == 0)
    throw ConfigError("deliveryMatrix: empty item, room or person set");
  Eigen::VectorXd back = reachBack.size() == 0 ? reachFromShop : reachBack;
  if (static_cast<std::size_t>(back.size()) != nR)
    throw ConfigError("deliveryMatrix: reachBack has " + std::to_string(back.size()) +
                      " rooms, reachFromShop has " + std::to_string(nR));
  for (std::size_t r = 0; r < nR; ++r) {
    checkProb(reachFromShop(r), "reachFromShop[" + std::to_string(r) + "]");
    checkProb(back(r), "reachBack[" + std::to_string(r) + "]");
  }
  const std::size_t n = numItems * nR * numPersons;
  auto roomOf = [&](std::size_t s) { return (s / numPersons) % nR; };
  Eigen::MatrixXd td(n, n);
  for (std::size_t s = 0; s < n; ++s)
    for (std::size_t a = 0; a < n; ++a) {
      const std::size_t goal = roomOf(s), mis = roomOf(a);
      td(s, a) = s == a ? reachFromShop(goal)
                        : reachFromShop(mis) * back(mis) * reachFromShop(goal);
    }
  return td;
}

Eigen::VectorXd ownOfficePrior(std::size_t numItems, std::size_t numRooms,
                               const std::vector<std::size_t>& ownRoom, double pOwn) {
  checkProb(pOwn, "pOwn");
  const std::size_t nP = ownRoom.size();
  if (numItems == 0 || numRooms == 0 || nP == 0)
    throw ConfigError("ownOfficePrior: empty item, room or person set");
  if (numRooms == 1 && pOwn != 1.0)
    throw ConfigError("ownOfficePrior: with one room pOwn must be 1");
  Eigen::VectorXd prior(static_cast<Eigen::Index>(numItems * numRooms * nP));
  for (std::size_t i = 0; i < numItems; ++i)
    for (std::size_t r = 0; r < numRooms; ++r)
      for (std::size_t p = 0; p < nP; ++p) {
        if (ownRoom[p] >= numRooms)
          throw ConfigError("ownOfficePrior: ownRoom[" + std::to_string(p) + "] = " +
                            std::to_string(ownRoom[p]) + " out of range");
        const double pr = r == ownRoom[p] ? pOwn : (1.0 - pOwn) / (numRooms - 1.0);
        prior((i * numRooms + r) * nP + p) = pr / (numItems * nP);
      }
  return prior;
}

DialogSpec placeholderNames(DialogSpec spec, std::size_t items, std::size_t rooms,
                            std::size_t persons) {
  auto names = [](const std::string& stem, std::size_t n) {
    std::vector<std::string> v;
    for (std::size_t k = 1; k <= n; ++k) v.push_back(stem + std::to_string(k));
    return v;
  };
  spec.items = names("item_", items);
  spec.rooms = names("room_", rooms);
  spec.persons = names("person_", persons);
  return spec;
}

DialogPomdp::DialogPomdp(DialogSpec spec)
    : spec_(std::move(spec)), nI_(spec_.items.size()), nR_(spec_.rooms.size()),
      nP_(spec_.persons.size()), nReq_(nI_ * nR_ * nP_), firstServe_(3 + nI_ + nR_ + nP_),
      model_(build()) {}

pomdp::Model DialogPomdp::build() {
  checkNames(spec_.items, "items");
  checkNames(spec_.rooms, "rooms");
  checkNames(spec_.persons, "persons");
  checkProb(spec_.pGeneral, "pGeneral");
  checkProb(spec_.pYesNo, "pYesNo");
  if (spec_.turnLimit < 0)
    throw ConfigError("dialog POMDP: turnLimit = " + std::to_string(spec_.turnLimit));
  if (!std::isfinite(spec_.generalCost) || !std::isfinite(spec_.confirmCost) ||
      !std::isfinite(spec_.successReward) || !std::isfinite(spec_.failureReward))
    throw ConfigError("dialog POMDP: non-finite cost or reward");
  const auto n = static_cast<Eigen::Index>(nReq_);
  if (spec_.prior.size() == 0) spec_.prior = Eigen::VectorXd::Constant(n, 1.0 / nReq_);
  if (spec_.prior.size() != n)
    throw ConfigError("dialog POMDP: prior has " + std::to_string(spec_.prior.size()) +
                      " entries, expected " + std::to_string(nReq_) + " requests");
  if (spec_.prior.minCoeff() < 0.0 ||
      std::abs(spec_.prior.sum() - 1.0) > pomdp::Model::kTolerance)
    throw ConfigError("dialog POMDP: prior is not a distribution (sum " +
                      std::to_string(spec_.prior.sum()) + ")");
  if (spec_.delivery.size() == 0) spec_.delivery = Eigen::MatrixXd::Ones(n, n);
  if (spec_.delivery.rows() != n || spec_.delivery.cols() != n)
    throw ConfigError("dialog POMDP: delivery matrix T^D is " +
                      std::to_string(spec_.delivery.rows()) + "x" +
                      std::to_string(spec_.delivery.cols()) + ", expected " +
                      std::to_string(nReq_) + "x" + std::to_string(nReq_));
  for (Eigen::Index s = 0; s < n; ++s)
    for (Eigen::Index a = 0; a < n; ++a)
      checkProb(spec_.delivery(s, a),
                "delivery(" + std::to_string(s) + ", " + std::to_string(a) + ")");
  if (spec_.serveCost.size() != 0) {
    if (spec_.serveCost.rows() != n || spec_.serveCost.cols() != n)
      throw ConfigError("dialog POMDP: serveCost is " + std::to_string(spec_.serveCost.rows()) +
                        "x" + std::to_string(spec_.serveCost.cols()) + ", expected " +
                        std::to_string(nReq_) + "x" + std::to_string(nReq_));
    if (!spec_.serveCost.allFinite())
      throw ConfigError("dialog POMDP: serveCost has a non-finite entry");
  }
  for (std::size_t s = 0; s < nReq_; ++s) {
    personOf_.push_back(static_cast<int>(s % nP_));
    roomOf_.push_back(static_cast<int>((s / nP_) % nR_));
    itemOf_.push_back(static_cast<int>(s / (nP_ * nR_)));
  }
  for (auto* v : {&itemOf_, &roomOf_, &personOf_}) v->push_back(-1);  // terminal

  const std::size_t nS = nReq_ + 1, nA = firstServe_ + nReq_, nO = nI_ + nR_ + nP_ + 3;
  const std::size_t term = nReq_;
  const auto S = static_cast<Eigen::Index>(nS), O = static_cast<Eigen::Index>(nO);
  std::vector<Eigen::MatrixXd> t(nA), z(nA);
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(S, static_cast<Eigen::Index>(nA));
  // Answer to a general question about a factor with k values, true value v.
  auto general = [&](Eigen::MatrixXd& zm, std::size_t s, std::size_t v, std::size_t k,
                     std::size_t firstObs) {
    for (std::size_t w = 0; w < k; ++w)
      zm(s, firstObs + w) = k == 1 ? 1.0
                                   : (w == v ? spec_.pGeneral : (1.0 - spec_.pGeneral) / (k - 1.0));
  };
  for (std::size_t a = 0; a < nA; ++a) {
    z[a] = Eigen::MatrixXd::Zero(S, O);
    if (a < firstServe_) {
      t[a] = Eigen::MatrixXd::Identity(S, S);  // questions do not change the request
    } else {
      t[a] = Eigen::MatrixXd::Zero(S, S);
      t[a].col(term).setOnes();  // serving ends the episode
    }
    z[a](term, obsNone()) = 1.0;
    for (std::size_t s = 0; s < nReq_; ++s) {
      const std::size_t it = itemOf_[s], ro = roomOf_[s], pe = personOf_[s];
      if (a >= firstServe_) {
        const double td = spec_.delivery(s, a - firstServe_);
        r(s, a) = td * spec_.successReward + (1.0 - td) * spec_.failureReward;
        if (spec_.serveCost.size() != 0)
          r(s, a) -= spec_.serveCost(static_cast<Eigen::Index>(s),
                                     static_cast<Eigen::Index>(a - firstServe_));
        z[a](s, obsNone()) = 1.0;  // unreachable (successor is terminal) but a valid row
        continue;
      }
      const bool isGeneral = a < 3;
      r(s, a) = -(isGeneral ? spec_.generalCost : spec_.confirmCost);
      if (a == 0) {
        general(z[a], s, it, nI_, obsItem(0));
      } else if (a == 1) {
        general(z[a], s, ro, nR_, obsRoom(0));
      } else if (a == 2) {
        general(z[a], s, pe, nP_, obsPerson(0));
      } else {
        bool match;
        if (a < 3 + nI_) match = (a - 3) == it;
        else if (a < 3 + nI_ + nR_) match = (a - 3 - nI_) == ro;
        else match = (a - 3 - nI_ - nR_) == pe;
        z[a](s, obsYes()) = match ? spec_.pYesNo : 1.0 - spec_.pYesNo;
        z[a](s, obsNo()) = match ? 1.0 - spec_.pYesNo : spec_.pYesNo;
      }
    }
  }
  pomdp::Model m(std::move(t), std::move(z), std::move(r), spec_.discount);
  std::vector<std::string> sn, an, on;
  for (std::size_t s = 0; s < nReq_; ++s) sn.push_back(requestName(s));
  sn.push_back("terminal");
  an = {"ask_item", "ask_room", "ask_person"};
  for (const auto& i : spec_.items) an.push_back("confirm_item_" + i);
  for (const auto& i : spec_.rooms) an.push_back("confirm_room_" + i);
  for (const auto& i : spec_.persons) an.push_back("confirm_person_" + i);
  for (std::size_t s = 0; s < nReq_; ++s) an.push_back("serve_" + requestName(s));
  for (const auto& i : spec_.items) on.push_back("item_" + i);
  for (const auto& i : spec_.rooms) on.push_back("room_" + i);
  for (const auto& i : spec_.persons) on.push_back("person_" + i);
  on.insert(on.end(), {"yes", "no", "none"});
  m.setNames(sn, an, on);
  pomdp::Belief b0 = pomdp::Belief::Zero(S);
  b0.head(static_cast<Eigen::Index>(nReq_)) = spec_.prior;
  m.setInitialBelief(b0);
  return m;
}

std::size_t DialogPomdp::requestIndex(std::size_t item, std::size_t room,
                                      std::size_t person) const {
  if (item >= nI_ || room >= nR_ || person >= nP_)
    throw ConfigError("dialog POMDP: request <" + std::to_string(item) + "," +
                      std::to_string(room) + "," + std::to_string(person) + "> out of range");
  return (item * nR_ + room) * nP_ + person;
}

std::array<std::size_t, 3> DialogPomdp::requestParts(std::size_t request) const {
  if (request >= nReq_)
    throw ConfigError("dialog POMDP: request index " + std::to_string(request) + " out of range");
  return {request / (nP_ * nR_), (request / nP_) % nR_, request % nP_};
}

std::string DialogPomdp::requestName(std::size_t request) const {
  auto p = requestParts(request);
  return spec_.items[p[0]] + "_" + spec_.rooms[p[1]] + "_" + spec_.persons[p[2]];
}

DialogActionKind DialogPomdp::actionKind(std::size_t a) const {
  if (a == 0) return DialogActionKind::kAskItem;
  if (a == 1) return DialogActionKind::kAskRoom;
  if (a == 2) return DialogActionKind::kAskPerson;
  if (a < 3 + nI_) return DialogActionKind::kConfirmItem;
  if (a < 3 + nI_ + nR_) return DialogActionKind::kConfirmRoom;
  if (a < firstServe_) return DialogActionKind::kConfirmPerson;
  if (a < firstServe_ + nReq_) return DialogActionKind::kServe;
  throw ConfigError("dialog POMDP: action index " + std::to_string(a) + " out of range");
}

std::array<Eigen::VectorXd, 3> DialogPomdp::marginals(const pomdp::Belief& b) const {
  return {pomdp::marginal(b, itemOf_, nI_), pomdp::marginal(b, roomOf_, nR_),
          pomdp::marginal(b, personOf_, nP_)};
}

std::string DialogPomdp::exportCassandra() const { return pomdp::writeCassandra(model_); }

}  // namespace dialog
}  // namespace krr
