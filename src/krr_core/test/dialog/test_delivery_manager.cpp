// DeliveryManager: one delivery from the first words to the end, the class dialog_node and the
// delivery experiments both drive. Dialog turns and the repair of a misunderstood answer, the
// serve (forced at the turn limit), legs, the check at the room, redelivery, failures and the
// reward of a delivery, on a small model with a solved policy.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/delivery_manager.h"
#include "krr_core/dialog/certified_dialog_solver.h"

namespace {

using namespace krr;
using namespace krr::dialog;

/// coke / soda x room1 / room2 x bob; every room always reached; a wrong delivery costs 100.
struct Fixture {
  DialogPomdp dialog;
  pomdp::TurnLimitedPolicy policy;
  LanguageFrontEnd language;
  DialogConfig config;

  explicit Fixture(int turnLimit = 6)
      : dialog(spec(turnLimit)), policy(solve(dialog)), language(dialog, LanguageConfig()) {
    config.shop = "shop";
    config.turn_limit = turnLimit;
  }
  static DialogSpec spec(int turnLimit) {
    DialogSpec s;
    s.items = {"coke", "soda"};
    s.rooms = {"room1", "room2"};
    s.persons = {"bob"};
    s.serveCost = 100.0 * (Eigen::MatrixXd::Ones(4, 4) - Eigen::MatrixXd::Identity(4, 4));
    s.turnLimit = turnLimit;
    return s;
  }
  static pomdp::TurnLimitedPolicy solve(const DialogPomdp& d) {
    CertifiedSolverOptions o;
    o.precision = 1e-6;
    CertifiedDialogSolver s(d, Eigen::VectorXd(), 0, o);
    s.solve();
    return s.policy();
  }
  std::size_t request(const std::string& item, const std::string& room) const {
    return dialog.requestIndex(item == "coke" ? 0 : 1, room == "room1" ? 0 : 1, 0);
  }
};

/// Answers every question truthfully in words for `want`; at the room says `checks` in order.
class Person : public DeliveryPerson {
 public:
  Person(const DialogPomdp& d, std::size_t want, std::string opening,
         std::vector<std::string> checks)
      : d_(d), want_(want), opening_(std::move(opening)), checks_(std::move(checks)) {}
  void open(DeliveryManager& m) override {
    if (!opening_.empty()) m.hear(opening_);
  }
  bool answer(DeliveryManager& m, std::size_t q) override {
    const auto names = m.requestNames(want_);
    const std::string action = d_.model().actionNames()[q];
    std::string text;
    switch (d_.actionKind(q)) {
      case DialogActionKind::kAskItem: text = names[0]; break;
      case DialogActionKind::kAskRoom: text = names[1]; break;
      case DialogActionKind::kAskPerson: text = names[2]; break;
      default: {
        const std::string value = action.substr(action.rfind('_') + 1);
        text = value == names[0] || value == names[1] || value == names[2] ? "yes" : "no";
      }
    }
    m.hear(text);
    ++answers;
    return true;
  }
  bool check(DeliveryManager& m) override {
    if (next_ >= checks_.size()) return false;
    m.check(checks_[next_++]);
    return true;
  }
  int answers = 0;

 private:
  const DialogPomdp& d_;
  std::size_t want_;
  std::string opening_;
  std::vector<std::string> checks_;
  std::size_t next_ = 0;
};

class Legs : public DeliveryNavigator {
 public:
  explicit Legs(std::vector<bool> ok = {}) : ok_(std::move(ok)) {}
  LegRecord drive(const Leg& leg) override {
    const bool ok = k_ >= ok_.size() || ok_[k_];
    ++k_;
    places.push_back(leg.place);
    return {leg, ok, 7, ok ? "" : "trapped by walkers"};
  }
  std::vector<std::string> places;

