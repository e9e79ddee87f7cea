// Tests of DialogSession: belief updates from text and from observations, turns, the turn
// limit, the decision rule (decideAction), robustness.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/dialog_policy.h"
#include "krr_core/dialog/dialog_session.h"
#include "../support/office_dialog.h"

namespace krr {
namespace dialog {
namespace {

DialogSpec officeSpec() {
  DialogSpec spec = test::officeSpec();
  spec.persons = {"john", "bob"};
  spec.prior = ownOfficePrior(3, 5, {4, 1}, 0.8);  // john: room5, bob: room2
  return spec;
}

LanguageConfig config() {
  LanguageConfig c;
  c.ignoreWords = {"a", "for", "to"};
  c.synonyms = {{"office2", "room2"}};
  return c;
}

Eigen::VectorXd constant(const DialogPomdp& d, double v) {
  return Eigen::VectorXd::Constant(static_cast<Eigen::Index>(d.model().getS()), v);
}

/// A hand-made turn-limited policy: `question` (value 0) before the turn limit, and at the
/// limit (where the policy must serve) serve(`served`) with a value far below.
pomdp::TurnLimitedPolicy askThenServe(const DialogPomdp& d, std::size_t question,
                                      std::size_t served) {
  const int limit = d.spec().turnLimit;
  pomdp::TurnLimitedPolicy p(d.model().getS(), limit);
  p.add(constant(d, 0.0), question, limit - 1);
  p.add(constant(d, -1000.0), d.serveAction(served), limit);
  return p;
}

TEST(DialogSession, FullRequestMatchesTheHandComputedPosterior) {
  DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  DialogSession s(d, &lang);
  const BeliefSummary before = s.summary();
  EXPECT_NEAR(before.rooms(1), 0.425, 1e-12);  // 0.5 * 0.8 + 0.5 * 0.05
  HearResult h = s.hear("A coke for Bob to office2");
  ASSERT_EQ(h.applied.size(), 3u);
  EXPECT_TRUE(h.understood());
  const BeliefSummary after = s.summary();
  // Items: uniform prior, one answer "coke" with accuracy 0.8 -> 0.8, 0.1, 0.1.
  EXPECT_NEAR(after.items(0), 0.8, 1e-12);
  EXPECT_NEAR(after.items(1), 0.1, 1e-12);
  // (room, person): weights prior * P(bob | p) * P(room2 | r), see the derivation:
  // bob/room2 0.256, john/room2 0.004, bob/other 4 x 0.001, john/room5 0.004,
  // john/other 3 x 0.00025; total 0.26875.
  EXPECT_NEAR(after.persons(1), 0.26 / 0.26875, 1e-12);
  EXPECT_NEAR(after.rooms(1), 0.26 / 0.26875, 1e-12);
  EXPECT_NEAR(after.rooms(4), (0.004 + 0.001) / 0.26875, 1e-12);
  EXPECT_LT(after.entropy, before.entropy);
  EXPECT_EQ(d.requestName(after.mostLikely), "coke_room2_bob");
  EXPECT_EQ(s.turns(), 0);  // the user spoke first: no question asked
}

TEST(DialogSession, YesAnswersTheQuestionAskedAndCountsTurns) {
  DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  DialogSession s(d, &lang);
  s.act(d.confirmItem(1));  // "Should I deliver a coffee?"
  EXPECT_EQ(s.turns(), 1);
  EXPECT_EQ(s.lastQuestion(), static_cast<long>(d.confirmItem(1)));
  HearResult h = s.hear("yes");
  ASSERT_EQ(h.applied.size(), 1u);
  EXPECT_EQ(h.applied[0].action, d.confirmItem(1));
  EXPECT_NEAR(s.summary().items(1), 2.0 / 3, 1e-12);  // 0.8 / (0.8 + 0.2 + 0.2)
  // A yes before any question is ignored with a note and leaves the belief alone.
  s.reset();
  const pomdp::Belief b0 = s.belief();
  HearResult ignored = s.hear("yes");
  EXPECT_FALSE(ignored.understood());
  EXPECT_EQ(ignored.notes.size(), 1u);
  EXPECT_TRUE(s.belief().isApprox(b0));
}

TEST(DialogSession, GarbageLeavesTheBeliefAndReportsWords) {
  DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  DialogSession s(d, &lang);
  const pomdp::Belief b0 = s.belief();
  HearResult h = s.hear("blorp %%% zing");
  EXPECT_FALSE(h.understood());
  EXPECT_EQ(h.unknownWords, (std::vector<std::string>{"blorp", "zing"}));
  EXPECT_FALSE(h.notes.empty());
  EXPECT_EQ(s.belief(), b0);
  EXPECT_FALSE(s.hear("").understood());
}

TEST(DialogSession, ImpossibleObservationIsReportedNotThrown) {
  DialogSpec spec = officeSpec();
  spec.pGeneral = 1.0;  // answers are always right: hearing coffee after coke is impossible
  DialogPomdp d(spec);
  LanguageFrontEnd lang(d, config());
  DialogSession s(d, &lang);
  ASSERT_TRUE(s.hear("coke").understood());
  const pomdp::Belief b = s.belief();
  HearResult h = s.hear("coffee");
  EXPECT_FALSE(h.understood());
  ASSERT_EQ(h.notes.size(), 1u);
  EXPECT_NE(h.notes[0].find("impossible"), std::string::npos) << h.notes[0];
  EXPECT_EQ(s.belief(), b);
}

TEST(DialogSession, ObserveUpdatesTheBeliefLikeHearing) {
  DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  // A simulated person's answers come as observations: no language front end needed.
  DialogSession sim(d, nullptr);
  DialogSession text(d, &lang);
  sim.act(d.confirmItem(1));
  text.act(d.confirmItem(1));
  EXPECT_TRUE(sim.observe(d.confirmItem(1), d.obsYes()));
  text.hear("yes");
  EXPECT_NEAR(sim.summary().items(1), 2.0 / 3, 1e-12);  // 0.8 / (0.8 + 0.2 + 0.2)
  EXPECT_TRUE(sim.belief().isApprox(text.belief(), 1e-12));
  EXPECT_EQ(sim.turns(), 1);  // observing does not count a turn, asking does
  EXPECT_TRUE(sim.observe(d.askRoom(), d.obsRoom(1)));
  EXPECT_TRUE(text.hear("room2").understood());
  EXPECT_TRUE(sim.belief().isApprox(text.belief(), 1e-12));
  EXPECT_EQ(sim.turns(), 1);
  // Not a question, an observation out of range, text without a front end: ConfigError.
  EXPECT_THROW(sim.observe(d.serveAction(0), d.obsNone()), ConfigError);
  EXPECT_THROW(sim.observe(d.model().getA(), d.obsYes()), ConfigError);
  EXPECT_THROW(sim.observe(d.askItem(), d.model().getO()), ConfigError);
  EXPECT_THROW(sim.hear("coke"), ConfigError);
  // After the serve, nothing more is observed.
  sim.act(d.serveAction(0));
  EXPECT_THROW(sim.observe(d.askItem(), d.obsItem(0)), ConfigError);
}

TEST(DialogSession, ImpossibleObservationLeavesTheBelief) {
  DialogSpec spec = officeSpec();
  spec.pGeneral = 1.0;  // answers are always right: hearing coffee after coke is impossible
  DialogPomdp d(spec);
  DialogSession s(d, nullptr);
  ASSERT_TRUE(s.observe(d.askItem(), d.obsItem(0)));
  EXPECT_NEAR(s.summary().items(0), 1.0, 1e-12);
  const pomdp::Belief b = s.belief();
  EXPECT_FALSE(s.observe(d.askItem(), d.obsItem(1)));
  EXPECT_EQ(s.belief(), b);
  // Yes / no to a general question is impossible too (only item names answer "which item?").
  EXPECT_FALSE(s.observe(d.askItem(), d.obsYes()));
  EXPECT_EQ(s.belief(), b);
}

TEST(DialogSession, TurnLimitForcesServingTheMostLikelyRequest) {
  DialogSpec spec = officeSpec();
  spec.turnLimit = 3;
  DialogPomdp d(spec);
  LanguageFrontEnd lang(d, config());
  // The policy asks for the room until the limit and there serves <coke, room1, john>, which
  // the answers make unlikely: the turn-limit rule serves the most likely request instead.
  const std::size_t policyServes = d.requestIndex(0, 0, 0);
  const auto policy = askThenServe(d, d.askRoom(), policyServes);
  DialogSession s(d, &lang, &policy);
  s.hear("soda for john");
  for (int t = 0; t < 3; ++t) {
    EXPECT_FALSE(s.atTurnLimit());
    const std::size_t a = s.nextAction();
    ASSERT_EQ(a, d.askRoom());
    s.act(a);
    s.hear("room3");
  }
  EXPECT_TRUE(s.atTurnLimit());
  EXPECT_EQ(s.turns(), 3);
  EXPECT_EQ(policy.bestAction(s.belief(), s.turns()), d.serveAction(policyServes));
  const std::size_t serve = s.nextAction();
  ASSERT_TRUE(d.isServe(serve));
  EXPECT_EQ(d.requestName(d.requestOfServe(serve)), "soda_room3_john");
  EXPECT_EQ(d.requestOfServe(serve), s.summary().mostLikely);
  EXPECT_NE(d.requestOfServe(serve), policyServes);
  EXPECT_EQ(decideAction(d, policy, s.belief(), s.turns()), serve);
  s.act(serve);
  EXPECT_TRUE(s.finished());
  EXPECT_EQ(s.servedRequest(), d.requestOfServe(serve));
  EXPECT_FALSE(s.hear("coke").understood());
  EXPECT_THROW(s.nextAction(), ConfigError);
  EXPECT_THROW(s.act(d.askItem()), ConfigError);
}

TEST(DialogSession, WithoutAPolicyOnlyTheTurnLimitDecides) {
  DialogSpec spec = officeSpec();
  spec.turnLimit = 2;
  DialogPomdp d(spec);
  DialogSession s(d, nullptr);
  EXPECT_THROW(s.nextAction(), ConfigError);  // scripted dialogs choose their questions
  s.act(d.askItem());
  ASSERT_TRUE(s.observe(d.askItem(), d.obsItem(1)));
  s.act(d.askPerson());
  ASSERT_TRUE(s.observe(d.askPerson(), d.obsPerson(1)));
  ASSERT_TRUE(s.atTurnLimit());
  const std::size_t serve = s.nextAction();
  ASSERT_TRUE(d.isServe(serve));
  EXPECT_EQ(d.requestName(d.requestOfServe(serve)), "coffee_room2_bob");  // bob's office
}

TEST(DialogSession, APolicyThatAsksAtTheTurnLimitIsAnError) {
  DialogSpec spec = officeSpec();
  spec.turnLimit = 2;
  DialogPomdp d(spec);
  // The only vector usable at the limit (stage 2) is a question: a policy solved without the
  // limit. It is reported, not silently overridden.
  pomdp::TurnLimitedPolicy asks(d.model().getS(), 2);
  asks.add(constant(d, 0.0), d.confirmRoom(1), 2);
  asks.add(constant(d, -5.0), d.serveAction(0), 1);  // serves, but only before the limit
  DialogSession s(d, nullptr, &asks);
  EXPECT_EQ(s.nextAction(), d.confirmRoom(1));
  s.act(d.confirmRoom(1));
  s.act(d.confirmRoom(1));
  ASSERT_TRUE(s.atTurnLimit());
  try {
    s.nextAction();
    ADD_FAILURE() << "a question at the turn limit was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("confirm_room_room2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(decideAction(d, asks, s.belief(), 2), ConfigError);
  EXPECT_THROW(decideAction(d, asks, s.belief(), 5), ConfigError);  // beyond: as at the limit
}

TEST(DecideAction, LookaheadAsksWhenAQuestionIsWorthMoreThanTheServe) {
  DialogSpec spec = officeSpec();
  Eigen::VectorXd reach = Eigen::VectorXd::Constant(5, 0.5);
  spec.delivery = deliveryMatrix(3, reach, 2);
  DialogPomdp d(spec);
  const pomdp::Model& m = d.model();
  const std::size_t target = d.requestIndex(0, 1, 1);  // coke, room2, bob
  // The policy serves everywhere (value 0 beats the question's -1), but its serve vector is
  // not the serve's real worth: at the prior, serving earns R(b, serve) < 0 while a
  // confirmation costs 1.5 and leads to beliefs the policy values at 0.
  pomdp::TurnLimitedPolicy p(m.getS(), spec.turnLimit);
  p.add(constant(d, 0.0), d.serveAction(target), spec.turnLimit);
  p.add(constant(d, -1.0), d.confirmRoom(1), spec.turnLimit - 1);
  const pomdp::Belief prior = m.initialBelief();
  ASSERT_EQ(p.bestAction(prior, 0), d.serveAction(target));
  const double serveValue = p.lookahead(m, prior, d.serveAction(target), 0, true);
  EXPECT_NEAR(serveValue, pomdp::expectedReward(m, prior, d.serveAction(target)), 1e-12);
  EXPECT_LT(serveValue, -1.5);
  const std::size_t a = decideAction(d, p, prior, 0);
  ASSERT_TRUE(d.isQuestion(a));
  // The best question by the lookahead (every confirmation is worth -1.5, the first wins).
  EXPECT_EQ(a, d.confirmItem(0));
  EXPECT_NEAR(p.lookahead(m, prior, a, 0, false), -1.5, 1e-12);
  for (std::size_t q = 0; d.isQuestion(q); ++q)
    EXPECT_LE(p.lookahead(m, prior, q, 0, false), p.lookahead(m, prior, a, 0, false) + 1e-9);
  // Certain of the request, the serve earns 80 (0.5) - 80 (0.5) = 0 > -1.5: it stays.
  pomdp::Belief sure = pomdp::Belief::Zero(static_cast<Eigen::Index>(m.getS()));
  sure(static_cast<Eigen::Index>(target)) = 1.0;
  EXPECT_EQ(decideAction(d, p, sure, 0), d.serveAction(target));
  // At the turn limit there is no lookahead: the most likely request is served.
  EXPECT_EQ(decideAction(d, p, prior, spec.turnLimit),
            d.serveAction(summarizeBelief(d, prior).mostLikely));
  // A session follows the same rule.
  DialogSession s(d, nullptr, &p);
  EXPECT_EQ(s.nextAction(), a);
}

TEST(DecideAction, ATwoValueConfirmationNamesTheLikelierValue) {
  // Solvers keep one of "is it for john?" / "is it for bob?" (one experiment on two values);
  // the robot must ask about the person it believes more likely, whichever the policy stored.
  DialogPomdp d(officeSpec());
  const pomdp::Model& m = d.model();
  pomdp::TurnLimitedPolicy p = askThenServe(d, d.confirmPerson(0), 0);  // "john?"
  pomdp::Belief b = pomdp::Belief::Zero(static_cast<Eigen::Index>(m.getS()));
  b(static_cast<Eigen::Index>(d.requestIndex(0, 1, 1))) = 0.98;  // bob
  b(static_cast<Eigen::Index>(d.requestIndex(0, 4, 0))) = 0.02;  // john
  EXPECT_EQ(decideAction(d, p, b, 0), d.confirmPerson(1));
  b(static_cast<Eigen::Index>(d.requestIndex(0, 1, 1))) = 0.02;
  b(static_cast<Eigen::Index>(d.requestIndex(0, 4, 0))) = 0.98;
  EXPECT_EQ(decideAction(d, p, b, 0), d.confirmPerson(0));
  // Equal: the policy's own wording. More than two values: confirmations are distinct
  // experiments, left as they are.
  b(static_cast<Eigen::Index>(d.requestIndex(0, 1, 1))) = 0.5;
  b(static_cast<Eigen::Index>(d.requestIndex(0, 4, 0))) = 0.5;
  EXPECT_EQ(decideAction(d, p, b, 0), d.confirmPerson(0));
  pomdp::TurnLimitedPolicy room = askThenServe(d, d.confirmRoom(0), 0);
  EXPECT_EQ(decideAction(d, room, b, 0), d.confirmRoom(0));
  // The same experiment: the answers swap, the posteriors agree.
  pomdp::Belief yes0, no1;
  ASSERT_TRUE(pomdp::tryUpdateBelief(m, m.initialBelief(), d.confirmPerson(0), d.obsYes(), yes0));
  ASSERT_TRUE(pomdp::tryUpdateBelief(m, m.initialBelief(), d.confirmPerson(1), d.obsNo(), no1));
  EXPECT_LT((yes0 - no1).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(DecideAction, TheMemoDecidesExactlyLikeTheRule) {
  DialogSpec spec = officeSpec();
  DialogPomdp d(spec);
  const pomdp::Model& m = d.model();
  const std::size_t target = d.requestIndex(0, 1, 1);
  pomdp::TurnLimitedPolicy p(m.getS(), spec.turnLimit);
  p.add(constant(d, 0.0), d.serveAction(target), spec.turnLimit);
  p.add(constant(d, -1.0), d.confirmRoom(1), spec.turnLimit - 1);
  p.add(constant(d, -0.5), d.askItem(), 2);
  DecisionMemo memo(3);  // tiny: it also forgets
  // Beliefs along real answer sequences, revisited: the memo answers as decideAction does.
  for (int round = 0; round < 3; ++round) {
    DialogSession s(d, nullptr, &p);
    s.setDecisionMemo(&memo);
    for (int turn = 0; turn < spec.turnLimit && !s.finished(); ++turn) {
      const std::size_t expected = decideAction(d, p, s.belief(), s.turns());
      ASSERT_EQ(s.nextAction(), expected);
      if (!d.isQuestion(expected)) break;
      s.act(expected);
      s.observe(expected, m.possibleObservations(expected).front());
    }
  }
  EXPECT_GT(memo.hits(), 0u);
  EXPECT_GT(memo.misses(), 0u);
}

/// A hand-made policy with plans: vector 0 (turn 0) asks "is it for john?"; "yes" continues
/// with vector 1 (serve `onYes`), "no" with vector 2 (serve `onNo`).
pomdp::TurnLimitedPolicy confirmJohnPlan(const DialogPomdp& d, std::size_t onYes, std::size_t onNo) {
  const int limit = d.spec().turnLimit;
  pomdp::TurnLimitedPolicy p(d.model().getS(), limit);
  p.add(constant(d, 10.0), d.confirmPerson(0), 0);
  p.add(constant(d, 0.0), d.serveAction(onYes), limit);
  p.add(constant(d, 0.0), d.serveAction(onNo), limit);
  std::vector<long> next(3 * d.model().getO(), -1);
  next[d.obsYes()] = 1;
  next[d.obsNo()] = 2;
  p.setPlans(d.model().getO(), next);
  return p;
}

TEST(DialogSession, FollowsThePlanOnTheAnswerToItsQuestion) {
  DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  const std::size_t bob2 = d.requestIndex(0, 1, 1), john5 = d.requestIndex(0, 4, 0);
  const pomdp::TurnLimitedPolicy p = confirmJohnPlan(d, john5, bob2);
  DialogSession s(d, &lang, &p);
  EXPECT_EQ(s.plan(), -1);  // at the prior: a scan finds vector 0
  ASSERT_EQ(s.nextAction(), d.confirmPerson(0));
  s.act(d.confirmPerson(0));
  ASSERT_TRUE(s.hear("no").understood());
  EXPECT_EQ(s.plan(), 2);
  EXPECT_EQ(s.nextAction(), d.serveAction(bob2));  // the plan's serve: the most likely request
  // "Is it for bob?" (the robot's wording of the plan's "john?" once bob is likelier): "yes"
  // to it is "no" to the plan's question.
  s.reset();
  ASSERT_EQ(s.hear("bob").applied.size(), 1u);  // no question asked yet: off any plan
  EXPECT_EQ(s.plan(), -1);
  ASSERT_EQ(s.nextAction(), d.confirmPerson(1));
  s.act(d.confirmPerson(1));
  ASSERT_TRUE(s.hear("yes").understood());
  EXPECT_EQ(s.plan(), 2);
  // More than the plan's answer leaves the plan; so does not answering at all.
  s.reset();
  s.act(s.nextAction());
  ASSERT_EQ(s.hear("no a coke").applied.size(), 2u);
  EXPECT_EQ(s.plan(), -1);
  s.reset();
  s.act(s.nextAction());
  EXPECT_FALSE(s.hear("blorp").understood());
  EXPECT_EQ(s.plan(), -1);
  ASSERT_TRUE(s.hear("no").understood());  // the answer, late: still the plan's question
  EXPECT_EQ(s.plan(), 2);
}

TEST(DialogSession, APlanServesOnlyTheMostLikelyRequest) {
  // The plan's serve is the reward's best for the plan's own belief; at any other belief the
  // robot serves it only if it is the most likely request, else it scans the policy.
  DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  const std::size_t bob2 = d.requestIndex(0, 1, 1), john5 = d.requestIndex(0, 4, 0);
  const pomdp::TurnLimitedPolicy p = confirmJohnPlan(d, bob2, john5);
  DialogSession s(d, &lang, &p);
  ASSERT_EQ(s.hear("a coke for bob to office2").applied.size(), 3u);
  ASSERT_EQ(s.summary().mostLikely, bob2);
  ASSERT_EQ(s.nextAction(), d.confirmPerson(1));  // "is it for bob?"
  s.act(d.confirmPerson(1));
  ASSERT_TRUE(s.hear("yes").understood());
  ASSERT_EQ(s.plan(), 2);  // "no" to "john?": the plan serves john5
  ASSERT_EQ(p.action(2), d.serveAction(john5));
  // bob2 is the most likely request: the scan decides (vectors 1 and 2 tie, the lowest index
  // wins, and no question is worth more than serving).
  EXPECT_EQ(s.nextAction(), d.serveAction(bob2));
  EXPECT_EQ(s.nextAction(), decideAction(d, p, s.belief(), s.turns()));
}

TEST(DialogSession, RefusesBadActionsAndPolicies) {
  DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  DialogSession noPolicy(d, &lang);
  EXPECT_THROW(noPolicy.nextAction(), ConfigError);
  EXPECT_THROW(noPolicy.act(d.model().getA()), ConfigError);
  pomdp::TurnLimitedPolicy wrong(3, d.spec().turnLimit);
  EXPECT_THROW(DialogSession(d, &lang, &wrong), ConfigError);
  // A policy solved for another turn limit does not fit the model.
  pomdp::TurnLimitedPolicy otherLimit(d.model().getS(), d.spec().turnLimit + 1);
  otherLimit.add(constant(d, 0.0), d.serveAction(0), d.spec().turnLimit + 1);
  EXPECT_THROW(DialogSession(d, &lang, &otherLimit), ConfigError);
  // One check, one message (dialog_policy.h policyMismatch) for the session, the experiment
  // and the policy cache.
  const std::string S = std::to_string(d.model().getS()), T = std::to_string(d.spec().turnLimit);
  EXPECT_EQ(policyMismatch(wrong, d),
            "policy has 3 states and turn limit " + T + ", the dialog model " + S + " and " + T);
  EXPECT_EQ(policyMismatch(otherLimit, d), "policy has " + S + " states and turn limit " +
                                               std::to_string(d.spec().turnLimit + 1) +
                                               ", the dialog model " + S + " and " + T);
  try {
    DialogSession bad(d, &lang, &wrong);
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "dialog session: " + policyMismatch(wrong, d));
  }
  // An empty policy has nothing to say.
  pomdp::TurnLimitedPolicy empty(d.model().getS(), d.spec().turnLimit);
  DialogSession none(d, &lang, &empty);
  EXPECT_THROW(none.nextAction(), ConfigError);
}

}  // namespace
}  // namespace dialog
}  // namespace krr
