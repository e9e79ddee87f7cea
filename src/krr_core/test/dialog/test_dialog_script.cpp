// Tests of the scripted-dialog runner (paper, Figure 4) and its CSV / JSON output.
#include <gtest/gtest.h>

#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/dialog_script.h"
#include "krr_core/dialog/certified_dialog_solver.h"
#include "../support/office_dialog.h"

namespace krr {
namespace dialog {
namespace {

/// The office dialog of the paper; prior: john's office room5, bob's room2, 0.8.
DialogPomdp officeDialog() {
  DialogSpec spec = test::officeSpec();
  spec.persons = {"john", "bob"};
  spec.prior = ownOfficePrior(3, 5, {4, 1}, 0.8);
  Eigen::VectorXd reach(5);
  reach << 0.95, 0.65, 0.75, 0.95, 0.5;
  spec.delivery = deliveryMatrix(3, reach, 2);
  return DialogPomdp(spec);
}

/// The shipped configuration, so that a broken config/language.yaml fails here.
LanguageConfig shippedConfig() {
  return loadLanguageConfig(std::string(KRR_TEST_DATA_DIR) + "/../../../../config/language.yaml");
}

const std::vector<std::string> kFigure4 = {"I'd like to order a coke for Bob to office2.",
                                           "A coke.", "Yes.", "Yes."};
const std::vector<std::string> kFigure4Questions = {"ask_item", "confirm_item_coke",
                                                    "confirm_room_room2"};

TEST(DialogScript, Figure4BeliefMovesTowardsCokeBobRoom2) {
  DialogPomdp d = officeDialog();
  LanguageFrontEnd lang(d, shippedConfig());
  ScriptResult r = runDialogScript(d, lang, nullptr, kFigure4Questions, kFigure4);
  ASSERT_EQ(r.turns.size(), 5u);  // the prior and four user turns, as in Figure 4
  const auto& t = r.turns;
  for (std::size_t k = 1; k < t.size(); ++k) {
    EXPECT_TRUE(t[k].heard.unknownWords.empty()) << k;
    EXPECT_TRUE(t[k].heard.understood()) << k;
  }
  // Turn 0: uniform items and persons (the joint prior is not uniform: rooms 2 and 5).
  EXPECT_NEAR(t[0].belief.items(0), 1.0 / 3, 1e-12);
  EXPECT_NEAR(t[0].belief.persons(1), 0.5, 1e-12);
  // Turn 1: "a coke for Bob to office2" raises coke, bob and room2 together.
  EXPECT_EQ(t[1].heard.applied.size(), 3u);
  EXPECT_GT(t[1].belief.items(0), 0.75);
  EXPECT_GT(t[1].belief.persons(1), 0.95);
  EXPECT_GT(t[1].belief.rooms(1), 0.95);
  EXPECT_EQ(t[2].robotAction, "ask_item");
  EXPECT_EQ(t[2].robotText, "Which item is it?");
  EXPECT_EQ(t[3].robotAction, "confirm_item_coke");
  EXPECT_EQ(t[4].robotAction, "confirm_room_room2");
  // Turn 2 ("a coke") and turn 3 ("yes") only move the item; turn 4 ("yes") only the room.
  EXPECT_GT(t[2].belief.items(0), t[1].belief.items(0));
  EXPECT_NEAR(t[2].belief.rooms(1), t[1].belief.rooms(1), 1e-12);
  EXPECT_GT(t[3].belief.items(0), t[2].belief.items(0));
  EXPECT_NEAR(t[3].belief.persons(1), t[2].belief.persons(1), 1e-12);
  EXPECT_GT(t[4].belief.rooms(1), t[3].belief.rooms(1));
  EXPECT_NEAR(t[4].belief.items(0), t[3].belief.items(0), 1e-12);
  for (std::size_t k = 1; k < t.size(); ++k) EXPECT_LT(t[k].belief.entropy, t[k - 1].belief.entropy);
  EXPECT_EQ(d.requestName(t[4].belief.mostLikely), "coke_room2_bob");
  EXPECT_GT(t[4].belief.mostLikelyProbability, 0.95);
  EXPECT_FALSE(r.served);  // no policy: the script only asks
  EXPECT_EQ(t[4].nextAction, "");
}

TEST(DialogScript, PolicyDrivenScriptAsksWhatThePolicySays) {
  DialogPomdp d = officeDialog();
  LanguageFrontEnd lang(d, shippedConfig());
  CertifiedSolverOptions opt;
  opt.precision = 1.0;
  opt.maxTrials = 30;  // any policy will do: the runner must follow it, whatever it says
  CertifiedDialogSolver solver(d, Eigen::VectorXd(), 0, opt);
  solver.solve();
  const pomdp::TurnLimitedPolicy policy = solver.policy();
  ScriptResult r = runDialogScript(d, lang, &policy, {}, kFigure4);
  EXPECT_EQ(r.turns.size() + r.unusedUtterances.size(), kFigure4.size() + 1);
  // Replay: every robot action is the robot's decision (decideAction) at the belief before it.
  DialogSession replay(d, &lang, &policy);
  for (std::size_t k = 1; k < r.turns.size(); ++k) {
    if (k > 1) {
      const std::size_t a = replay.nextAction();
      EXPECT_EQ(r.turns[k].robotAction, d.model().actionNames()[a]) << "turn " << k;
      EXPECT_EQ(r.turns[k - 1].nextAction, r.turns[k].robotAction) << "turn " << k;
      replay.act(a);
    }
    replay.hear(r.turns[k].user);
    EXPECT_TRUE(replay.summary().rooms.isApprox(r.turns[k].belief.rooms)) << "turn " << k;
    EXPECT_NEAR(replay.summary().entropy, r.turns[k].belief.entropy, 1e-12) << "turn " << k;
  }
  const std::size_t next = replay.nextAction();
  EXPECT_EQ(r.turns.back().nextAction, d.model().actionNames()[next]);
  EXPECT_EQ(r.served, d.isServe(next));
  if (r.served) {
    EXPECT_EQ(r.servedRequest, d.requestOfServe(next));
  }
}

TEST(DialogScript, ServingEarlyLeavesUnusedUtterances) {
  DialogPomdp d = officeDialog();
  LanguageFrontEnd lang(d, shippedConfig());
  const std::size_t serve = d.serveAction(d.requestIndex(2, 0, 0));
  // One serve vector usable at every turn; its value is so low that no question looks better
  // in decideAction's lookahead (a question leads to beliefs the policy values at -1000).
  pomdp::TurnLimitedPolicy servePolicy(d.model().getS(), d.spec().turnLimit);
  servePolicy.add(Eigen::VectorXd::Constant(static_cast<Eigen::Index>(d.model().getS()), -1000.0),
                  serve, d.spec().turnLimit);
  ScriptResult r = runDialogScript(d, lang, &servePolicy, {}, {"soda", "room1", "john"});
  ASSERT_EQ(r.turns.size(), 2u);
  EXPECT_TRUE(r.served);
  EXPECT_EQ(r.servedRequest, d.requestIndex(2, 0, 0));
  EXPECT_EQ(r.unusedUtterances, (std::vector<std::string>{"room1", "john"}));
  EXPECT_EQ(r.turns[1].nextAction, "serve_soda_room1_john");
}

TEST(DialogScript, TurnLimitServesTheMostLikelyRequestWithoutAPolicy) {
  DialogSpec spec = officeDialog().spec();
  spec.turnLimit = 1;
  DialogPomdp d(spec);
  LanguageFrontEnd lang(d, shippedConfig());
  // (Without a policy every utterance after the first needs a scripted question, even one
  // the turn limit would leave unused: checked before running.)
  ScriptResult r =
      runDialogScript(d, lang, nullptr, {"ask_room"}, {"a soda for john to room3", "room3"});
  ASSERT_EQ(r.turns.size(), 3u);
  EXPECT_EQ(r.turns[1].nextAction, "ask_room");
  // One question asked: the limit. The robot serves the most likely request.
  EXPECT_EQ(r.turns[2].nextAction, "serve_" + d.requestName(r.turns[2].belief.mostLikely));
  EXPECT_EQ(r.turns[2].nextAction, "serve_soda_room3_john");
  EXPECT_TRUE(r.served);
  EXPECT_EQ(r.servedRequest, r.turns[2].belief.mostLikely);
  EXPECT_TRUE(r.unusedUtterances.empty());
}

TEST(DialogScript, GarbageTurnKeepsTheBeliefAndIsRecorded) {
  DialogPomdp d = officeDialog();
  LanguageFrontEnd lang(d, shippedConfig());
  ScriptResult r = runDialogScript(d, lang, nullptr, {"none"}, {"xyzzy plugh", "coffee"});
  ASSERT_EQ(r.turns.size(), 3u);
  EXPECT_EQ(r.turns[1].heard.unknownWords, (std::vector<std::string>{"xyzzy", "plugh"}));
  EXPECT_TRUE(r.turns[1].belief.items.isApprox(r.turns[0].belief.items));
  EXPECT_NEAR(r.turns[2].belief.items(1), 0.8, 1e-12);
  EXPECT_EQ(r.turns[2].robotAction, "none");
}

TEST(DialogScript, RefusesBadScriptsBeforeRunning) {
  DialogPomdp d = officeDialog();
  LanguageFrontEnd lang(d, shippedConfig());
  EXPECT_THROW(runDialogScript(d, lang, nullptr, {}, {}), ConfigError);
  EXPECT_THROW(runDialogScript(d, lang, nullptr, {}, {"coke", "yes"}), ConfigError);
  try {
    runDialogScript(d, lang, nullptr, {"ask_colour"}, {"coke", "red"});
    ADD_FAILURE() << "accepted an unknown action";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("ask_colour"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("confirm_room_room2"), std::string::npos);
  }
  EXPECT_EQ(actionByName(d, "confirm_person_bob"), static_cast<long>(d.confirmPerson(1)));
  EXPECT_EQ(actionByName(d, "none"), -1);
}

TEST(DialogScript, CsvAndJsonHaveOneRowPerTurn) {
  DialogPomdp d = officeDialog();
  LanguageFrontEnd lang(d, shippedConfig());
  ScriptResult r = runDialogScript(d, lang, nullptr, kFigure4Questions, kFigure4);
  const std::string csv = scriptToCsv(d, r);
  std::istringstream in(csv);
  std::string header, line;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("turn,robot_action,robot_text,user,observations,unknown_words,notes,"
                         "item_coke,item_coffee,item_soda,person_john,person_bob,room_room1,", 0),
            0u)
      << header;
  int rows = 0;
  while (std::getline(in, line)) ++rows;
  EXPECT_EQ(rows, 5);
  // Fields with commas or quotes are quoted (RFC 4180).
  ScriptResult q = runDialogScript(d, lang, nullptr, {}, {"say \"hi\", coke"});
  EXPECT_NE(scriptToCsv(d, q).find(",\"say \"\"hi\"\", coke\","), std::string::npos)
      << scriptToCsv(d, q);
  const std::string json = scriptToJson(d, r);
  EXPECT_NE(json.find("\"turns\": ["), std::string::npos);
  EXPECT_NE(json.find("\"user\": \"I'd like to order a coke for Bob to office2.\""),
            std::string::npos);
  EXPECT_NE(json.find("\"served\": false"), std::string::npos);
  const std::string text = scriptToText(d, r);
  EXPECT_NE(text.find("turn 4"), std::string::npos);
}

}  // namespace
}  // namespace dialog
}  // namespace krr