 private:
  std::vector<bool> ok_;
  std::size_t k_ = 0;
};

std::vector<std::string> tail(const std::vector<std::string>& v, std::size_t n) {
  return {v.end() - static_cast<long>(std::min(n, v.size())), v.end()};
}

TEST(DeliveryManager, ConfirmedDeliveryPicksUpAtTheShopThenDrivesToTheRoom) {
  Fixture f;
  DeliveryManager m(f.dialog, f.policy, &f.language, f.config);
  const std::size_t want = f.request("soda", "room2");
  Person p(f.dialog, want, "a soda to room2", {"yes"});
  Legs legs;
  ASSERT_TRUE(runDelivery(m, p, legs));
  const DeliveryRecord& r = m.record();
  EXPECT_EQ(r.served, want);
  EXPECT_EQ(r.outcome, DeliveryOutcome::kFulfilled);
  EXPECT_EQ(r.attempts, 1);
  EXPECT_EQ(legs.places, (std::vector<std::string>{"shop", "room2"}));
  EXPECT_EQ(r.navMoves(), 14u);
  EXPECT_EQ(r.turns, p.answers);
  EXPECT_DOUBLE_EQ(r.served_probability, r.max_probability);
  // The log: the dialog's actions (model names), then the legs, the check and the outcome.
  const auto& d = m.decisions();
  ASSERT_EQ(d.size(), static_cast<std::size_t>(r.turns) + 5);
  EXPECT_EQ(d[static_cast<std::size_t>(r.turns)], "serve_soda_room2_bob");
  EXPECT_EQ(tail(d, 4), (std::vector<std::string>{"navigate shop", "navigate room2", "check yes",
                                                  "fulfilled"}));
  EXPECT_EQ(m.phase(), DeliveryPhase::kDone);
  // Naming the delivered request again (without "no") also confirms it.
  DeliveryManager m2(f.dialog, f.policy, &f.language, f.config);
  Person p2(f.dialog, want, "a soda to room2", {"a soda to room2, thanks"});
  ASSERT_TRUE(runDelivery(m2, p2, legs));
  EXPECT_EQ(m2.record().outcome, DeliveryOutcome::kFulfilled);
}

TEST(DeliveryManager, WrongDeliveryGoesBackToTheShopAndRedelivers) {
  Fixture f;
  DeliveryManager m(f.dialog, f.policy, &f.language, f.config);
  // The person asks for a coke to room1 but the robot hears a soda to room2 (their answers to
  // the robot's questions agree with what it heard); at room2 they correct it.
  Person p(f.dialog, f.request("soda", "room2"), "a soda to room2",
           {"no, a coke to room1", "yes"});
  Legs legs;
  ASSERT_TRUE(runDelivery(m, p, legs));
  const DeliveryRecord& r = m.record();
  EXPECT_EQ(r.served, f.request("soda", "room2"));
  EXPECT_EQ(r.delivering, f.request("coke", "room1"));
  EXPECT_TRUE(r.redelivered);
  EXPECT_EQ(r.attempts, 2);
  EXPECT_EQ(r.outcome, DeliveryOutcome::kFulfilled);
  EXPECT_EQ(legs.places, (std::vector<std::string>{"shop", "room2", "shop", "room1"}));
  EXPECT_EQ(tail(m.decisions(), 7),
            (std::vector<std::string>{"navigate shop", "navigate room2", "check coke_room1_bob",
                                      "navigate shop", "navigate room1", "check yes", "fulfilled"}));
  ASSERT_EQ(r.legs.size(), 4u);
  EXPECT_EQ(r.legs[2].leg.kind, Leg::Kind::kReturn);
  EXPECT_EQ(r.legs[3].leg.kind, Leg::Kind::kToRoom);
  // Only what differs needs saying: "no, room1" keeps the item.
  DeliveryManager m2(f.dialog, f.policy, &f.language, f.config);
  Person p2(f.dialog, f.request("soda", "room2"), "a soda to room2", {"no, room1", "yes"});
  ASSERT_TRUE(runDelivery(m2, p2, legs));
  EXPECT_EQ(m2.record().delivering, f.request("soda", "room1"));
}

TEST(DeliveryManager, NoRedeliveryLeftFailsAndUnansweredChecksEnd) {
  Fixture f;
  f.config.max_redeliveries = 0;
  DeliveryManager m(f.dialog, f.policy, &f.language, f.config);
  Person p(f.dialog, f.request("soda", "room2"), "a soda to room2", {"no, a coke to room1"});
  Legs legs;
  ASSERT_TRUE(runDelivery(m, p, legs));
  EXPECT_EQ(m.record().outcome, DeliveryOutcome::kFailed);
  EXPECT_NE(m.record().message.find("no redelivery left"), std::string::npos) << m.record().message;

  // Nobody answers: unconfirmed. "No" without the right request, then nothing: failed.
  DeliveryManager m2(f.dialog, f.policy, &f.language, f.config);
  Person silent(f.dialog, f.request("soda", "room2"), "a soda to room2", {});
  ASSERT_TRUE(runDelivery(m2, silent, legs));
  EXPECT_EQ(m2.record().outcome, DeliveryOutcome::kUnconfirmed);
  DeliveryManager m3(f.dialog, f.policy, &f.language, f.config);
  Person no(f.dialog, f.request("soda", "room2"), "a soda to room2", {"no"});
  ASSERT_TRUE(runDelivery(m3, no, legs));
  EXPECT_EQ(m3.record().outcome, DeliveryOutcome::kFailed);
  // An unclear check asks again and keeps waiting.
  DeliveryManager m4(f.dialog, f.policy, &f.language, f.config);
  Person p4(f.dialog, f.request("soda", "room2"), "a soda to room2", {});
  m4.start();
  p4.open(m4);
  while (m4.phase() == DeliveryPhase::kDialog) {
    const std::size_t a = m4.decide();
    if (f.dialog.isQuestion(a)) p4.answer(m4, a);
  }
  m4.legDone(true, 0);
  m4.legDone(true, 0);
  ASSERT_EQ(m4.phase(), DeliveryPhase::kAwaitCheck);
  std::string reply;
  EXPECT_EQ(m4.check("hmm", &reply), CheckResult::kUnclear);
  EXPECT_NE(reply.find("Is this right?"), std::string::npos) << reply;
  EXPECT_EQ(m4.check("a coke and a soda", &reply), CheckResult::kUnclear);
  EXPECT_NE(reply.find("several"), std::string::npos) << reply;
  EXPECT_EQ(m4.phase(), DeliveryPhase::kAwaitCheck);
  EXPECT_EQ(m4.check("yes"), CheckResult::kConfirmed);
  EXPECT_EQ(m4.record().outcome, DeliveryOutcome::kFulfilled);
}

TEST(DeliveryManager, TheCorrectionHintUsesTheModelsOwnNames) {
  // Another building: none of the office's names. The hint after "no" must be one this
  // robot understands.
  DialogSpec s;
  s.items = {"tea", "juice"};
  s.rooms = {"lab", "studio"};
  s.persons = {"carol"};
  s.serveCost = 100.0 * (Eigen::MatrixXd::Ones(4, 4) - Eigen::MatrixXd::Identity(4, 4));
  s.turnLimit = 6;
  const DialogPomdp dialog(s);
  const pomdp::TurnLimitedPolicy policy = Fixture::solve(dialog);
  const LanguageFrontEnd language(dialog, LanguageConfig());
  DialogConfig config;
  config.shop = "shop";
  config.turn_limit = 6;
  DeliveryManager m(dialog, policy, &language, config);
  Person p(dialog, dialog.requestIndex(1, 1, 0), "a juice to studio", {});
  m.start();
  p.open(m);
  while (m.phase() == DeliveryPhase::kDialog) {
    const std::size_t a = m.decide();
    if (dialog.isQuestion(a)) p.answer(m, a);
  }
  m.legDone(true, 0);
  m.legDone(true, 0);
  ASSERT_EQ(m.phase(), DeliveryPhase::kAwaitCheck);
  std::string reply;
  EXPECT_EQ(m.check("no", &reply), CheckResult::kUnclear);
  EXPECT_EQ(reply, "Sorry! What did you ask for? (for example: no, a tea for carol to lab)");
  EXPECT_EQ(exampleRequest(dialog.spec()), "a tea for carol to lab");
}

TEST(DeliveryManager, ALegThatDoesNotArriveFailsTheDelivery) {
  Fixture f;
  DeliveryManager m(f.dialog, f.policy, &f.language, f.config);
  Person p(f.dialog, f.request("coke", "room1"), "a coke to room1", {"yes"});
  Legs legs({true, false});
  ASSERT_TRUE(runDelivery(m, p, legs));
  const DeliveryRecord& r = m.record();
  EXPECT_EQ(r.outcome, DeliveryOutcome::kFailed);
  EXPECT_TRUE(r.navFailed());
  EXPECT_NE(r.message.find("room1"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("trapped by walkers"), std::string::npos) << r.message;
  EXPECT_EQ(m.decisions().back(), "failed");
}

TEST(DeliveryManager, MisunderstoodAnswerRepeatsTheQuestionWithoutATurn) {
  Fixture f;
  DeliveryManager m(f.dialog, f.policy, &f.language, f.config);
  m.start();
  const std::size_t q = m.decide();  // from the prior: the robot must ask first
  ASSERT_TRUE(f.dialog.isQuestion(q)) << f.dialog.model().actionNames()[q];
  EXPECT_EQ(m.record().turns, 1);
  const double cost = m.record().qa_cost;
  EXPECT_FALSE(m.hear("xyzzy").understood());
  EXPECT_EQ(m.decide(), q);  // the same question again
  EXPECT_EQ(m.record().turns, 1);
  EXPECT_DOUBLE_EQ(m.record().qa_cost, cost);
  EXPECT_EQ(m.decisions().size(), 2u);
  // Phase errors are reported, not ignored.
  EXPECT_THROW(m.leg(), ConfigError);
  EXPECT_THROW(m.legDone(true, 1), ConfigError);
  EXPECT_THROW(m.checkRequest(0), ConfigError);
  m.reset();
  EXPECT_EQ(m.phase(), DeliveryPhase::kIdle);
  EXPECT_THROW(m.hear("coke"), ConfigError);
}

TEST(DeliveryManager, TheTurnLimitForcesTheMostLikelyRequest) {
  Fixture f(0);  // no question allowed
  DeliveryManager m(f.dialog, f.policy, &f.language, f.config);
  m.start();
  m.hear("a soda to room1");
  const std::size_t a = m.decide();
  ASSERT_TRUE(f.dialog.isServe(a));
  EXPECT_TRUE(m.record().forced);
  EXPECT_EQ(m.record().served, f.request("soda", "room1"));
  EXPECT_EQ(m.phase(), DeliveryPhase::kNavigating);
  EXPECT_EQ(m.leg().place, "shop");
  EXPECT_EQ(m.leg().kind, Leg::Kind::kPickup);
}

TEST(DeliveryManager, RewardOfADeliveryHasTheServeRewardsTerms) {
  DialogConfig c;
  c.wrong_delivery_penalty = 120.0;
  DeliveryRecord r;
  r.served = 3;
  r.qa_cost = 5.5;
  r.outcome = DeliveryOutcome::kFulfilled;
  r.legs = {{{Leg::Kind::kPickup, "shop", 0}, true, 0, ""},
            {{Leg::Kind::kToRoom, "room1", 0}, true, 12, ""},
            {{Leg::Kind::kReturn, "shop", 0}, true, 11, ""},
            {{Leg::Kind::kToRoom, "room2", 1}, true, 20, ""}};
  DeliveryReward w = deliveryReward(r, 7, c);  // served 3, asked for 7: wrong, redelivered
  EXPECT_DOUBLE_EQ(w.delivery, 80.0);
  EXPECT_DOUBLE_EQ(w.qa, 5.5);
  EXPECT_DOUBLE_EQ(w.navigation, 43.0);  // step cost 1 x 43 moves
  EXPECT_DOUBLE_EQ(w.penalty, 120.0);
  EXPECT_DOUBLE_EQ(w.total(), 80.0 - 5.5 - 43.0 - 120.0);
  r.outcome = DeliveryOutcome::kFailed;
  r.legs.back().reached = false;
  w = deliveryReward(r, 3, c);  // right request, trapped on the way
  EXPECT_DOUBLE_EQ(w.delivery, -80.0);
  EXPECT_DOUBLE_EQ(w.navigation, 43.0 + 40.0);  // + the failure penalty
  EXPECT_DOUBLE_EQ(w.penalty, 0.0);
  c.serve_cost_mode = ServeCostMode::kNone;  // the paper's formula: no navigation term
  EXPECT_DOUBLE_EQ(deliveryReward(r, 3, c).navigation, 0.0);
}

TEST(DeliveryManager, SilentPersonLeavesTheDialogUnfinished) {
  Fixture f;
  class Silent : public DeliveryPerson {
    bool answer(DeliveryManager&, std::size_t) override { return false; }
    bool check(DeliveryManager&) override { return false; }
  } silent;
  Legs legs;
  DeliveryManager m(f.dialog, f.policy, &f.language, f.config);
  EXPECT_FALSE(runDelivery(m, silent, legs));
  EXPECT_EQ(m.phase(), DeliveryPhase::kDialog);
  EXPECT_TRUE(legs.places.empty());
}

}  // namespace
