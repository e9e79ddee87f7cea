// DeliveryExperiment: delivery trials end to end on a corridor domain with the tiny office
// (8 requests): the 20-turn limit, the redelivery rule, failed trips, what the reward sums,
// determinism per (seed, trial) whatever the threads, the policy cache, the conditions.
#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/delivery_experiment.h"
#include "delivery_test_support.h"

namespace {

using namespace krr;
using namespace krr::dialog;
using delivery_test::data;
using delivery_test::repo;

DialogConfig config() {
  DialogConfig c;
  c.office_plog = data("tiny_office.plog");
  c.speech_plog = repo("config/dialog.plog");
  c.known_threshold = 3;
  c.max_episodes_per_task = 30;
  c.convergence_episodes = 5;
  c.solver_max_trials = 40;
  return c;
}

DeliveryExperimentOptions options(double br, std::uint64_t seed = 5) {
  DeliveryExperimentOptions o;
  o.blocking_rate = br;
  o.seed = seed;
  o.domain_name = "corridor";
  return o;
}

/// A policy that always takes action a.
pomdp::AlphaVectorPolicy always(const pomdp::DialogPomdp& d, std::size_t a) {
  pomdp::AlphaVectorPolicy p(d.model().getS());
  p.add(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(d.model().getS())), a);
  return p;
}

std::vector<std::string> rows(const DeliveryExperiment& ex, std::size_t begin, std::size_t n,
                              std::size_t threads) {
  std::vector<std::string> out;
  for (const auto& r : ex.runTrials(begin, n, threads)) out.push_back(deliveryCsvRow(ex.dialog(), r));
  return out;
}

TEST(DeliveryExperiment, TurnLimitForcesTheMostLikelyDelivery) {
  const kb::NavDomain d = delivery_test::corridor(40, delivery_test::exactMoves());
  DeliveryExperiment ex(d, config(), options(0.0));
  ASSERT_EQ(ex.dialog().numRequests(), 8u);
  ex.setPolicy(always(ex.dialog(), ex.dialog().askItem()));  // never serves by itself
  for (std::size_t i = 0; i < 10; ++i) {
    const DeliveryTrialResult r = ex.runTrial(i);
    EXPECT_EQ(r.turns, 20);
    EXPECT_TRUE(r.forced);
    EXPECT_DOUBLE_EQ(r.qa_cost, 20 * 2.0);
    EXPECT_GE(r.served_probability, 0.5);  // the mode of the belief (2 items only were asked)
    EXPECT_GT(r.entropy, 0.0);
  }
  DialogConfig c = config();
  c.turn_limit = 3;
  DeliveryExperiment short3(d, c, options(0.0));
  short3.setPolicy(always(short3.dialog(), short3.dialog().confirmRoom(1)));
  const DeliveryTrialResult r = short3.runTrial(0);
  EXPECT_EQ(r.turns, 3);
  EXPECT_DOUBLE_EQ(r.qa_cost, 3 * 1.5);
  EXPECT_THROW(ex.setPolicy(pomdp::AlphaVectorPolicy(3)), ConfigError);
}

TEST(DeliveryExperiment, RedeliveryRuleAndWhatTheRewardSums) {
  const kb::NavDomain d = delivery_test::corridor(40, delivery_test::exactMoves());
  DeliveryExperiment ex(d, config(), options(0.0));
  const pomdp::DialogPomdp& dlg = ex.dialog();
  const std::size_t x = dlg.requestIndex(0, 0, 0);      // coke, room1, ann: one move away
  const std::size_t far = dlg.requestIndex(1, 1, 1);    // soda, room2, ben: six moves away
  ex.setPolicy(always(dlg, dlg.serveAction(x)));
  // Right at once: one trip shop -> room1.
  DeliveryTrialResult r = ex.runTrial(0, static_cast<long>(x));
  EXPECT_TRUE(r.correct);
  EXPECT_EQ(r.turns, 0);
  EXPECT_EQ(r.trips, 1);
  EXPECT_EQ(r.nav_moves, 1u);
  EXPECT_FALSE(r.redelivered);
  EXPECT_TRUE(r.fulfilled);
  EXPECT_DOUBLE_EQ(r.reward, 80.0 - 0.0 - 1.0);
  // Wrong: shop -> room1, back to the shop, learn the request, shop -> room2 (br 0: no blocking).
  r = ex.runTrial(1, static_cast<long>(far));
  EXPECT_FALSE(r.correct);
  EXPECT_EQ(r.served, x);
  EXPECT_EQ(r.request, far);
  EXPECT_TRUE(r.redelivered);
  EXPECT_EQ(r.trips, 3);
  EXPECT_EQ(r.nav_moves, 1u + 1u + 6u);
  EXPECT_TRUE(r.fulfilled);
  EXPECT_FALSE(r.nav_failed);
  EXPECT_DOUBLE_EQ(r.delivery_reward, 80.0);
  EXPECT_DOUBLE_EQ(r.nav_cost, 8.0);
  EXPECT_DOUBLE_EQ(r.reward, 80.0 - 8.0);
  // Same room, wrong item: still three trips (the delivery equation's misidentification case).
  r = ex.runTrial(2, static_cast<long>(dlg.requestIndex(1, 0, 0)));
  EXPECT_EQ(r.trips, 3);
  EXPECT_EQ(r.nav_moves, 3u);
}

