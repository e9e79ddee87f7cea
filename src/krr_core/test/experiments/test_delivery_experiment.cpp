// DeliveryExperiment: delivery trials end to end on a corridor domain with the tiny office
// (8 requests), run by the robot's DeliveryManager: the 20-turn limit, the redelivery rule,
// failed trips, what the reward sums, determinism per (seed, trial) whatever the threads, the
// policy cache, the conditions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/experiments/delivery_experiment.h"
#include "../dialog/delivery_test_support.h"

namespace {

using namespace krr;
using namespace krr::dialog;
using namespace krr::experiments;
using delivery_test::data;
using delivery_test::repo;

/// The paper's serve reward plus trip costs, no wrong-delivery penalty (tests that need it
/// set it: penalisedConfig()).
DialogConfig config() {
  DialogConfig c;
  c.shop = "shop";  // the test domains' place names
  c.wrong_delivery_penalty = 0.0;
  c.office_plog = data("tiny_office.plog");
  c.speech_plog = repo("config/dialog.plog");
  c.known_threshold = 3;
  c.max_episodes_per_task = 30;
  c.convergence_episodes = 5;
  c.solver_max_trials = 40;
  return c;
}

/// config() with config/dialog.yaml's wrong-delivery penalty: serving on the prior is no longer
/// optimal, so the solver has work to do and the robot asks before serving.
DialogConfig penalisedConfig() {
  DialogConfig c = config();
  c.wrong_delivery_penalty = 120.0;
  return c;
}

DeliveryExperimentOptions options(double br, std::uint64_t seed = 5) {
  DeliveryExperimentOptions o;
  o.blocking_rate = br;
  o.seed = seed;
  o.domain_name = "corridor";
  return o;
}

Eigen::VectorXd constant(const DialogPomdp& d, double v) {
  return Eigen::VectorXd::Constant(static_cast<Eigen::Index>(d.model().getS()), v);
}

/// A policy that asks question q until the turn limit, where (as it must) it serves.
pomdp::TurnLimitedPolicy askUntilTheLimit(const DialogPomdp& d, std::size_t q) {
  const int limit = d.spec().turnLimit;
  pomdp::TurnLimitedPolicy p(d.model().getS(), limit);
  p.add(constant(d, 0.0), q, limit - 1);
  p.add(constant(d, -1000.0), d.serveAction(0), limit);
  return p;
}

/// A policy that serves `request` at once. Its value is so low that no question looks better
/// in the robot's one-step lookahead (decideAction): the serve is taken as it is.
pomdp::TurnLimitedPolicy serveAtOnce(const DialogPomdp& d, std::size_t request) {
  pomdp::TurnLimitedPolicy p(d.model().getS(), d.spec().turnLimit);
  p.add(constant(d, -1000.0), d.serveAction(request), d.spec().turnLimit);
  return p;
}

std::vector<std::string> rows(const DeliveryExperiment& ex, std::size_t begin, std::size_t n,
                              std::size_t threads) {
  std::vector<std::string> out;
  for (const auto& r : ex.runTrials(begin, n, threads))
    out.push_back(deliveryCsvRow(ex.dialog(), ex.rewardError(), r, ex.preparation().policy.bounds));
  return out;
}

/// Legs driven, without the (empty) pickup leg at the shop: the trips of the delivery equation.
std::size_t trips(const DeliveryTrialResult& r) {
  return r.delivery.legs.empty() ? 0 : r.delivery.legs.size() - 1;
}

TEST(DeliveryExperiment, TurnLimitForcesTheMostLikelyDelivery) {
  const kb::NavDomain d = delivery_test::corridor(40, delivery_test::exactMoves());
  DeliveryExperiment ex(d, config(), options(0.0), false);  // the policy is set below
  ASSERT_EQ(ex.dialog().numRequests(), 8u);
  ASSERT_EQ(ex.dialog().spec().turnLimit, 20);
  ex.setPolicy(askUntilTheLimit(ex.dialog(), ex.dialog().askItem()));  // asks until forced
  for (std::size_t i = 0; i < 10; ++i) {
    const DeliveryTrialResult r = ex.runTrial(i);
    EXPECT_EQ(r.delivery.turns, 20);
    EXPECT_TRUE(r.delivery.forced);
    EXPECT_DOUBLE_EQ(r.delivery.qa_cost, 20 * 2.0);
    EXPECT_DOUBLE_EQ(r.reward.qa, 20 * 2.0);
    // The most likely request is served, not the policy's serve(0).
    EXPECT_DOUBLE_EQ(r.delivery.served_probability, r.delivery.max_probability);
    EXPECT_GE(r.delivery.served_probability, 0.5);  // the mode (only the item was asked)
    EXPECT_GT(r.delivery.entropy, 0.0);
    EXPECT_NE(r.delivery.outcome, DeliveryOutcome::kNone);
  }
  DialogConfig c = config();
  c.turn_limit = 3;
  DeliveryExperiment short3(d, c, options(0.0), false);
  short3.setPolicy(askUntilTheLimit(short3.dialog(), short3.dialog().confirmRoom(1)));
  const DeliveryTrialResult r = short3.runTrial(0);
  EXPECT_EQ(r.delivery.turns, 3);
  EXPECT_TRUE(r.delivery.forced);
  EXPECT_DOUBLE_EQ(r.delivery.qa_cost, 3 * 1.5);
  // Policies that do not fit the model: other state count, other turn limit.
  EXPECT_THROW(ex.setPolicy(pomdp::TurnLimitedPolicy(3, 20)), ConfigError);
  EXPECT_THROW(ex.setPolicy(askUntilTheLimit(short3.dialog(), short3.dialog().askItem())),
               ConfigError);
}

TEST(DeliveryExperiment, WithoutSolvingTrialsNeedAPolicy) {
  const kb::NavDomain d = delivery_test::corridor(40, delivery_test::exactMoves());
  DeliveryExperiment ex(d, config(), options(0.0), false);
  EXPECT_EQ(ex.policy().size(), 0u);
  EXPECT_FALSE(ex.preparation().policy.from_cache);
  EXPECT_EQ(ex.preparation().policy.bounds.trials, 0u);
  EXPECT_THROW(ex.runTrial(0), ConfigError);
  ex.setPolicy(serveAtOnce(ex.dialog(), 0));
  EXPECT_EQ(ex.policy().size(), 1u);
  EXPECT_NO_THROW(ex.runTrial(0));
  EXPECT_THROW(ex.runTrial(0, 8), ConfigError);  // fixed request out of range
}

TEST(DeliveryExperiment, RedeliveryRuleAndWhatTheRewardSums) {
  const kb::NavDomain d = delivery_test::corridor(40, delivery_test::exactMoves());
  DeliveryExperiment ex(d, config(), options(0.0), false);
  const DialogPomdp& dlg = ex.dialog();
  const std::size_t x = dlg.requestIndex(0, 0, 0);      // coke, room1, ann: one move away
  const std::size_t far = dlg.requestIndex(1, 1, 1);    // soda, room2, ben: six moves away
  ex.setPolicy(serveAtOnce(dlg, x));
  // Right at once: one trip shop -> room1.
  DeliveryTrialResult r = ex.runTrial(0, static_cast<long>(x));
  EXPECT_TRUE(r.correct);
  EXPECT_EQ(r.delivery.turns, 0);
  EXPECT_FALSE(r.delivery.forced);
  EXPECT_EQ(trips(r), 1u);
  EXPECT_EQ(r.delivery.navMoves(), 1u);
  EXPECT_FALSE(r.delivery.redelivered);
  EXPECT_EQ(r.delivery.attempts, 1);
  EXPECT_TRUE(r.fulfilled);
  EXPECT_EQ(r.delivery.outcome, DeliveryOutcome::kFulfilled);
  EXPECT_DOUBLE_EQ(r.reward.total(), 80.0 - 0.0 - 1.0);
  EXPECT_DOUBLE_EQ(r.reward.penalty, 0.0);
  // Wrong: shop -> room1, back to the shop, learn the request, shop -> room2 (br 0: no blocking).
  r = ex.runTrial(1, static_cast<long>(far));
  EXPECT_FALSE(r.correct);
  EXPECT_EQ(r.delivery.served, x);
  EXPECT_EQ(r.delivery.delivering, far);
  EXPECT_EQ(r.request, far);
  EXPECT_TRUE(r.delivery.redelivered);
  EXPECT_EQ(r.delivery.attempts, 2);
  ASSERT_EQ(trips(r), 3u);
  EXPECT_EQ(r.delivery.legs[0].leg.kind, Leg::Kind::kPickup);
  EXPECT_EQ(r.delivery.legs[1].leg.place, "room1");
  EXPECT_EQ(r.delivery.legs[2].leg.kind, Leg::Kind::kReturn);
  EXPECT_EQ(r.delivery.legs[2].leg.place, "shop");
  EXPECT_EQ(r.delivery.legs[3].leg.place, "room2");
  EXPECT_EQ(r.delivery.navMoves(), 1u + 1u + 6u);
  EXPECT_TRUE(r.fulfilled);
  EXPECT_FALSE(r.delivery.navFailed());
  EXPECT_DOUBLE_EQ(r.reward.delivery, 80.0);
  EXPECT_DOUBLE_EQ(r.reward.qa, 0.0);
  EXPECT_DOUBLE_EQ(r.reward.navigation, 8.0);
  EXPECT_DOUBLE_EQ(r.reward.penalty, 0.0);  // config() has no wrong-delivery penalty
  EXPECT_DOUBLE_EQ(r.reward.total(), 80.0 - 8.0);
  // Same room, wrong item: still three trips (the delivery equation's misidentification case).
  r = ex.runTrial(2, static_cast<long>(dlg.requestIndex(1, 0, 0)));
  EXPECT_EQ(trips(r), 3u);
  EXPECT_EQ(r.delivery.navMoves(), 3u);
  EXPECT_TRUE(r.fulfilled);

  // The wrong-delivery penalty is charged for a wrong serve, even when redelivered.
  DialogConfig penalised = config();
  penalised.wrong_delivery_penalty = 120.0;
  DeliveryExperiment pen(d, penalised, options(0.0), false);
  pen.setPolicy(serveAtOnce(pen.dialog(), x));
  r = pen.runTrial(1, static_cast<long>(far));
  EXPECT_TRUE(r.fulfilled);
  EXPECT_DOUBLE_EQ(r.reward.penalty, 120.0);
  EXPECT_DOUBLE_EQ(r.reward.total(), 80.0 - 8.0 - 120.0);
  EXPECT_DOUBLE_EQ(pen.runTrial(0, static_cast<long>(x)).reward.penalty, 0.0);

  // Without redeliveries a wrong delivery fails at the room.
  DialogConfig once = config();
  once.max_redeliveries = 0;
  DeliveryExperiment noRedelivery(d, once, options(0.0), false);
  noRedelivery.setPolicy(serveAtOnce(noRedelivery.dialog(), x));
  r = noRedelivery.runTrial(1, static_cast<long>(far));
  EXPECT_FALSE(r.fulfilled);
  EXPECT_FALSE(r.delivery.redelivered);
  EXPECT_EQ(r.delivery.outcome, DeliveryOutcome::kFailed);
  EXPECT_EQ(trips(r), 1u);
  EXPECT_FALSE(r.delivery.navFailed());
  EXPECT_DOUBLE_EQ(r.reward.total(), -80.0 - 1.0);

  // Without serve costs (mode none) the navigation term is not charged.
  DialogConfig paper = config();
  paper.serve_cost_mode = ServeCostMode::kNone;
  DeliveryExperiment none(d, paper, options(0.0), false);
  none.setPolicy(serveAtOnce(none.dialog(), x));
  r = none.runTrial(1, static_cast<long>(far));
  EXPECT_DOUBLE_EQ(r.reward.navigation, 0.0);
  EXPECT_DOUBLE_EQ(r.reward.total(), 80.0);
}

TEST(DeliveryExperiment, FailedTripsEndTheDeliveryUnfulfilled) {
  // br = 1: every move into the blocking area is blocked; a blocked robot is eventually
  // trapped (or runs out of moves), so room2 is never reached.
  const kb::NavDomain d = delivery_test::corridor(40, delivery_test::exactMoves());
  DeliveryExperiment ex(d, config(), options(1.0), false);
  const DialogPomdp& dlg = ex.dialog();
  ex.setPolicy(serveAtOnce(dlg, dlg.requestIndex(0, 1, 1)));  // serve room2
  for (std::size_t i = 0; i < 5; ++i) {
    const DeliveryTrialResult r = ex.runTrial(i, static_cast<long>(dlg.requestIndex(1, 0, 0)));
    EXPECT_EQ(trips(r), 1u);  // wrong, but the robot never arrives to find out
    EXPECT_TRUE(r.delivery.navFailed());
    EXPECT_FALSE(r.delivery.legs.back().reached);
    EXPECT_FALSE(r.delivery.legs.back().why.empty());
    EXPECT_FALSE(r.delivery.redelivered);
    EXPECT_FALSE(r.fulfilled);
    EXPECT_EQ(r.delivery.outcome, DeliveryOutcome::kFailed);
    EXPECT_DOUBLE_EQ(r.reward.navigation, static_cast<double>(r.delivery.navMoves()) + 40.0);
    EXPECT_DOUBLE_EQ(r.reward.total(),
                     -80.0 - (static_cast<double>(r.delivery.navMoves()) + 40.0));
  }
}

TEST(DeliveryExperiment, TrialsDependOnlyOnSeedAndIndex) {
  const kb::NavDomain d = delivery_test::corridor();
  const std::string cache = delivery_test::tempDir("delivery_exp_cache");
  auto o = options(0.5, 9);
  o.cache_dir = cache;
  DeliveryExperiment ex(d, penalisedConfig(), o);
  const PolicyReport& solved = ex.preparation().policy;
  EXPECT_FALSE(solved.from_cache);
  EXPECT_TRUE(solved.reproducible);  // stopped by the precision or the trial budget
  EXPECT_EQ(solved.converged, solved.bounds.gap() <= penalisedConfig().solver_precision);
  EXPECT_LE(solved.bounds.lower, solved.bounds.upper + 1e-9);
  EXPECT_GT(solved.bounds.trials, 0u);
  EXPECT_EQ(solved.file.find(cache + "/"), 0u) << solved.file;
  EXPECT_GT(ex.policy().size(), 0u);
  EXPECT_EQ(ex.policy().turnLimit(), 20);
  const auto one = rows(ex, 0, 30, 1);
  EXPECT_EQ(rows(ex, 0, 30, 4), one);
  const auto part = rows(ex, 10, 5, 2);
  EXPECT_EQ(part, std::vector<std::string>(one.begin() + 10, one.begin() + 15));
  // A new process (here: a new experiment) reuses the cached knowledge and policy.
  DeliveryExperiment again(d, penalisedConfig(), o);
  EXPECT_TRUE(again.preparation().learning.from_cache);
  EXPECT_TRUE(again.preparation().policy.from_cache);
  EXPECT_TRUE(again.preparation().policy.reproducible);
  EXPECT_EQ(again.preparation().policy.file, solved.file);
  EXPECT_EQ(again.policy().toText(), ex.policy().toText());
  // The bounds are cached with the policy (exactly: the rows print them).
  EXPECT_DOUBLE_EQ(again.preparation().policy.bounds.lower, solved.bounds.lower);
  EXPECT_DOUBLE_EQ(again.preparation().policy.bounds.upper, solved.bounds.upper);
  EXPECT_EQ(again.preparation().policy.converged, solved.converged);
  EXPECT_EQ(rows(again, 0, 30, 3), one);
  // Without a cache it learns and solves again, reproducibly.
  auto noCache = o;
  noCache.cache_dir.clear();
  DeliveryExperiment fresh(d, penalisedConfig(), noCache);
  EXPECT_FALSE(fresh.preparation().policy.from_cache);
  EXPECT_TRUE(fresh.preparation().policy.file.empty());
  EXPECT_EQ(rows(fresh, 0, 30, 1), one);
  // Another seed gives other trials.
  auto other = o;
  other.seed = 10;
  DeliveryExperiment ex10(d, penalisedConfig(), other);
  EXPECT_NE(rows(ex10, 0, 30, 1), one);
  // The CSV row has the header's columns, trial index first.
  const std::string header = deliveryCsvHeader();
  EXPECT_EQ(std::count(header.begin(), header.end(), ','), std::count(one[0].begin(), one[0].end(), ','));
  EXPECT_EQ(header.substr(0, 6), "trial,");
  EXPECT_EQ(one[7].substr(0, 2), "7,");
  EXPECT_NE(header.find(",penalty,policy_lower,policy_upper"), std::string::npos) << header;
  // Every trial's record is consistent with its reward and outcome; the robot asks first.
  std::size_t asked = 0;
  for (const DeliveryTrialResult& r : ex.runTrials(0, 30, 2)) {
    if (r.delivery.turns > 0) ++asked;
    EXPECT_EQ(r.correct, r.delivery.served == r.request);
    EXPECT_EQ(r.fulfilled, r.delivery.outcome == DeliveryOutcome::kFulfilled);
    const DeliveryReward w = deliveryReward(r.delivery, r.request, ex.config());
    EXPECT_DOUBLE_EQ(r.reward.total(), w.total());
    EXPECT_DOUBLE_EQ(r.reward.qa, r.delivery.qa_cost);
    EXPECT_LE(r.delivery.turns, 20);
    EXPECT_EQ(r.delivery.forced, r.delivery.turns == 20);
    EXPECT_LE(r.delivery.served_probability, r.delivery.max_probability + 1e-12);
  }
  EXPECT_GT(asked, 15u);
}

TEST(DeliveryExperiment, ConditionsUseKnowledgeLearnedAtTheirBlockingRate) {
  const kb::NavDomain d = delivery_test::corridor();
  auto o = options(0.9);
  o.condition = KnowledgeCondition::kOutdated;
  DeliveryExperiment outdated(d, config(), o, false);  // only the models are compared
  EXPECT_DOUBLE_EQ(outdated.preparation().knowledge_br, 0.3);
  o.condition = KnowledgeCondition::kLearned;
  DeliveryExperiment learned(d, config(), o, false);
  EXPECT_DOUBLE_EQ(learned.preparation().knowledge_br, 0.9);
  // Knowledge learned in the harder world expects room2 (across the blocking area) to be
  // harder to reach, and the dialog's T^D follows.
  EXPECT_LT(learned.navigation().toRoom(1).reach, outdated.navigation().toRoom(1).reach);
  const std::size_t s = learned.dialog().requestIndex(0, 1, 0);
  EXPECT_LT(learned.dialog().spec().delivery(s, s), outdated.dialog().spec().delivery(s, s));
  EXPECT_LT(learned.navigation().trips().reachFromShop()(1),
            outdated.navigation().trips().reachFromShop()(1));
  // The serve rewards of the outdated knowledge are further from the true world's (the
  // decision-theory sanity line of Table I uses this error).
  EXPECT_GE(learned.rewardError(), 0.0);
  EXPECT_GT(outdated.rewardError(), learned.rewardError());
  EXPECT_EQ(conditionFromString("outdated"), KnowledgeCondition::kOutdated);
  EXPECT_THROW(conditionFromString("fresh"), ConfigError);
  o.blocking_rate = -0.1;
  EXPECT_THROW(DeliveryExperiment(d, config(), o), ConfigError);
}

}  // namespace

