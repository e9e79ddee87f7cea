#include "krr_core/dialog/delivery_manager.h"

#include <array>
#include <set>

#include "krr_core/common/errors.h"

namespace krr {
namespace dialog {

namespace {

const char* phaseName(DeliveryPhase p) {
  switch (p) {
    case DeliveryPhase::kIdle: return "idle";
    case DeliveryPhase::kDialog: return "dialog";
    case DeliveryPhase::kNavigating: return "navigating";
    case DeliveryPhase::kAwaitCheck: return "awaiting the check";
    case DeliveryPhase::kDone: return "done";
  }
  return "?";
}

}  // namespace

std::string toString(DeliveryOutcome o) {
  switch (o) {
    case DeliveryOutcome::kFulfilled: return "fulfilled";
    case DeliveryOutcome::kFailed: return "failed";
    case DeliveryOutcome::kUnconfirmed: return "unconfirmed";
    case DeliveryOutcome::kNone: break;
  }
  return "";
}

std::size_t DeliveryRecord::navMoves() const {
  std::size_t m = 0;
  for (const auto& l : legs) m += l.moves;
  return m;
}

bool DeliveryRecord::navFailed() const {
  for (const auto& l : legs)
    if (!l.reached) return true;
  return false;
}

DeliveryManager::DeliveryManager(const DialogPomdp& dialog,
                                 const pomdp::TurnLimitedPolicy& policy,
                                 const LanguageFrontEnd* language, const DialogConfig& config)
    : dialog_(dialog), language_(language), shop_(config.shop),
      maxRedeliveries_(config.max_redeliveries), session_(dialog, language, &policy) {
  config.validate();
}

void DeliveryManager::requirePhase(DeliveryPhase p, const char* what) const {
  if (phase_ != p)
    throw ConfigError(std::string("delivery: ") + what + " while " + phaseName(phase_) +
                      " (expected " + phaseName(p) + ")");
}

std::vector<std::string> DeliveryManager::requestNames(std::size_t request) const {
  const auto p = dialog_.requestParts(request);
  const auto& s = dialog_.spec();
  return {s.items[p[0]], s.rooms[p[1]], s.persons[p[2]]};
}

void DeliveryManager::start() {
  session_.reset();
  record_ = DeliveryRecord();
  plan_.clear();
  next_ = 0;
  saidWrong_ = false;
  repeat_ = false;
  decisions_.clear();
  phase_ = DeliveryPhase::kDialog;
}

void DeliveryManager::reset() {
  start();
  phase_ = DeliveryPhase::kIdle;
}

HearResult DeliveryManager::hear(const std::string& text) {
  requirePhase(DeliveryPhase::kDialog, "hearing an answer");
  HearResult h = session_.hear(text);
  repeat_ = !h.understood() && session_.lastQuestion() >= 0;
  return h;
}

bool DeliveryManager::observe(std::size_t question, std::size_t observation) {
  requirePhase(DeliveryPhase::kDialog, "observing an answer");
  repeat_ = false;
  return session_.observe(question, observation);
}

std::size_t DeliveryManager::decide() {
  requirePhase(DeliveryPhase::kDialog, "deciding");
  if (repeat_) {
    repeat_ = false;
    const auto again = static_cast<std::size_t>(session_.lastQuestion());
    decisions_.push_back(dialog_.model().actionNames()[again]);
    return again;
  }
  const bool forced = session_.atTurnLimit();
  const std::size_t a = session_.nextAction();
  decisions_.push_back(dialog_.model().actionNames()[a]);
  if (dialog_.isQuestion(a)) {
    session_.act(a);
    record_.turns = session_.turns();
    record_.qa_cost -= dialog_.model().getExpectedReward(0, a);  // questions cost the same everywhere
    return a;
  }
  const BeliefSummary b = session_.summary();
  record_.served = record_.delivering = dialog_.requestOfServe(a);
  record_.forced = forced;
  record_.entropy = b.entropy;
  record_.max_probability = b.mostLikelyProbability;
  record_.served_probability = session_.belief()(static_cast<Eigen::Index>(record_.served));
  session_.act(a);
  record_.attempts = 1;
  const std::size_t room = dialog_.requestParts(record_.served)[1];
  beginLegs({{Leg::Kind::kPickup, shop_, room},
             {Leg::Kind::kToRoom, dialog_.spec().rooms[room], room}});
  return a;
}

void DeliveryManager::beginLegs(std::vector<Leg> legs) {
  plan_ = std::move(legs);
  next_ = 0;
  phase_ = DeliveryPhase::kNavigating;
  decisions_.push_back("navigate " + plan_[0].place);
}

const Leg& DeliveryManager::leg() const {
  requirePhase(DeliveryPhase::kNavigating, "asking for the leg");
  return plan_[next_];
}

void DeliveryManager::legDone(bool reached, std::size_t moves, const std::string& why) {
  requirePhase(DeliveryPhase::kNavigating, "ending a leg");
  record_.legs.push_back({plan_[next_], reached, moves, why});
  if (!reached) {
    finish(DeliveryOutcome::kFailed, "navigation to " + plan_[next_].place + " failed" +
                                         (why.empty() ? "" : ": " + why));
    return;
  }
  if (++next_ < plan_.size()) {
    decisions_.push_back("navigate " + plan_[next_].place);
    return;
  }
  phase_ = DeliveryPhase::kAwaitCheck;
  saidWrong_ = false;
}

CheckResult DeliveryManager::checkRequest(std::size_t request) {
  requirePhase(DeliveryPhase::kAwaitCheck, "checking the delivery");
  if (request >= dialog_.numRequests())
    throw ConfigError("delivery: request " + std::to_string(request) + " out of range");
  if (request == record_.delivering) {
    decisions_.push_back("check yes");
    finish(DeliveryOutcome::kFulfilled, "the person confirmed the delivery");
    return CheckResult::kConfirmed;
  }
  decisions_.push_back("check " + dialog_.requestName(request));
  const auto want = requestNames(request);
  if (record_.attempts > maxRedeliveries_) {
    finish(DeliveryOutcome::kFailed, "wrong delivery: <" + want[0] + ", " + want[1] + ", " +
                                         want[2] + "> was asked for, no redelivery left");
    return CheckResult::kFailed;
  }
  const std::size_t from = dialog_.requestParts(record_.delivering)[1];
  const std::size_t to = dialog_.requestParts(request)[1];
  record_.delivering = request;
  record_.redelivered = true;
  ++record_.attempts;
  beginLegs({{Leg::Kind::kReturn, shop_, from}, {Leg::Kind::kToRoom, dialog_.spec().rooms[to], to}});
  return CheckResult::kRedelivering;
}

CheckResult DeliveryManager::check(const std::string& text, std::string* reply) {
  requirePhase(DeliveryPhase::kAwaitCheck, "checking the delivery");
  if (!language_) throw ConfigError("delivery: no language front end to understand the check");
  const ParsedUtterance u = language_->parse(text);
  const auto& spec = dialog_.spec();
  std::array<std::set<std::size_t>, 3> said;
  for (const auto& m : u.mentions) said[static_cast<int>(m.factor)].insert(m.index);
  auto parts = dialog_.requestParts(record_.delivering);  // item, room, person
  for (int f = 0; f < 3; ++f) {
    if (said[f].size() > 1) {
      if (reply) *reply = std::string("Which ") + factorName(static_cast<Factor>(f)) +
                          " was it? You named several.";
      return CheckResult::kUnclear;
    }
    if (said[f].size() == 1) parts[f] = *said[f].begin();
  }
  const std::size_t named = dialog_.requestIndex(parts[0], parts[1], parts[2]);
  if (named != record_.delivering) return checkRequest(named);
  // "yes", or the delivered request named again without a "no": confirmed.
  if (u.no == 0 && (u.yes > 0 || !u.mentions.empty())) return checkRequest(named);
  if (u.no > 0) saidWrong_ = true;
  if (reply)
    *reply = u.no > 0 ? "Sorry! What did you ask for? (for example: no, " + exampleRequest(spec) + ")"
                      : "Is this right? Please answer yes, or tell me what you asked for.";
  return CheckResult::kUnclear;
}

void DeliveryManager::checkTimedOut() {
  requirePhase(DeliveryPhase::kAwaitCheck, "timing out the check");
  if (saidWrong_) finish(DeliveryOutcome::kFailed, "wrong delivery, and the right request was not given");
  else finish(DeliveryOutcome::kUnconfirmed, "nobody checked the delivery");
}

void DeliveryManager::fail(const std::string& why) {
  if (phase_ == DeliveryPhase::kDone || phase_ == DeliveryPhase::kIdle) return;
  finish(DeliveryOutcome::kFailed, why);
}

void DeliveryManager::finish(DeliveryOutcome o, const std::string& message) {
  record_.outcome = o;
  record_.message = message;
  phase_ = DeliveryPhase::kDone;
  decisions_.push_back(toString(o));
}

bool runDelivery(DeliveryManager& m, DeliveryPerson& person, DeliveryNavigator& nav) {
  m.start();
  person.open(m);
  while (m.phase() == DeliveryPhase::kDialog) {
    const std::size_t a = m.decide();
    if (m.dialog().isQuestion(a) && !person.answer(m, a)) return false;
  }
  // A person who keeps saying nothing usable at the room is treated as silent after a while.
  constexpr int kMaxUnclearChecks = 10;
  int unclear = 0;
  while (m.phase() != DeliveryPhase::kDone) {
    if (m.phase() == DeliveryPhase::kNavigating) {
      const LegRecord r = nav.drive(m.leg());
      m.legDone(r.reached, r.moves, r.why);
      unclear = 0;
    } else if ((!person.check(m) || ++unclear > kMaxUnclearChecks) &&
               m.phase() == DeliveryPhase::kAwaitCheck) {
      m.checkTimedOut();
    }
  }
  return true;
}

DeliveryReward deliveryReward(const DeliveryRecord& r, std::size_t request, const DialogConfig& c) {
  DeliveryReward w;
  w.delivery = r.outcome == DeliveryOutcome::kFulfilled ? c.success_reward : c.failure_reward;
  w.qa = r.qa_cost;
  if (c.serve_cost_mode == ServeCostMode::kExpected)
    w.navigation = c.serve_cost_weight * (c.step_cost * static_cast<double>(r.navMoves()) +
                                          (r.navFailed() ? c.failure_penalty : 0.0));
  w.penalty = r.served != request ? c.wrong_delivery_penalty : 0.0;
  return w;
}

}  // namespace dialog
}  // namespace krr
