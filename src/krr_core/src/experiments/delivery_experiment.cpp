#include "krr_core/common/parallel.h"
#include "krr_core/experiments/delivery_experiment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "krr_core/common/errors.h"
#include "krr_core/nav/blocking_rate.h"
#include "krr_core/kb/simulated_navigation.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/belief.h"

namespace krr {
namespace experiments {

using dialog::DecisionMemo;
using dialog::DeliveryManager;
using dialog::DeliveryNavigation;
using dialog::DeliveryNavigator;
using dialog::DeliveryOutcome;
using dialog::DeliveryPerson;
using dialog::DeliveryRecord;
using dialog::DialogConfig;
using dialog::DialogKnowledge;
using dialog::DialogPomdp;
using dialog::Leg;
using dialog::LegRecord;
using dialog::TripResult;

std::string toString(KnowledgeCondition c) {
  return c == KnowledgeCondition::kLearned ? "learned" : "outdated";
}

KnowledgeCondition conditionFromString(const std::string& text) {
  if (text == "learned") return KnowledgeCondition::kLearned;
  if (text == "outdated") return KnowledgeCondition::kOutdated;
  throw ConfigError("condition '" + text + "' must be learned or outdated");
}

void DeliveryExperimentOptions::validate() const {
  auto bad = [](const std::string& f, double v) {
    throw ConfigError("delivery experiment: field '" + f + "': value " + std::to_string(v) +
                      " must be in [0, 1]");
  };
  nav::checkBlockingRate(blocking_rate, "delivery experiment");
  if (!(outdated_rate >= 0 && outdated_rate <= 1)) bad("outdated_rate", outdated_rate);
}

namespace {

std::size_t sample(const Eigen::VectorXd& p, Rng& rng) {
  double u = uniform01(rng);
  for (Eigen::Index k = 0; k < p.size(); ++k) {
    if (u < p(k)) return static_cast<std::size_t>(k);
    u -= p(k);
  }
  // Rounding: the last entry with positive probability.
  for (Eigen::Index k = p.size() - 1; k > 0; --k)
    if (p(k) > 0) return static_cast<std::size_t>(k);
  return 0;
}

/// The person of a trial: answers through the speech model, knows their request at the room.
class SimulatedPerson : public DeliveryPerson {
 public:
  SimulatedPerson(const DialogPomdp& d, std::size_t request, Rng& rng)
      : d_(d), request_(request), rng_(rng) {}
  bool answer(DeliveryManager& m, std::size_t question) override {
    const auto& row = d_.model().observationRow(request_, question);
    double u = uniform01(rng_);
    std::size_t o = row.back().first;
    for (const auto& e : row) {
      if (u < e.second) {
        o = e.first;
        break;
      }
      u -= e.second;
    }
    m.observe(question, o);
    return true;
  }
  bool check(DeliveryManager& m) override {
    m.checkRequest(request_);
    return true;
  }

 private:
  const DialogPomdp& d_;
  std::size_t request_;
  Rng& rng_;
};

/// Legs in the blockage simulator; the robot starts every delivery at the shop.
class SimulatedNavigator : public DeliveryNavigator {
 public:
  SimulatedNavigator(const DeliveryNavigation& nav, const nav::BlockageSimulator& sim,
                     const nav::Context& context, Rng& rng)
      : nav_(nav), sim_(sim), context_(context), rng_(rng) {}
  LegRecord drive(const Leg& leg) override {
    LegRecord r{leg, true, 0, ""};
    if (leg.kind == Leg::Kind::kPickup) return r;  // already at the shop
    const TripResult t = nav_.execute(sim_, leg.room, leg.kind == Leg::Kind::kToRoom, context_, rng_);
    r.reached = t.reached;
    r.moves = t.moves;
    if (!t.reached) r.why = t.trapped ? "trapped" : "step limit";
    return r;
  }

