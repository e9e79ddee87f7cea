// The navigation transfer experiment (learn shop->room1, extract, apply to shop->room2) on the
// 8 x 3 corridor of krr_test::corridor8x3 (room2's route crosses blocking area ba1).
#include <gtest/gtest.h>
#include <unistd.h>

#include "../support/nav_fixtures.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/experiments/nav_transfer.h"

namespace {

using namespace krr::experiments;
using krr::kb::NavDomain;

NavDomain tinyDomain() { return krr_test::corridor8x3("tiny"); }

/// The tasks of the paper's office, which the test domains name alike (no default places).
NavTransferOptions officeTasks() {
  NavTransferOptions o;
  o.start = "shop";
  o.source = "room1";
  o.target = "room2";
  return o;
}

NavTransferOptions tinyOptions() {
  NavTransferOptions o = officeTasks();
  o.source_episodes = 60;
  o.convergence_episodes = 10;
  o.target_episodes = 15;
  o.rmax.known_threshold = 2;
  return o;
}

TEST(NavTransfer, TrialExtractsKnowledgeAndUsesItThroughTheReasoner) {
  NavDomain d = tinyDomain();
  krr::kb::NavigationKnowledge kb(*d.grid, d.knowledge_files);
  auto t = runNavTransferTrial(d, kb, tinyOptions(), 7, 0);
  ASSERT_EQ(t.reward_with.size(), 15u);
  ASSERT_EQ(t.reward_without.size(), 15u);
  EXPECT_GT(t.learned_pairs, 0u);
  EXPECT_GT(t.prior_pairs, 0u);
  // R-Max explores the whole corridor, room2 included; room2 is the target's (terminal) goal,
  // so its learned pairs are in the KB but cannot be priors of the target task.
  EXPECT_LT(t.prior_pairs, t.learned_pairs);
  EXPECT_LE(t.source_episodes_run, 60u);
}

TEST(NavTransfer, TrialsAreReproducibleAndIndependentOfThreads) {
  NavDomain d = tinyDomain();
  auto o = tinyOptions();
  krr::kb::NavigationKnowledge kb(*d.grid, d.knowledge_files);
  auto a = runNavTransferTrial(d, kb, o, 3, 5);
  auto b = runNavTransferTrial(d, kb, o, 3, 5);  // same KB object reused
  EXPECT_EQ(a.reward_with, b.reward_with);
  EXPECT_EQ(a.reward_without, b.reward_without);
  auto c = runNavTransferTrial(d, kb, o, 3, 6);
  EXPECT_NE(a.reward_without, c.reward_without);

  auto s1 = runNavTransfer(d, o, 11, 6, 1);
  auto s2 = runNavTransfer(d, o, 11, 6, 2);
  EXPECT_EQ(s1.mean_with, s2.mean_with);
  EXPECT_EQ(s1.mean_without, s2.mean_without);
}

TEST(NavTransfer, ExtractionLearnsFaster) {
  // With the whole corridor known from the source task the target policy is right from the
  // first episode; without it R-Max must first explore (M = 2 samples per pair, 84 pairs),
  // which costs whole episodes. Averaged over 20 seeded trials the gap is large.
  NavDomain d = tinyDomain();
  auto s = runNavTransfer(d, tinyOptions(), 1, 20, 2);
  double with = 0, without = 0;
  for (int e = 0; e < 3; ++e) {
    with += s.mean_with[e];
    without += s.mean_without[e];
  }
  EXPECT_GT(with / 3, without / 3 + 5.0) << "with " << with / 3 << " without " << without / 3;
  EXPECT_GT(s.success_with[0], s.success_without[0]);
}

TEST(NavTransfer, TrialRangesConcatenateToTheWholeRun) {
  NavDomain d = tinyDomain();
  auto o = tinyOptions();
  o.target_episodes = 5;
  const auto all = runNavTransferTrials(d, o, 4, 0, 4, 2);
  const auto head = runNavTransferTrials(d, o, 4, 0, 1, 1);
  const auto tail = runNavTransferTrials(d, o, 4, 1, 3, 2);
  ASSERT_EQ(all.size(), 4u);
  EXPECT_EQ(all[0].reward_with, head[0].reward_with);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(tail[i].index, i + 1);
    EXPECT_EQ(all[i + 1].reward_with, tail[i].reward_with);
    EXPECT_EQ(all[i + 1].reward_without, tail[i].reward_without);
    EXPECT_EQ(all[i + 1].success_without, tail[i].success_without);
  }
  // The summary of the trials is the summary runNavTransfer computes.
  const auto s = summarizeNavTransfer(all);
  const auto r = runNavTransfer(d, o, 4, 4, 1);
  EXPECT_EQ(s.mean_with, r.mean_with);
  EXPECT_EQ(s.ci_without, r.ci_without);
}

