#include "krr_core/common/format.h"
#include "krr_core/dialog/dialog_knowledge.h"

#include <cmath>
#include <map>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/dialog/request_prior.h"

namespace krr {
namespace dialog {

namespace {

constexpr double kTol = 1e-9;

std::string num(double v) { return formatNumber(v, 10); }

}  // namespace

DialogKnowledge::DialogKnowledge(const std::string& office_plog, const std::string& speech_plog)
    : names_(office_plog + " + " + speech_plog) {
  reasoner_.loadFile(office_plog);
  reasoner_.addStatements(readFile(speech_plog), "speech", speech_plog);
  base_ = dialogSpecFromKnowledge(reasoner_, office_plog);
  if (base_.items.size() * base_.rooms.size() * base_.persons.size() == 0)
    throw ConfigError(office_plog + ": the dialog needs at least one item, room and person");
  reasonSpeech();
}

void DialogKnowledge::reasonSpeech() {
  const auto& I = base_.items;
  const auto& R = base_.rooms;
  const auto& P = base_.persons;
  struct Factor {
    std::string name;  // item, room, person
    const std::vector<std::string>* values;
  };
  const Factor factors[3] = {{"item", &I}, {"room", &R}, {"person", &P}};
  double pGeneral = -1, pYesNo = -1;
  std::string generalWhere, yesnoWhere;
  auto query = [&](auto&& f, const std::string& what) {
    try {
      return f();
    } catch (const UnknownSymbolError& e) {
      throw ConfigError(names_ + ": the speech model needs " + what + ": " + e.what());
    }
  };
  for (std::size_t i = 0; i < I.size(); ++i)
    for (std::size_t r = 0; r < R.size(); ++r)
      for (std::size_t p = 0; p < P.size(); ++p) {
        const std::string request = "<" + I[i] + "," + R[r] + "," + P[p] + ">";
        const std::string ev = "do(curr_person=" + P[p] + "), do(curr_item(" + P[p] + ")=" + I[i] +
                               "), do(curr_room(" + P[p] + ")=" + R[r] + ")";
        const std::size_t truth[3] = {i, r, p};
        for (int f = 0; f < 3; ++f) {
          const auto& vals = *factors[f].values;
          const std::string attr = "heard_" + factors[f].name;
          // Answers to the general question about this factor.
          const auto dist = query([&] { return reasoner_.distribution(attr, ev); }, attr);
          std::map<std::string, double> pr;
          for (const auto& vp : dist) pr[vp.value] = vp.probability;
          double total = 0;
          for (const auto& kv : pr) total += kv.second;
          if (std::fabs(total - 1.0) > 1e-6)
            throw ConfigError(names_ + ": " + attr + " has total probability " + num(total) +
                              " for request " + request + " (it must always have a value)");
          const double correct = pr.count(vals[truth[f]]) ? pr[vals[truth[f]]] : 0.0;
          if (vals.size() > 1) {
            if (pGeneral < 0) {
              pGeneral = correct;
              generalWhere = attr + " for request " + request;
            }
            const double other = (1.0 - pGeneral) / (static_cast<double>(vals.size()) - 1.0);
            for (std::size_t w = 0; w < vals.size(); ++w) {
              const double got = pr.count(vals[w]) ? pr[vals[w]] : 0.0;
              const double want = w == truth[f] ? pGeneral : other;
              if (std::fabs(got - want) > kTol)
                throw ConfigError(names_ + ": P(" + attr + "=" + vals[w] + " | request " + request +
                                  ") = " + num(got) + ", but the dialog POMDP needs one accuracy " +
                                  "for general questions (" + num(pGeneral) + " from " +
                                  generalWhere + ") with the other answers equally likely (" +
                                  num(other) + ")");
            }
          }
          // Answers to the confirming questions "is it v?".
          const std::string yes = "yes_" + factors[f].name, asked = "asked_" + factors[f].name;
          for (std::size_t v = 0; v < vals.size(); ++v) {
            const std::string q = "?{" + yes + "=true} | do(" + asked + "=" + vals[v] + "), " + ev;
            const double py = query([&] { return reasoner_.probability(q); }, yes + " and " + asked);
            const double right = v == truth[f] ? py : 1.0 - py;  // P(the right answer)
            if (pYesNo < 0) {
              pYesNo = right;
              yesnoWhere = q;
            }
            if (std::fabs(right - pYesNo) > kTol)
              throw ConfigError(names_ + ": " + q + " = " + num(py) + " makes the " +
                                (v == truth[f] ? "yes" : "no") + " answer right with probability " +
                                num(right) + ", but the dialog POMDP needs one yes/no accuracy (" +
                                num(pYesNo) + " from " + yesnoWhere + ")");
          }
        }
      }
  if (pGeneral < 0) pGeneral = 1.0;  // every factor has a single value: nothing to mishear
  speech_.p_general = pGeneral;
  speech_.p_yesno = pYesNo;
}

void DialogKnowledge::checkRooms(const TripTable& trips) const {
  if (trips.rooms != base_.rooms || trips.to_room.size() != base_.rooms.size() ||
      trips.to_shop.size() != base_.rooms.size()) {
    std::string a, b;
    for (const auto& r : trips.rooms) a += (a.empty() ? "" : ",") + r;
    for (const auto& r : base_.rooms) b += (b.empty() ? "" : ",") + r;
    throw ConfigError("dialog knowledge: the navigation rooms {" + a +
                      "} are not the knowledge base's rooms {" + b + "} (same order)");
  }
}

Eigen::MatrixXd DialogKnowledge::serveCosts(const TripTable& trips, ServeCostMode mode) const {
  checkRooms(trips);
  const auto n = static_cast<Eigen::Index>(numRequests());
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(n, n);
  if (mode == ServeCostMode::kNone) return k;
  for (Eigen::Index s = 0; s < n; ++s)
    for (Eigen::Index a = 0; a < n; ++a) {
      const TripEstimate& out = trips.to_room[roomOf(static_cast<std::size_t>(a))];
      const TripEstimate& back = trips.to_shop[roomOf(static_cast<std::size_t>(a))];
      const TripEstimate& redo = trips.to_room[roomOf(static_cast<std::size_t>(s))];
      k(s, a) = out.cost + (s == a ? 0.0 : out.reach * (back.cost + back.reach * redo.cost));
    }
  return k;
}

DialogSpec DialogKnowledge::buildSpec(const TripTable& trips,
                                             const DialogConfig& config) const {
  config.validate();
  checkRooms(trips);
  DialogSpec spec = base_;
  spec.pGeneral = speech_.p_general;
  spec.pYesNo = speech_.p_yesno;
  spec.generalCost = config.general_cost;
  spec.confirmCost = config.confirm_cost;
  spec.successReward = config.success_reward;
  spec.failureReward = config.failure_reward;
  spec.discount = config.discount;
  spec.turnLimit = config.turn_limit;
  spec.delivery = deliveryMatrix(base_.items.size(), trips.reachFromShop(),
                                        base_.persons.size(), trips.reachBack());
  const auto n = static_cast<Eigen::Index>(numRequests());
  spec.serveCost = config.serve_cost_weight * serveCosts(trips, config.serve_cost_mode) +
                   config.wrong_delivery_penalty *
                       (Eigen::MatrixXd::Ones(n, n) - Eigen::MatrixXd::Identity(n, n));
  return spec;
}

}  // namespace dialog
}  // namespace krr