 private:
  const DeliveryNavigation& nav_;
  const nav::BlockageSimulator& sim_;
  const nav::Context& context_;
  Rng& rng_;
};

}  // namespace

DeliveryExperiment::DeliveryExperiment(const kb::NavDomain& domain, const DialogConfig& config,
                                       const DeliveryExperimentOptions& options,
                                       bool solve_policy)
    : domain_(domain), config_(config), options_(options) {
  options_.validate();
  if (options_.domain_name.empty())
    throw ConfigError("delivery experiment: field 'domain_name' is empty");
  config_.validate();
  if (!domain.grid || !domain.space || !domain.simulator)
    throw ConfigError("delivery experiment: the navigation domain is not loaded");

  // Dialog knowledge first: its rooms are the delivery destinations.
  Stopwatch clock;
  knowledge_ = std::make_unique<DialogKnowledge>(config_.office_plog, config_.speech_plog);
  const double dialogReasoning = clock.seconds();

  // 1. Navigation knowledge with the condition's learned part.
  navKnowledge_ = std::make_unique<kb::NavigationKnowledge>(*domain.grid, domain.knowledge_files);
  prep_.knowledge_br = options_.condition == KnowledgeCondition::kLearned ? options_.blocking_rate
                                                                           : options_.outdated_rate;
  prep_.learning = prepareLearnedKnowledge(domain, *navKnowledge_, config_, knowledge_->base().rooms,
                                           prep_.knowledge_br, options_.seed, options_.cache_dir,
                                           options_.domain_name);

  // 2. Procedure 2 and the navigation side of deliveries.
  clock.reset();
  nav_ = dialog::deliveryNavigationFromKnowledge(domain, *navKnowledge_, config_,
                                                 knowledge_->base().rooms);
  prep_.nav_model_seconds = clock.seconds();

  // 3. The dialog POMDP and its policy.
  clock.reset();
  dialog_ = std::make_unique<DialogPomdp>(knowledge_->buildSpec(nav_->trips(), config_));
  prep_.dialog_model_seconds = dialogReasoning + clock.seconds();
  if (solve_policy)
    policy_ = dialog::solveDialogPolicy(*dialog_, config_, options_.cache_dir, &prep_.policy);

  context_ = nav::Context::withRate(domain.simulator->timeOfDayIndex(config_.time),
                                    options_.blocking_rate);
  // What the robot's policies achieve in the true world, and the serve rewards there (the
  // same builder as the robot's model: one definition of the reward).
  true_trips_ = nav_->evaluate(kb::trueDynamics(*domain.simulator, *domain.space, context_));
  true_dialog_ = std::make_unique<DialogPomdp>(knowledge_->buildSpec(true_trips_, config_));
}

void DeliveryExperiment::setPolicy(const pomdp::TurnLimitedPolicy& policy) {
  const std::string mismatch = dialog::policyMismatch(policy, *dialog_);
  if (!mismatch.empty()) throw ConfigError("delivery experiment: " + mismatch);
  policy_ = policy;
}

double DeliveryExperiment::rewardError() const {
  double e = 0.0;
  for (std::size_t s = 0; s < dialog_->numRequests(); ++s)
    for (std::size_t a = 0; a < dialog_->numRequests(); ++a)
      e = std::max(e, std::abs(dialog_->model().getExpectedReward(s, dialog_->serveAction(a)) -
                               true_dialog_->model().getExpectedReward(s, true_dialog_->serveAction(a))));
  return e;
}

DeliveryTrialResult DeliveryExperiment::runTrial(std::size_t index, long fixed_request,
                                                 DecisionMemo* memo) const {
  const DialogPomdp& d = *dialog_;
  if (fixed_request >= static_cast<long>(d.numRequests()))
    throw ConfigError("delivery trial: request " + std::to_string(fixed_request) +
                      " out of range");
  DeliveryTrialResult r;
  r.trial = index;
  const std::uint64_t seed = options_.seed;
  {
    Rng rng = makeRng(seed, "delivery/request", index);
    r.request = sample(d.spec().prior, rng);  // drawn even when fixed: same streams either way
  }
  if (fixed_request >= 0) r.request = static_cast<std::size_t>(fixed_request);
  Rng dialogRng = makeRng(seed, "delivery/dialog", index);
  Rng navRng = makeRng(seed, "delivery/navigation", index);
  SimulatedPerson person(d, r.request, dialogRng);
  SimulatedNavigator navigator(*nav_, *domain_.simulator, context_, navRng);
  if (policy_.size() == 0) throw ConfigError("delivery trial: no dialog policy (setPolicy first)");
  DeliveryManager manager(d, policy_, nullptr, config_);
  manager.setDecisionMemo(memo);
  dialog::runDelivery(manager, person, navigator);
  r.delivery = manager.record();
  r.correct = r.delivery.served == r.request;
  r.fulfilled = r.delivery.outcome == DeliveryOutcome::kFulfilled;
  r.reward = dialog::deliveryReward(r.delivery, r.request, config_);
  r.expected_reward = true_dialog_->model().getExpectedReward(
                          r.request, true_dialog_->serveAction(r.delivery.served)) -
                      r.delivery.qa_cost;
  return r;
}

std::vector<DeliveryTrialResult> DeliveryExperiment::runTrials(std::size_t begin,
                                                               std::size_t count,
                                                               std::size_t threads) const {
  return runParallelTrials<DeliveryTrialResult>(count, threads, [&]() {
    auto memo = std::make_shared<DecisionMemo>();  // per thread: the same beliefs recur
    return [&, memo](std::size_t k) { return runTrial(begin + k, -1, memo.get()); };
  });
}

std::string deliveryCsvHeader() {
  return "trial,room,reward,fulfilled,qa_cost,turns,entropy,request,served,served_room,correct,"
         "forced,served_probability,max_probability,trips,nav_moves,nav_failed,redelivered,"
         "delivery_reward,nav_cost,penalty,policy_lower,policy_upper,expected_reward,reward_error";
}

std::string deliveryCsvRow(const DialogPomdp& d, double rewardError, const DeliveryTrialResult& r,
                           const pomdp::BoundsReport& policy) {
  const auto& rooms = d.spec().rooms;
  const DeliveryRecord& x = r.delivery;
  char buf[640];
  std::snprintf(buf, sizeof(buf),
                "%zu,%s,%.6g,%d,%.6g,%d,%.6g,%s,%s,%s,%d,%d,%.6g,%.6g,%zu,%zu,%d,%d,%.6g,%.6g,%.6g,"
                "%.10g,%.10g,%.10g,%.10g",
                r.trial, rooms[d.requestParts(r.request)[1]].c_str(), r.reward.total(),
                r.fulfilled ? 1 : 0, x.qa_cost, x.turns, x.entropy, d.requestName(r.request).c_str(),
                d.requestName(x.served).c_str(), rooms[d.requestParts(x.served)[1]].c_str(),
                r.correct ? 1 : 0, x.forced ? 1 : 0, x.served_probability, x.max_probability,
                x.legs.empty() ? 0 : x.legs.size() - 1, x.navMoves(), x.navFailed() ? 1 : 0,
                x.redelivered ? 1 : 0, r.reward.delivery, r.reward.navigation, r.reward.penalty,
                policy.lower, policy.upper, r.expected_reward, rewardError);
  return buf;
}

}  // namespace experiments
}  // namespace krr