TEST(NavTransfer, OptionsFileIsReadAndValidated) {
  char tmpl[] = "/tmp/krr_transfer_opt_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  auto load = [&](const std::string& text) {
    krr::writeFileAtomic(dir + "/o.yaml", text);
    return loadNavTransferOptions(dir + "/o.yaml", officeTasks());
  };
  const auto o = load("nav_transfer: {target: room5, target_episodes: 40}\n"
                      "rmax_learning: {known_threshold: 3}\nplanning: {step_cost: 0.5}\n");
  EXPECT_EQ(o.target, "room5");
  EXPECT_EQ(o.target_episodes, 40u);
  EXPECT_EQ(o.rmax.known_threshold, 3u);
  EXPECT_EQ(o.rmax.step_cost, 0.5);
  EXPECT_EQ(o.rmax.rmax, 40.0);  // untouched default
  for (const auto& [text, what] : std::vector<std::pair<std::string, std::string>>{
           {"nav_transfer: {targt: room5}\n", "unknown field 'nav_transfer.targt'"},
           {"targt: room5\n", "unknown field 'targt'"},
           {"nav_transfer: {target_episodes: 0}\n", "target_episodes"},
           {"simulator: {blocking_rate: 1.5}\n", "blocking_rate"},
           {"rmax_learning: {known_threshold: 0}\n", "rmax_learning.known_threshold"},
           {"rmax_learning: {speed: 1}\n", "unknown field 'rmax_learning.speed'"},
           {"nav_transfer: {target: room1}\n", "same as source"},
           // The time of day is a base setting (context.time), not the experiment's own.
           {"nav_transfer: {time: noon}\n", "unknown field 'nav_transfer.time'"},
           {"rmax_learning: [1, 2\n", "broken YAML"}}) {
    try {
      load(text);
      ADD_FAILURE() << "no ConfigError for " << text;
    } catch (const krr::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("o.yaml"), std::string::npos) << e.what();
    }
  }
  // No place has a default name: a file and defaults naming none are refused, naming the field.
  krr::writeFileAtomic(dir + "/o.yaml", "nav_transfer: {start: shop, target: room5}\n");
  try {
    loadNavTransferOptions(dir + "/o.yaml");
    ADD_FAILURE() << "no ConfigError without a source";
  } catch (const krr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'source' has invalid value '' (no place"),
              std::string::npos) << e.what();
  }
  // The shipped experiment loads over its base, config/navigation.yaml (reward, R-Max, br),
  // changing only M.
  const auto shipped = loadNavTransferOptions(
      std::string(KRR_TEST_DATA_DIR) + "/../../../../config/experiments/nav_transfer.yaml");
  EXPECT_EQ(shipped.rmax.rmax, 40.0);  // the paper's Rmax
  EXPECT_EQ(shipped.rmax.step_cost, 1.0);
  EXPECT_EQ(shipped.rmax.known_threshold, 3u);
  EXPECT_EQ(shipped.rmax.discount, 0.95);
  EXPECT_EQ(shipped.rmax.replan_every, 10u);
  EXPECT_EQ(shipped.blocking_rate, 0.3);
  EXPECT_EQ(shipped.time, "morning");  // navigation.yaml's context.time
  EXPECT_EQ(shipped.start + " " + shipped.source + " " + shipped.target, "shop room1 room2");
  EXPECT_EQ(load("context: {time: noon}\n").time, "noon");
}

TEST(NavTransfer, InvalidOptionsAreRefused) {
  NavDomain d = tinyDomain();
  auto o = tinyOptions();
  o.target = o.source;
  EXPECT_THROW(runNavTransfer(d, o, 1, 2, 1), krr::ConfigError);
  o = tinyOptions();
  o.blocking_rate = 1.5;
  EXPECT_THROW(runNavTransfer(d, o, 1, 2, 1), krr::ConfigError);
  EXPECT_THROW(runNavTransfer(d, tinyOptions(), 1, 0, 1), krr::ConfigError);
  o = tinyOptions();
  o.target = "room9";
  EXPECT_THROW(runNavTransfer(d, o, 1, 2, 1), krr::UnknownSymbolError);
}

}  // namespace
