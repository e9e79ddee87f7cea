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
}

namespace {

/// @brief On a slot of two values, "is it v?" and "is it w?" are one experiment (yes to one is
/// no to the other, at the same accuracy), so solvers keep one of them; a person expects the
/// robot to name the value it believes more likely ("is it for Bob?" at 98 % Bob, not "is it
/// for Alice?"). Any other action is returned as it is.
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

}  // namespace

std::size_t decideAction(const DialogPomdp& d, const pomdp::TurnLimitedPolicy& policy,
                         const pomdp::Belief& b, int turns) {
  const std::size_t a = policy.bestAction(b, turns);
  const auto mostLikely = [&] {
    Eigen::Index best = 0;
    b.head(static_cast<Eigen::Index>(d.numRequests())).maxCoeff(&best);
    return d.serveAction(static_cast<std::size_t>(best));
  };
  if (turns >= d.spec().turnLimit) {
    if (!d.isServe(a))
      throw ConfigError("dialog: the policy asks '" + d.model().actionNames()[a] + "' after " +
                        std::to_string(turns) + " questions, at the turn limit where it must " +
                        "serve (was it solved without the limit?)");
    return mostLikely();
  }
  if (!d.isServe(a)) return phrasedConfirm(d, a, b);
  const double serve = policy.lookahead(d.model(), b, a, turns, true);
  std::vector<std::size_t> questions;
  for (std::size_t q = 0; q < d.model().getA() && d.isQuestion(q); ++q) questions.push_back(q);
  const std::vector<double> values = policy.lookahead(d.model(), b, questions, turns);
  std::size_t best = a;
  double bestValue = serve;
  for (std::size_t k = 0; k < questions.size(); ++k)
    if (values[k] > bestValue + 1e-9) {
      bestValue = values[k];
      best = questions[k];
    }
  return phrasedConfirm(d, best, b);
}

std::size_t DecisionMemo::decide(const DialogPomdp& d,
                                 const pomdp::TurnLimitedPolicy& policy, const pomdp::Belief& b,
                                 int turns) {
  key_.assign(reinterpret_cast<const char*>(&turns), sizeof(turns));
  key_.append(reinterpret_cast<const char*>(b.data()),
              static_cast<std::size_t>(b.size()) * sizeof(double));
  const auto it = memo_.find(key_);
  if (it != memo_.end()) {
    ++hits_;
    return it->second;
  }
  ++misses_;
  const std::size_t a = decideAction(d, policy, b, turns);
  if (memo_.size() >= capacity_) memo_.clear();
  memo_.emplace(key_, a);
  return a;
}

std::size_t DialogSession::nextAction() const {
  if (finished_) throw ConfigError("dialog session: the dialog has ended");
  if (!policy_) {
    if (atTurnLimit()) return dialog_.serveAction(summary().mostLikely);
    throw ConfigError("dialog session: no policy to choose the next action");
  }
  return memo_ ? memo_->decide(dialog_, *policy_, belief_, turns_)
               : decideAction(dialog_, *policy_, belief_, turns_);
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
  return true;
}

BeliefSummary DialogSession::summary() const { return summarizeBelief(dialog_, belief_); }

}  // namespace dialog
}  // namespace krr
