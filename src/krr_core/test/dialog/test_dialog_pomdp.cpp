// Tests of the dialog POMDP factory (DialogPomdp, deliveryMatrix, ownOfficePrior).
#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/dialog/certified_dialog_solver.h"
#include "../support/office_dialog.h"

namespace krr {
namespace dialog {
namespace {

DialogSpec paperSpec() {
  DialogSpec spec = test::officeSpec();
  spec.prior = ownOfficePrior(3, 5, {0, 1}, 0.8);  // alice: room1, bob: room2
  Eigen::VectorXd reach(5);
  reach << 0.95, 0.65, 0.75, 0.95, 0.5;
  spec.delivery = deliveryMatrix(3, reach, 2);
  return spec;
}

TEST(DialogPomdp, SizesNamesAndStochasticRows) {
  DialogPomdp d(paperSpec());
  const pomdp::Model& m = d.model();
  EXPECT_EQ(d.numRequests(), 30u);
  EXPECT_EQ(m.getS(), 31u);               // 30 requests + terminal
  EXPECT_EQ(m.getA(), 3u + 10u + 30u);    // general, confirming, serve
  EXPECT_EQ(m.getO(), 3u + 5u + 2u + 3u);  // answers, yes, no, none
  EXPECT_EQ(m.actionNames()[d.serveAction(d.requestIndex(0, 1, 1))], "serve_coke_room2_bob");
  EXPECT_EQ(m.actionNames()[d.confirmRoom(4)], "confirm_room_room5");
  for (std::size_t a = 0; a < m.getA(); ++a)
    for (std::size_t s = 0; s < m.getS(); ++s) {
      EXPECT_NEAR(m.transitionMatrix(a).row(s).sum(), 1.0, 1e-12);
      EXPECT_NEAR(m.observationMatrix(a).row(s).sum(), 1.0, 1e-12);
    }
  EXPECT_NEAR(m.initialBelief().sum(), 1.0, 1e-12);
  EXPECT_EQ(m.initialBelief()(d.terminalState()), 0.0);
}

TEST(DialogPomdp, QuestionsKeepTheRequestAndServingEndsTheEpisode) {
  DialogPomdp d(paperSpec());
  const pomdp::Model& m = d.model();
  for (std::size_t a = 0; a < m.getA(); ++a) {
    EXPECT_EQ(m.isIdentityTransition(a), d.isQuestion(a)) << a;
    if (d.isServe(a)) {
      for (std::size_t s = 0; s < m.getS(); ++s)
        EXPECT_EQ(m.getTransitionProbability(s, a, d.terminalState()), 1.0);
    }
  }
  EXPECT_TRUE(m.isTerminal(d.terminalState()));
  for (std::size_t s = 0; s < d.numRequests(); ++s) EXPECT_FALSE(m.isTerminal(s));
  // the only observation after serving (or in the terminal state) is "none"
  EXPECT_EQ(m.getObservationProbability(d.terminalState(), d.askItem(), d.obsNone()), 1.0);
}

TEST(DialogPomdp, RewardsFollowThePaper) {
  DialogPomdp d(paperSpec());
  const pomdp::Model& m = d.model();
  const std::size_t s = d.requestIndex(0, 0, 0);  // <coke, room1, alice>
  EXPECT_EQ(m.getExpectedReward(s, d.askRoom()), -2.0);
  EXPECT_EQ(m.getExpectedReward(s, d.confirmItem(1)), -1.5);
  EXPECT_EQ(m.getExpectedReward(d.terminalState(), d.askRoom()), 0.0);
  // correct serve: T^D = P(shop, room1) = 0.95 -> 80 * 0.95 - 80 * 0.05 = 72
  EXPECT_NEAR(m.getExpectedReward(s, d.serveAction(s)), 72.0, 1e-12);
  // wrong serve <coke, room5, alice>: T^D = P(shop,room5) P(room5,shop) P(shop,room1)
  //   = 0.5 * 0.5 * 0.95 = 0.2375 -> 160 * 0.2375 - 80 = -42
  EXPECT_NEAR(m.getExpectedReward(s, d.serveAction(d.requestIndex(0, 4, 0))), -42.0, 1e-12);
}

TEST(DialogPomdp, DeliveryMatrixAndPriorByHand) {
  Eigen::VectorXd reach(2), back(2);
  reach << 0.9, 0.6;
  back << 0.8, 0.5;
  Eigen::MatrixXd td = deliveryMatrix(1, reach, 1, back);  // requests: room0, room1
  EXPECT_DOUBLE_EQ(td(0, 0), 0.9);
  EXPECT_DOUBLE_EQ(td(1, 1), 0.6);
  EXPECT_DOUBLE_EQ(td(0, 1), 0.6 * 0.5 * 0.9);  // went to room1, back, then room0
  EXPECT_DOUBLE_EQ(td(1, 0), 0.9 * 0.8 * 0.6);
  EXPECT_THROW(deliveryMatrix(1, reach, 1, Eigen::VectorXd::Ones(3)), ConfigError);
  reach(1) = 1.2;
  EXPECT_THROW(deliveryMatrix(1, reach, 1), ConfigError);

  Eigen::VectorXd prior = ownOfficePrior(3, 5, {0, 1}, 0.8);
  DialogPomdp d(paperSpec());
  // P(<coke, room1, alice>) = 1/3 (item) * 1/2 (person) * 0.8 (own office)
  EXPECT_NEAR(prior(d.requestIndex(0, 0, 0)), 0.8 / 6, 1e-15);
  // P(<soda, room3, bob>) = 1/3 * 1/2 * 0.2 / 4
  EXPECT_NEAR(prior(d.requestIndex(2, 2, 1)), 0.05 / 6, 1e-15);
  auto mg = d.marginals(d.model().initialBelief());
  EXPECT_NEAR(mg[0](1), 1.0 / 3, 1e-12);
  EXPECT_NEAR(mg[1](0), 0.5 * 0.8 + 0.5 * 0.05, 1e-12);  // room1 = 0.425
  EXPECT_NEAR(mg[1](4), 0.05, 1e-12);
  EXPECT_NEAR(mg[2](1), 0.5, 1e-12);
}

TEST(DialogPomdp, AnswerModel) {
  DialogPomdp d(paperSpec());
  const pomdp::Model& m = d.model();
  const std::size_t s = d.requestIndex(1, 1, 1);  // <coffee, room2, bob>
  EXPECT_DOUBLE_EQ(m.getObservationProbability(s, d.askRoom(), d.obsRoom(1)), 0.8);
  EXPECT_DOUBLE_EQ(m.getObservationProbability(s, d.askRoom(), d.obsRoom(3)), 0.2 / 4);
  EXPECT_DOUBLE_EQ(m.getObservationProbability(s, d.askItem(), d.obsItem(0)), 0.2 / 2);
  EXPECT_DOUBLE_EQ(m.getObservationProbability(s, d.askPerson(), d.obsPerson(1)), 0.8);
  EXPECT_DOUBLE_EQ(m.getObservationProbability(s, d.confirmItem(1), d.obsYes()), 0.8);
  EXPECT_DOUBLE_EQ(m.getObservationProbability(s, d.confirmItem(2), d.obsNo()), 0.8);
  EXPECT_DOUBLE_EQ(m.getObservationProbability(s, d.confirmPerson(0), d.obsYes()), 0.2);
  EXPECT_EQ(d.actionKind(d.confirmRoom(2)), DialogActionKind::kConfirmRoom);
  EXPECT_EQ(d.actionKind(d.serveAction(3)), DialogActionKind::kServe);
  EXPECT_EQ(d.requestName(s), "coffee_room2_bob");
  EXPECT_EQ(d.requestParts(s), (std::array<std::size_t, 3>{1, 1, 1}));
}

TEST(DialogPomdp, RejectsBadSpecs) {
  DialogSpec spec = paperSpec();
  spec.prior = Eigen::VectorXd::Constant(29, 1.0 / 29);
  EXPECT_THROW(DialogPomdp{spec}, ConfigError);
  spec = paperSpec();
  spec.pYesNo = 1.1;
  EXPECT_THROW(DialogPomdp{spec}, ConfigError);
  spec = paperSpec();
  spec.rooms[1] = "room1";
  EXPECT_THROW(DialogPomdp{spec}, ConfigError);
  spec = paperSpec();
  spec.delivery = Eigen::MatrixXd::Ones(30, 29);
  EXPECT_THROW(DialogPomdp{spec}, ConfigError);
}

/// Mean number of questions over seeded simulated dialogs with a fixed request: the user's
/// answers are drawn from the observation model, the robot acts by the turn-limited policy
/// (which serves by itself at the turn limit). Episode e uses stream makeRng(seed, "dialog", e).
double meanQuestions(const DialogPomdp& d, const pomdp::TurnLimitedPolicy& policy,
                     std::size_t request, std::size_t episodes, std::uint64_t seed) {
  const pomdp::Model& m = d.model();
  std::size_t questions = 0;
  for (std::size_t e = 0; e < episodes; ++e) {
    Rng rng = makeRng(seed, "dialog", e);
    pomdp::Belief b = m.initialBelief();
    for (int turns = 0;; ++turns) {
      const std::size_t a = policy.bestAction(b, turns);
      if (d.isServe(a)) break;
      EXPECT_LT(turns, d.spec().turnLimit) << "the policy asks at the turn limit";
      if (turns >= d.spec().turnLimit) break;
      ++questions;
      double u = uniform01(rng);
      const auto& row = m.observationRow(request, a);
      std::size_t o = row.back().first;
      for (const auto& entry : row) {
        if (u < entry.second) {
          o = entry.first;
          break;
        }
        u -= entry.second;
      }
      b = pomdp::updateBelief(m, b, a, o);
    }
  }
  return static_cast<double>(questions) / static_cast<double>(episodes);
}

// Harder navigation to the requested room -> more questions before serving.
// One item, one person, rooms A and B; prior P(A) = 0.7, P^N(shop, B) = 0.6. Serving A
// when the request is B succeeds with P(A)^2 P(B) (go to A, come back, go to B), so the
// lower P(A), the costlier it is to head for A by mistake and the more the robot confirms.
// The turn-limited solver certifies both policies (gap <= 0.02), so the comparison is between
// optimal policies; question counts are averaged over 2000 seeded dialogs with request A.
TEST(DialogPomdp, HarderRoomMeansMoreQuestions) {
  auto questions = [](double reachA) {
    DialogSpec spec;
    spec.items = {"coke"};
    spec.rooms = {"roomA", "roomB"};
    spec.persons = {"alice"};
    spec.discount = 0.95;
    spec.prior = Eigen::Vector2d(0.7, 0.3);
    spec.delivery = deliveryMatrix(1, Eigen::Vector2d(reachA, 0.6), 1);
    DialogPomdp d(spec);
    CertifiedSolverOptions opt;
    opt.precision = 0.02;
    CertifiedDialogSolver solver(d, Eigen::VectorXd(), 0, opt);
    EXPECT_TRUE(solver.solve());
    return meanQuestions(d, solver.policy(), 0, 2000, 7);
  };
  const double easy = questions(0.95), hard = questions(0.6);
  EXPECT_LT(easy, 0.5);        // easy room: serve A on the prior
  EXPECT_GT(hard, easy + 1.0);  // hard room: confirm first
}

// The serve cost (the knowledge base's navigation costs) is subtracted from the serve reward
// only; questions and the terminal state are unaffected.
TEST(DialogPomdp, ServeCostIsSubtractedFromServeRewards) {
  DialogSpec spec = paperSpec();
  spec.serveCost = Eigen::MatrixXd::Constant(30, 30, 5.0);
  spec.serveCost(0, 0) = 1.0;
  DialogPomdp d(spec);
  const pomdp::Model& m = d.model();
  const std::size_t s = d.requestIndex(0, 0, 0);
  EXPECT_NEAR(m.getExpectedReward(s, d.serveAction(s)), 72.0 - 1.0, 1e-12);
  EXPECT_NEAR(m.getExpectedReward(s, d.serveAction(d.requestIndex(0, 4, 0))), -42.0 - 5.0, 1e-12);
  EXPECT_EQ(m.getExpectedReward(s, d.askRoom()), -2.0);
  spec.serveCost(1, 2) = std::nan("");
  EXPECT_THROW(DialogPomdp{spec}, ConfigError);
  spec.serveCost = Eigen::MatrixXd::Zero(30, 29);
  EXPECT_THROW(DialogPomdp{spec}, ConfigError);
}

}  // namespace
}  // namespace dialog
}  // namespace krr