// The expected reward of a trial under the true world (the robot's policies driven in the
// simulator's exact dynamics) is what the realised rewards average to: one definition of the
// reward (dialog_knowledge.h), realised by the trials, expected by the model report.
TEST(DeliveryExperiment, ExpectedRewardIsTheMeanOfTheRealisedReward) {
  const kb::NavDomain d = delivery_test::corridor(40);
  DeliveryExperiment ex(d, penalisedConfig(), options(0.5, 11));
  const TripTable& truth = ex.trueTrips();
  ASSERT_EQ(truth.rooms, (std::vector<std::string>{"room1", "room2"}));
  EXPECT_NEAR(truth.to_room[0].reach, ex.navigation().toRoom(0).reach, 0.05);  // never blocked
  EXPECT_LT(truth.to_room[1].reach, 0.95);                                    // across ba1
  const auto rs = ex.runTrials(0, 6000, 2);
  double realised = 0, expected = 0, sq = 0;
  for (const auto& r : rs) {
    realised += r.reward.total();
    expected += r.expected_reward;
    sq += (r.reward.total() - r.expected_reward) * (r.reward.total() - r.expected_reward);
  }
  const double n = static_cast<double>(rs.size());
  const double se = std::sqrt(sq / n / n);
  EXPECT_NEAR(realised / n, expected / n, 4 * se + 1e-9)
      << "realised " << realised / n << " vs expected " << expected / n;
  // At br 0 with exact moves the true world never fails: P^N = 1 both ways.
  const kb::NavDomain easy = delivery_test::corridor(40, delivery_test::exactMoves());
  DeliveryExperiment calm(easy, penalisedConfig(), options(0.0, 11));
  for (std::size_t r = 0; r < 2; ++r) {
    EXPECT_DOUBLE_EQ(calm.trueTrips().to_room[r].reach, 1.0);
    EXPECT_DOUBLE_EQ(calm.trueTrips().to_shop[r].reach, 1.0);
  }
}
