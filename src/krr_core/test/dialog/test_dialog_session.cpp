// Tests of DialogSession: belief updates from text, turns, the turn limit, robustness.
#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/dialog_session.h"

namespace krr {
namespace dialog {
namespace {

pomdp::DialogSpec officeSpec() {
  pomdp::DialogSpec spec;
  spec.persons = {"john", "bob"};
  spec.prior = pomdp::ownOfficePrior(3, 5, {4, 1}, 0.8);  // john: room5, bob: room2
  return spec;
}

LanguageConfig config() {
  LanguageConfig c;
  c.ignoreWords = {"a", "for", "to"};
  c.synonyms = {{"office2", "room2"}};
  return c;
}

pomdp::AlphaVectorPolicy constantPolicy(const pomdp::DialogPomdp& d, std::size_t a) {
  pomdp::AlphaVectorPolicy p(d.model().getS());
  p.add(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(d.model().getS())), a);
  return p;
}

TEST(DialogSession, FullRequestMatchesTheHandComputedPosterior) {
  pomdp::DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  DialogSession s(d, lang);
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
  pomdp::DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  DialogSession s(d, lang);
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
  pomdp::DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  DialogSession s(d, lang);
  const pomdp::Belief b0 = s.belief();
  HearResult h = s.hear("blorp %%% zing");
  EXPECT_FALSE(h.understood());
  EXPECT_EQ(h.unknownWords, (std::vector<std::string>{"blorp", "zing"}));
  EXPECT_FALSE(h.notes.empty());
  EXPECT_EQ(s.belief(), b0);
  EXPECT_FALSE(s.hear("").understood());
}

TEST(DialogSession, ImpossibleObservationIsReportedNotThrown) {
  pomdp::DialogSpec spec = officeSpec();
  spec.pGeneral = 1.0;  // answers are always right: hearing coffee after coke is impossible
  pomdp::DialogPomdp d(spec);
  LanguageFrontEnd lang(d, config());
  DialogSession s(d, lang);
  ASSERT_TRUE(s.hear("coke").understood());
  const pomdp::Belief b = s.belief();
  HearResult h = s.hear("coffee");
  EXPECT_FALSE(h.understood());
  ASSERT_EQ(h.notes.size(), 1u);
  EXPECT_NE(h.notes[0].find("impossible"), std::string::npos) << h.notes[0];
  EXPECT_EQ(s.belief(), b);
}

TEST(DialogSession, TurnLimitForcesServingTheMostLikelyRequest) {
  pomdp::DialogSpec spec = officeSpec();
  spec.turnLimit = 3;
  pomdp::DialogPomdp d(spec);
  LanguageFrontEnd lang(d, config());
  auto askForever = constantPolicy(d, d.askRoom());
  DialogSession s(d, lang, &askForever);
  s.hear("soda for john");
  for (int t = 0; t < 3; ++t) {
    const std::size_t a = s.nextAction();
    ASSERT_EQ(a, d.askRoom());
    s.act(a);
    s.hear("room3");
  }
  EXPECT_TRUE(s.atTurnLimit());
  const std::size_t serve = s.nextAction();
  ASSERT_TRUE(d.isServe(serve));
  EXPECT_EQ(d.requestName(d.requestOfServe(serve)), "soda_room3_john");
  s.act(serve);
  EXPECT_TRUE(s.finished());
  EXPECT_EQ(s.servedRequest(), d.requestOfServe(serve));
  EXPECT_FALSE(s.hear("coke").understood());
  EXPECT_THROW(s.nextAction(), ConfigError);
  EXPECT_THROW(s.act(d.askItem()), ConfigError);
}

TEST(DialogSession, RefusesBadActionsAndPolicies) {
  pomdp::DialogPomdp d(officeSpec());
  LanguageFrontEnd lang(d, config());
  DialogSession noPolicy(d, lang);
  EXPECT_THROW(noPolicy.nextAction(), ConfigError);
  EXPECT_THROW(noPolicy.act(d.model().getA()), ConfigError);
  pomdp::AlphaVectorPolicy wrong(3);
  EXPECT_THROW(DialogSession(d, lang, &wrong), ConfigError);
}

}  // namespace
}  // namespace dialog
}  // namespace krr
