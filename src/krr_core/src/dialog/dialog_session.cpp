#include "krr_core/dialog/dialog_session.h"

#include "krr_core/common/errors.h"
#include "krr_core/dialog/dialog_policy.h"

namespace krr {
namespace dialog {

BeliefSummary summarizeBelief(const DialogPomdp& dialog, const pomdp::Belief& b) {
  BeliefSummary s;
  auto m = dialog.marginals(b);  // item, room, person
  s.items = m[0];
  s.rooms = m[1];
  s.persons = m[2];
  s.entropy = pomdp::entropy(b);
  Eigen::Index best = 0;
  s.mostLikelyProbability =
      b.head(static_cast<Eigen::Index>(dialog.numRequests())).maxCoeff(&best);
  s.mostLikely = static_cast<std::size_t>(best);
  return s;
}

DialogSession::DialogSession(const DialogPomdp& dialog, const LanguageFrontEnd* language,
                             const pomdp::TurnLimitedPolicy* policy)
    : dialog_(dialog), language_(language), policy_(policy) {
  if (policy_) {
    const std::string mismatch = policyMismatch(*policy_, dialog_);
    if (!mismatch.empty()) throw ConfigError("dialog session: " + mismatch);
  }
  reset();
}

void DialogSession::reset() {
  belief_ = dialog_.model().initialBelief();
  turns_ = 0;
  lastQuestion_ = -1;
  finished_ = false;
  served_ = 0;
  plan_ = asked_ = -1;
  pending_ = DialogDecision{};
}

namespace {

/// @brief On a slot of two values, "is it v?" and "is it w?" are one experiment (yes to one is
/// no to the other, at the same accuracy), so solvers keep one of them; a person expects the
/// robot to name the value it believes more likely ("is it for Dave?" at 98 % Dave, not "is it
/// for Erin?"). Any other action is returned as it is.
std::size_t phrasedConfirm(const DialogPomdp& d, std::size_t a, const pomdp::Belief& b) {
  const DialogActionKind kind = d.actionKind(a);
  int slot;
  std::size_t first;
  switch (kind) {
    case DialogActionKind::kConfirmItem: slot = 0, first = d.confirmItem(0); break;
    case DialogActionKind::kConfirmRoom: slot = 1, first = d.confirmRoom(0); break;
    case DialogActionKind::kConfirmPerson: slot = 2, first = d.confirmPerson(0); break;
    default: return a;
  }
  const std::array<Eigen::VectorXd, 3> m = d.marginals(b);
  if (m[static_cast<std::size_t>(slot)].size() != 2) return a;
  const std::size_t v = a - first, other = 1 - v;
  return m[static_cast<std::size_t>(slot)](static_cast<Eigen::Index>(other)) >
                 m[static_cast<std::size_t>(slot)](static_cast<Eigen::Index>(v))
             ? first + other
             : a;
}

/// @brief Serve the belief's most likely request (the turn limit's rule).
std::size_t mostLikelyServe(const DialogPomdp& d, const pomdp::Belief& b) {
  Eigen::Index best = 0;
  b.head(static_cast<Eigen::Index>(d.numRequests())).maxCoeff(&best);
  return d.serveAction(static_cast<std::size_t>(best));
}

}  // namespace

DialogDecision decideDialog(const DialogPomdp& d, const pomdp::TurnLimitedPolicy& policy,
                            const pomdp::Belief& b, int turns) {
  const std::size_t i = policy.bestIndex(b, turns);
  const std::size_t a = policy.action(i);
  if (turns >= d.spec().turnLimit) {
    if (!d.isServe(a))
      throw ConfigError("dialog: the policy asks '" + d.model().actionNames()[a] + "' after " +
                        std::to_string(turns) + " questions, at the turn limit where it must " +
                        "serve (was it solved without the limit?)");
    return {mostLikelyServe(d, b), -1};
  }
  if (!d.isServe(a)) return {phrasedConfirm(d, a, b), static_cast<long>(i)};
  const double serve = policy.lookahead(d.model(), b, a, turns, true);
  std::vector<std::size_t> questions;
  for (std::size_t q = 0; q < d.model().getA() && d.isQuestion(q); ++q) questions.push_back(q);
  const std::vector<double> values = policy.lookahead(d.model(), b, questions, turns);
  DialogDecision best{a, static_cast<long>(i)};
  double bestValue = serve;
  for (std::size_t k = 0; k < questions.size(); ++k)
    if (values[k] > bestValue + 1e-9) {
      bestValue = values[k];
      best = {questions[k], -1};
    }
  best.action = phrasedConfirm(d, best.action, b);
  return best;
}

DialogDecision DecisionMemo::decide(const DialogPomdp& d,
                                    const pomdp::TurnLimitedPolicy& policy,
                                    const pomdp::Belief& b, int turns) {
  key_.assign(reinterpret_cast<const char*>(&turns), sizeof(turns));
  key_.append(reinterpret_cast<const char*>(b.data()),
              static_cast<std::size_t>(b.size()) * sizeof(double));
  const auto it = memo_.find(key_);
  if (it != memo_.end()) {
    ++hits_;
    return it->second;
  }
  ++misses_;
  const DialogDecision a = decideDialog(d, policy, b, turns);
  if (memo_.size() >= capacity_) memo_.clear();
  memo_.emplace(key_, a);
  return a;
}

std::size_t DialogSession::nextAction() const {
  if (finished_) throw ConfigError("dialog session: the dialog has ended");
  if (!policy_) {
    if (atTurnLimit()) return mostLikelyServe(dialog_, belief_);
    throw ConfigError("dialog session: no policy to choose the next action");
  }
  if (plan_ >= 0 && !atTurnLimit()) {  // on a plan: its action, O(1)
    const std::size_t a = policy_->action(static_cast<std::size_t>(plan_));
    if (dialog_.isQuestion(a)) {
      pending_ = {phrasedConfirm(dialog_, a, belief_), plan_};
      return pending_.action;
    }
    // A plan's serve is its reward's best for the plan's own belief, and a commit plan never
    // asks about the room again: served as it is only when it is the most likely request;
    // otherwise the scan decides (never worth less than the plan at this belief).
    if (belief_(static_cast<Eigen::Index>(dialog_.requestOfServe(a))) >=
        belief_.head(static_cast<Eigen::Index>(dialog_.numRequests())).maxCoeff()) {
      pending_ = {a, plan_};
      return a;
    }
  }
  pending_ = memo_ ? memo_->decide(dialog_, *policy_, belief_, turns_)
                   : decideDialog(dialog_, *policy_, belief_, turns_);
  return pending_.action;
}

void DialogSession::advance(std::size_t q, std::size_t o) {
  const long asked = asked_;
  asked_ = -1;
  plan_ = -1;
  if (asked < 0 || static_cast<long>(q) != lastQuestion_) return;
  if (policy_->action(static_cast<std::size_t>(asked)) != q) {  // the phrased twin: yes <-> no
    if (o == dialog_.obsYes()) o = dialog_.obsNo();
    else if (o == dialog_.obsNo()) o = dialog_.obsYes();
  }
  plan_ = policy_->next(static_cast<std::size_t>(asked), o);
}

void DialogSession::act(std::size_t a) {
  if (finished_) throw ConfigError("dialog session: the dialog has ended");
  if (a >= dialog_.model().getA())
    throw ConfigError("dialog session: action " + std::to_string(a) + " out of range (" +
                      std::to_string(dialog_.model().getA()) + " actions)");
  if (dialog_.isServe(a)) {
    finished_ = true;
    served_ = dialog_.requestOfServe(a);
    return;
  }
  lastQuestion_ = static_cast<long>(a);
  ++turns_;
  asked_ = policy_ && policy_->hasPlans() && pending_.plan >= 0 && pending_.action == a ? pending_.plan : -1;
  plan_ = -1;
  pending_ = DialogDecision{};
}

HearResult DialogSession::hear(const std::string& text) {
  HearResult r;
  r.text = text;
  if (finished_) {
    r.notes.push_back("the dialog has ended: utterance ignored");
    return r;
  }
  if (!language_) throw ConfigError("dialog session: no language front end to understand text");
  Interpretation in = language_->understand(text, dialog_, lastQuestion_);
  r.unknownWords = std::move(in.unknownWords);
  r.notes = std::move(in.notes);
  for (const DialogObservation& o : in.observations) {
    pomdp::Belief next;
    double p = 0.0;
    if (pomdp::tryUpdateBelief(dialog_.model(), belief_, o.action, o.observation, next, &p)) {
      belief_ = std::move(next);
      r.applied.push_back(o);
    } else {
      r.notes.push_back("observation " + o.description +
                        " is impossible under the current belief: ignored");
    }
  }
  if (r.applied.size() == 1) advance(r.applied[0].action, r.applied[0].observation);
  else if (!r.applied.empty()) plan_ = asked_ = -1;  // more than the plan's answer: off the plan
  return r;
}

bool DialogSession::observe(std::size_t question, std::size_t observation) {
  if (finished_) throw ConfigError("dialog session: the dialog has ended");
  if (question >= dialog_.model().getA() || !dialog_.isQuestion(question))
    throw ConfigError("dialog session: action " + std::to_string(question) + " is not a question");
  if (observation >= dialog_.model().getO())
    throw ConfigError("dialog session: observation " + std::to_string(observation) + " out of range");
  pomdp::Belief next;
  if (!pomdp::tryUpdateBelief(dialog_.model(), belief_, question, observation, next)) return false;
  belief_ = std::move(next);
  advance(question, observation);
  return true;
}

BeliefSummary DialogSession::summary() const { return summarizeBelief(dialog_, belief_); }

}  // namespace dialog
}  // namespace krr
