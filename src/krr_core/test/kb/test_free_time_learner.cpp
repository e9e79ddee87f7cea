// Procedure 1 on an 8 x 3 corridor with three places (krr_test::corridor8x3).
#include <gtest/gtest.h>
#include <unistd.h>

#include "../support/nav_fixtures.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/kb/free_time_learner.h"
#include "krr_core/nav/grid_astar.h"

namespace {

using namespace krr::kb;

NavDomain corridor() { return krr_test::corridor8x3("corridor"); }

FreeTimeOptions options() {
  FreeTimeOptions o;
  o.max_episodes_per_task = 40;
  o.convergence_episodes = 8;
  o.rmax.known_threshold = 2;
  return o;
}

TEST(LeastKnownSelector, PicksTheRouteTheKnowledgeBaseKnowsLeast) {
  NavDomain d = corridor();
  NavigationKnowledge kb(*d.grid, d.knowledge_files);
  LeastKnownSelector sel({"shop", "room1", "room2"}, "shop");
  krr::Rng rng = krr::makeRng(1, "sel");
  // Teach the KB the whole shop->room1 route (top row): that task now has no unknown pair on
  // its shortest route, so room2 must be selected.
  krr::nav::GridAStar astar(*d.grid);
  auto route = astar.plan(d.grid->placeCell("shop"), d.grid->placeCell("room1"));
  std::vector<krr::mdp::KnownPair> pairs;
  for (size_t k = 0; k < route.moves.size(); ++k) {
    krr::mdp::KnownPair kp;
    kp.state = d.space->stateOf(route.cells[k]);
    kp.action = static_cast<krr::mdp::ActionId>(route.moves[k]);
    kp.distribution = {krr::mdp::Outcome{d.space->stateOf(route.cells[k + 1]), 1.0}};
    kp.samples = 3;
    pairs.push_back(kp);
  }
  kb.addLearned(pairs, "morning");
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(sel.next(kb.buildModel({"morning"}), *d.space, rng).goal, "room2");
  EXPECT_THROW(LeastKnownSelector({"shop"}, "shop"), krr::ConfigError);
  // The rule itself, as the delivery route selector uses it: any start, any order of tasks.
  const NavModel model = kb.buildModel({"morning"});
  const std::vector<NavTask> tasks = {{"room2", "shop"}, {"shop", "room1"}, {"shop", "room2"}};
  for (int i = 0; i < 5; ++i) {
    const std::size_t pick = krr::kb::leastKnownTask(tasks, model, *d.space, rng);
    EXPECT_NE(tasks[pick].goal, "room1") << "shop->room1 is fully known";
  }
  EXPECT_THROW(krr::kb::leastKnownTask({}, model, *d.space, rng), krr::ConfigError);
}

/// @brief How much the knowledge base learned at `time`, in the extraction's own unit: learned
/// (cell, move) pairs, or areas whose pooled rates were written.
std::size_t learnedAt(const NavigationKnowledge& kb, const std::string& time, Extraction e) {
  if (e == Extraction::kPairs) return kb.learnedPairCount(time);
  const auto it = kb.learnedAreas().find(time);
  if (it == kb.learnedAreas().end()) return 0;
  std::size_t areas = 0;  // one learned_area(A, T) fact per area
  for (std::size_t p = it->second.find("learned_area("); p != std::string::npos;
       p = it->second.find("learned_area(", p + 1))
    ++areas;
  return areas;
}

class FreeTimeLearnerBoth : public ::testing::TestWithParam<Extraction> {};

TEST_P(FreeTimeLearnerBoth, LearnsTasksAndWritesKnowledgeBack) {
  NavDomain d = corridor();
  NavigationKnowledge kb(*d.grid, d.knowledge_files);
  LeastKnownSelector sel({"room1", "room2"}, "shop");
  auto o = options();
  o.extraction = GetParam();
  o.max_tasks = 1;
  FreeTimeLearner learner(d, kb, sel, o);
  krr::Rng rng = krr::makeRng(5, "ftl");
  int persisted = 0;
  auto first = learner.run(rng, [] { return false; }, [&](const NavTask&) { ++persisted; });
  ASSERT_EQ(first.tasks.size(), 1u);
  EXPECT_EQ(persisted, 1);
  EXPECT_FALSE(first.interrupted);
  EXPECT_TRUE(first.converged[0]);
  EXPECT_GT(first.pairs_extracted, 0u);
  const std::size_t learned1 = learnedAt(kb, "morning", o.extraction);
  EXPECT_EQ(learned1, first.pairs_extracted);
  EXPECT_EQ(learnedAt(kb, "noon", o.extraction), 0u);  // learned in the morning only
  EXPECT_EQ(kb.learnedPairCount(), o.extraction == Extraction::kPairs ? learned1 : 0u)
      << "area extraction writes no per-pair knowledge";

  // The next session starts from the knowledge base (Procedure 2 priors): it knows at least as
  // much afterwards. Learned pairs start known, so it converges in fewer episodes than the
  // first task needed; area knowledge does not mark pairs known (free_time_learner.cpp).
  auto second = learner.run(rng, [] { return false; });
  ASSERT_EQ(second.tasks.size(), 1u);
  EXPECT_GE(learnedAt(kb, "morning", o.extraction), learned1);
  if (o.extraction == Extraction::kPairs) EXPECT_LT(second.episodes[0], first.episodes[0]);
  else EXPECT_EQ(second.pairs_extracted, learned1) << "the same areas, re-estimated";
}

TEST_P(FreeTimeLearnerBoth, InterruptionKeepsWhatWasLearnedSoFar) {
  NavDomain d = corridor();
  NavigationKnowledge kb(*d.grid, d.knowledge_files);
  LeastKnownSelector sel({"room1", "room2"}, "shop");
  auto o = options();
  o.extraction = GetParam();
  FreeTimeLearner learner(d, kb, sel, o);
  krr::Rng rng = krr::makeRng(9, "ftl");
  int checks = 0;
  // The interruption is checked once before a task is selected and once before every episode:
  // returning true on the fifth check lets three episodes of the first task run.
  auto report = learner.run(rng, [&] { return ++checks > 4; });
  EXPECT_TRUE(report.interrupted);
  ASSERT_EQ(report.tasks.size(), 1u);
  EXPECT_EQ(report.episodes[0], 3u);
  EXPECT_FALSE(report.converged[0]);
  EXPECT_GT(learnedAt(kb, "morning", o.extraction), 0u);
}

INSTANTIATE_TEST_SUITE_P(Extractions, FreeTimeLearnerBoth,
                         ::testing::Values(Extraction::kPairs, Extraction::kAreas),
                         [](const ::testing::TestParamInfo<Extraction>& i) {
                           return toString(i.param);
                         });

TEST(FreeTimeLearner, InvalidOptionsAreRefused) {
  NavDomain d = corridor();
  NavigationKnowledge kb(*d.grid, d.knowledge_files);
  LeastKnownSelector sel({"room1"}, "shop");
  auto o = options();
  o.max_episodes_per_task = 0;
  EXPECT_THROW(FreeTimeLearner(d, kb, sel, o), krr::ConfigError);
  o = options();
  o.rmax.rmax = -1;
  EXPECT_THROW(FreeTimeLearner(d, kb, sel, o), krr::ConfigError);
}

}  // namespace
