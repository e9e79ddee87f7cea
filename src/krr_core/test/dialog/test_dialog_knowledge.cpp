// DialogKnowledge: the dialog POMDP constructed by reasoning. Prior and speech model from P-log,
// T^D by the delivery equation and serve costs against hand computation, and on the real
// office model: the policy asks more questions when the requested room is harder to reach.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/delivery_experiment.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "delivery_test_support.h"

namespace {

using namespace krr;
using namespace krr::dialog;
using delivery_test::data;
using delivery_test::repo;

DeliveryNavigation chainNavigation(const kb::NavStateSpace& sp) {
  DeliveryNavigationOptions o;
  o.rooms = {"room1", "room2"};
  o.step_limit = 10;
  o.failure_penalty = 40.0;
  return DeliveryNavigation(sp, delivery_test::chainModel(sp, 0.9), o);
}

TEST(DialogKnowledge, PriorOfTheOfficeKnowledgeBaseEqualsHandComputation) {
  const DialogKnowledge k(repo("config/office.plog"), repo("config/dialog.plog"));
  const pomdp::DialogSpec& b = k.base();
  ASSERT_EQ(k.numRequests(), 30u);
  ASSERT_EQ(b.rooms.size(), 5u);
  ASSERT_EQ(b.persons, (std::vector<std::string>{"john", "bob"}));
  // Uniform person and item; a person's own office with 0.8, the other 4 rooms 0.05 each.
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t r = 0; r < 5; ++r)
      for (std::size_t p = 0; p < 2; ++p) {
        const bool own = (p == 0 && b.rooms[r] == "room5") || (p == 1 && b.rooms[r] == "room2");
        const double want = 0.5 * (1.0 / 3.0) * (own ? 0.8 : 0.05);
        EXPECT_NEAR(k.prior()((i * 5 + r) * 2 + p), want, 1e-9) << i << r << p;
        EXPECT_EQ(k.roomOf((i * 5 + r) * 2 + p), r);
      }
  EXPECT_NEAR(k.prior().sum(), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(k.speech().p_general, 0.8);
  EXPECT_DOUBLE_EQ(k.speech().p_yesno, 0.8);
}

TEST(DialogKnowledge, SpeechModelComesFromPlog) {
  const DialogKnowledge k(data("tiny_office.plog"), data("speech_90_70.plog"));
  EXPECT_NEAR(k.speech().p_general, 0.9, 1e-12);
  EXPECT_NEAR(k.speech().p_yesno, 0.7, 1e-12);
  // Tiny prior: P(ann) = 3/4, own office 9/10, items uniform.
  EXPECT_NEAR(k.prior()(0), 0.75 * 0.5 * 0.9, 1e-12);   // coke, room1, ann
  EXPECT_NEAR(k.prior()(1), 0.25 * 0.5 * 0.1, 1e-12);   // coke, room1, ben
  // The POMDP built from it hears what the knowledge says.
  const nav::NavGrid grid = delivery_test::chain();
  const kb::NavStateSpace sp(grid);
  const DeliveryNavigation nav = chainNavigation(sp);
  DialogConfig cfg;
  const pomdp::DialogPomdp d(k.buildSpec(nav, cfg));
  const std::size_t s = d.requestIndex(1, 0, 1);  // soda, room1, ben
  EXPECT_NEAR(d.model().getObservationProbability(s, d.askItem(), d.obsItem(1)), 0.9, 1e-12);
  EXPECT_NEAR(d.model().getObservationProbability(s, d.askItem(), d.obsItem(0)), 0.1, 1e-12);
  EXPECT_NEAR(d.model().getObservationProbability(s, d.confirmRoom(0), d.obsYes()), 0.7, 1e-12);
  EXPECT_NEAR(d.model().getObservationProbability(s, d.confirmPerson(0), d.obsNo()), 0.7, 1e-12);
}

TEST(DialogKnowledge, SpeechModelsThePomdpCannotRepresentAreRefused) {
  try {
    DialogKnowledge k(data("tiny_office.plog"), data("speech_asymmetric.plog"));
    ADD_FAILURE() << "asymmetric yes/no accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("yes_item"), std::string::npos) << e.what();
  }
  // A speech model without the attributes the dialog needs.
  EXPECT_THROW(DialogKnowledge(data("tiny_office.plog"), data("tiny_office.plog")), Error);
}

TEST(DialogKnowledge, DeliveryEquationAndServeCostsMatchHandComputation) {
  const DialogKnowledge k(data("tiny_office.plog"), repo("config/dialog.plog"));
  const nav::NavGrid grid = delivery_test::chain();
  const kb::NavStateSpace sp(grid);
  const DeliveryNavigation nav = chainNavigation(sp);
  // P^N(shop, room1) = P^N(room1, shop) = 0.9; P^N(shop, room2) = P^N(room2, shop) = 0.729.
  // C(shop, room1) = 1 + 40 * 0.1 = 5; C(shop, room2) = 2.71 + 40 * 0.271 = 13.55.
  DialogConfig cfg;
  cfg.serve_cost_mode = ServeCostMode::kNone;
  const pomdp::DialogPomdp paper(k.buildSpec(nav, cfg));
  const std::size_t s = paper.requestIndex(0, 1, 0);  // coke, room2, ann
  const std::size_t a = paper.requestIndex(1, 0, 0);  // soda, room1, ann
  const std::size_t a2 = paper.requestIndex(1, 1, 0);  // soda, room2, ann
  const Eigen::MatrixXd& td = paper.spec().delivery;
  EXPECT_NEAR(td(s, s), 0.729, 1e-12);                // right: P^N(shop, goal)
  EXPECT_NEAR(td(s, a), 0.9 * 0.9 * 0.729, 1e-12);    // wrong: P^N(shop,mis) P^N(mis,shop) P^N(shop,goal)
  EXPECT_NEAR(td(s, a2), 0.729 * 0.729 * 0.729, 1e-12);
  EXPECT_NEAR(td(a, s), 0.729 * 0.729 * 0.9, 1e-12);
  const double rPaper = 80 * 0.59049 - 80 * (1 - 0.59049);
  EXPECT_NEAR(paper.model().getExpectedReward(s, paper.serveAction(a)), rPaper, 1e-9);

  const Eigen::MatrixXd tasks = k.serveCosts(nav, ServeCostMode::kTasks);
  EXPECT_NEAR(tasks(s, s), 13.55, 1e-9);             // one task: shop -> room2
  EXPECT_NEAR(tasks(s, a), 5 + 5 + 13.55, 1e-9);     // three tasks: shop->room1->shop->room2
  const Eigen::MatrixXd expected = k.serveCosts(nav, ServeCostMode::kExpected);
  EXPECT_NEAR(expected(s, s), 13.55, 1e-9);
  EXPECT_NEAR(expected(s, a), 5 + 0.9 * (5 + 0.9 * 13.55), 1e-9);  // later trips if arrived
  EXPECT_EQ(k.serveCosts(nav, ServeCostMode::kNone).norm(), 0.0);

  cfg.serve_cost_mode = ServeCostMode::kTasks;
  cfg.serve_cost_weight = 0.5;
  const pomdp::DialogPomdp ext(k.buildSpec(nav, cfg));
  EXPECT_NEAR(ext.model().getExpectedReward(s, ext.serveAction(a)), rPaper - 0.5 * 23.55, 1e-9);
  // Costs, rewards and the turn limit come from the config.
  cfg.general_cost = 3.0;
  cfg.turn_limit = 7;
  const pomdp::DialogPomdp c2(k.buildSpec(nav, cfg));
  EXPECT_DOUBLE_EQ(c2.model().getExpectedReward(s, c2.askRoom()), -3.0);
  EXPECT_EQ(c2.spec().turnLimit, 7);

  // Navigation over other rooms than the knowledge base's is refused.
  DeliveryNavigationOptions o;
  o.rooms = {"room2", "room1"};
  const DeliveryNavigation swapped(sp, delivery_test::chainModel(sp, 0.9), o);
  EXPECT_THROW(k.buildSpec(swapped, cfg), ConfigError);
}

// The office knowledge base and the 30 x 30 office navigation model (human knowledge, i.e. the
// knowledge base before any learning: P^N(shop, room1) = 1, P^N(shop, room5) ~ 0.24). Bob's
// requests to room1 and to room5 have the same prior mass (0.05 / 6 each).
TEST(DialogKnowledge, AsksMoreQuestionsWhenTheRequestedRoomIsHarderToReach) {
  const kb::NavDomain dom = kb::NavDomain::load(
      repo("config/navigation.yaml"), "office_30x30", repo("maps/office_30x30_geometry.plog"),
      repo("config/navigation.plog"));
  kb::NavigationKnowledge nk(*dom.grid, dom.knowledge_files);
  DialogConfig cfg = loadDialogConfig(repo("config/dialog.yaml"));
  const DialogKnowledge k(cfg.office_plog, cfg.speech_plog);
  DeliveryNavigationOptions o;
  o.rooms = k.base().rooms;
  o.step_limit = static_cast<std::size_t>(dom.domain.step_limit);
  const DeliveryNavigation nav(*dom.space, nk.buildModel({"morning"}, 1.0).dynamics, o);
  ASSERT_NEAR(nav.toRoom(0).reach, 1.0, 1e-4);
  ASSERT_LT(nav.toRoom(4).reach, 0.5);

  cfg.solver_max_trials = 300;  // a small budget: the ordering does not need a converged policy
  auto questions = [&](const pomdp::DialogPomdp& d, const pomdp::AlphaVectorPolicy& pol,
                       std::size_t room) {
    double q = 0;
    for (std::size_t item = 0; item < 3; ++item)
      q += pomdp::simulateDialogs(d, pol, 60, 11, static_cast<long>(d.requestIndex(item, room, 1)))
               .meanQuestions / 3.0;
    return q;
  };
  cfg.serve_cost_mode = ServeCostMode::kTasks;
  const pomdp::DialogPomdp d(k.buildSpec(nav, cfg));
  ASSERT_NEAR(d.spec().prior(d.requestIndex(0, 0, 1)), d.spec().prior(d.requestIndex(0, 4, 1)), 1e-12);
  const pomdp::AlphaVectorPolicy pol = solveDialogPolicy(d, cfg, "");
  const double easy = questions(d, pol, 0), hard = questions(d, pol, 4);
  std::printf("questions for bob's requests: room1 %.2f, room5 %.2f\n", easy, hard);
  EXPECT_GT(hard, easy + 2.0) << "room1 " << easy << " questions, room5 " << hard;

  // The paper's formula alone (no navigation cost in the serve reward) asks nothing on this
  // map: a wrong delivery to room1 or room4 (P^N = 1) loses nothing under the delivery
  // equation (T^D(s, a) = P^N(shop, room(s)) either way), so serving one at once is optimal.
  cfg.serve_cost_mode = ServeCostMode::kNone;
  const pomdp::DialogPomdp paper(k.buildSpec(nav, cfg));
  const pomdp::AlphaVectorPolicy paperPol = solveDialogPolicy(paper, cfg, "");
  EXPECT_LT(questions(paper, paperPol, 0), 0.5);
  EXPECT_LT(questions(paper, paperPol, 4), 0.5);
}

}  // namespace