TEST(DeliveryExperiment, FailedTripsEndTheDeliveryUnfulfilled) {
  // br = 1: every move into the blocking area is blocked; a blocked robot is eventually
  // trapped (or runs out of moves), so room2 is never reached.
  const kb::NavDomain d = delivery_test::corridor(40, delivery_test::exactMoves());
  DeliveryExperiment ex(d, config(), options(1.0));
  const pomdp::DialogPomdp& dlg = ex.dialog();
  ex.setPolicy(always(dlg, dlg.serveAction(dlg.requestIndex(0, 1, 1))));  // serve room2
  for (std::size_t i = 0; i < 5; ++i) {
    const DeliveryTrialResult r = ex.runTrial(i, static_cast<long>(dlg.requestIndex(1, 0, 0)));
    EXPECT_EQ(r.trips, 1);  // wrong, but the robot never arrives to find out
    EXPECT_TRUE(r.nav_failed);
    EXPECT_FALSE(r.redelivered);
    EXPECT_FALSE(r.fulfilled);
    EXPECT_DOUBLE_EQ(r.reward, -80.0 - (static_cast<double>(r.nav_moves) + 40.0));
  }
}

TEST(DeliveryExperiment, TrialsDependOnlyOnSeedAndIndex) {
  const kb::NavDomain d = delivery_test::corridor();
  const std::string cache = delivery_test::tempDir("delivery_exp_cache");
  auto o = options(0.5, 9);
  o.cache_dir = cache;
  DeliveryExperiment ex(d, config(), o);
  EXPECT_FALSE(ex.preparation().policy_from_cache);
  EXPECT_TRUE(ex.preparation().reproducible);
  const auto one = rows(ex, 0, 30, 1);
  EXPECT_EQ(rows(ex, 0, 30, 4), one);
  const auto part = rows(ex, 10, 5, 2);
  EXPECT_EQ(part, std::vector<std::string>(one.begin() + 10, one.begin() + 15));
  // A new process (here: a new experiment) reuses the cached knowledge and policy.
  DeliveryExperiment again(d, config(), o);
  EXPECT_TRUE(again.preparation().learning.from_cache);
  EXPECT_TRUE(again.preparation().policy_from_cache);
  EXPECT_EQ(rows(again, 0, 30, 3), one);
  // Without a cache it learns and solves again, reproducibly.
  auto noCache = o;
  noCache.cache_dir.clear();
  DeliveryExperiment fresh(d, config(), noCache);
  EXPECT_EQ(rows(fresh, 0, 30, 1), one);
  // Another seed gives other trials.
  auto other = o;
  other.seed = 10;
  DeliveryExperiment ex10(d, config(), other);
  EXPECT_NE(rows(ex10, 0, 30, 1), one);
  // The CSV row has the header's columns, trial index first.
  const std::string header = deliveryCsvHeader();
  EXPECT_EQ(std::count(header.begin(), header.end(), ','), std::count(one[0].begin(), one[0].end(), ','));
  EXPECT_EQ(header.substr(0, 6), "trial,");
  EXPECT_EQ(one[7].substr(0, 2), "7,");
}

TEST(DeliveryExperiment, ConditionsUseKnowledgeLearnedAtTheirBlockingRate) {
  const kb::NavDomain d = delivery_test::corridor();
  auto o = options(0.9);
  o.condition = KnowledgeCondition::kOutdated;
  DeliveryExperiment outdated(d, config(), o);
  EXPECT_DOUBLE_EQ(outdated.preparation().knowledge_br, 0.3);
  o.condition = KnowledgeCondition::kLearned;
  DeliveryExperiment learned(d, config(), o);
  EXPECT_DOUBLE_EQ(learned.preparation().knowledge_br, 0.9);
  // Knowledge learned in the harder world expects room2 (across the blocking area) to be
  // harder to reach, and the dialog's T^D follows.
  EXPECT_LT(learned.navigation().toRoom(1).reach, outdated.navigation().toRoom(1).reach);
  const std::size_t s = learned.dialog().requestIndex(0, 1, 0);
  EXPECT_LT(learned.dialog().spec().delivery(s, s), outdated.dialog().spec().delivery(s, s));
  EXPECT_EQ(conditionFromString("outdated"), KnowledgeCondition::kOutdated);
  EXPECT_THROW(conditionFromString("fresh"), ConfigError);
  o.blocking_rate = -0.1;
  EXPECT_THROW(DeliveryExperiment(d, config(), o), ConfigError);
}

}  // namespace
