#include "krr_core/dialog/dialog_session.h"

#include "krr_core/common/errors.h"

namespace krr {
namespace dialog {

BeliefSummary summarizeBelief(const pomdp::DialogPomdp& dialog, const pomdp::Belief& b) {
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

DialogSession::DialogSession(const pomdp::DialogPomdp& dialog, const LanguageFrontEnd& language,
                             const pomdp::AlphaVectorPolicy* policy)
    : dialog_(dialog), language_(language), policy_(policy) {
  if (policy_ && policy_->numStates() != dialog_.model().getS())
    throw ConfigError("dialog session: policy has " + std::to_string(policy_->numStates()) +
                      " states, the dialog model has " + std::to_string(dialog_.model().getS()));
  reset();
}

void DialogSession::reset() {
  belief_ = dialog_.model().initialBelief();
  turns_ = 0;
  lastQuestion_ = -1;
  finished_ = false;
  served_ = 0;
}

std::size_t DialogSession::nextAction() const {
  if (finished_) throw ConfigError("dialog session: the dialog has ended");
  if (atTurnLimit()) return dialog_.serveAction(summary().mostLikely);
  if (!policy_) throw ConfigError("dialog session: no policy to choose the next action");
  return policy_->bestAction(belief_);
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
  Interpretation in = language_.understand(text, dialog_, lastQuestion_);
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

BeliefSummary DialogSession::summary() const { return summarizeBelief(dialog_, belief_); }

}  // namespace dialog
}  // namespace krr
