// Observed navigation: moves an external executor made (navigation_node's move_base mode) become
// the samples area extraction learns from. A simulated executor that aborts moves into a
// blocking area at a known rate must teach that rate as the area's walker rate, and the model
// the knowledge base then computes must trap moves into the area at that rate.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "../support/nav_fixtures.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/random.h"
#include "krr_core/kb/observed_navigation.h"

namespace {

using namespace krr;
using namespace krr::kb;

const std::string kNavPlog = krr_test::repoPath("config/navigation.plog");

/// 5 x 3 grid of 1 m cells; blocking area ba1 = column 2 (all rows), ba2 = cell (4, 0).
struct World {
  nav::NavGrid grid;
  std::string geometry;
  World() {
    using krr_test::place;
    grid = krr_test::makeGrid(5, 3, krr_test::places({place("shop", 0, 1), place("room1", 4, 1)},
                                                     {{"ba1", {2.0, 0.0, 3.0, 3.0}},
                                                      {"ba2", {4.0, 0.0, 5.0, 1.0}}}));
    geometry = krr_test::tempDir("observed") + "/geometry.plog";
    writeFileAtomic(geometry, grid.toPlog("observed_test"));
  }
};

/// An executor like the rostest's fake move_base: every move into a cell of ba1 is aborted
/// with probability `abort_ba1`, of ba2 with `abort_ba2`; every other move arrives.
ObservedMove execute(const nav::NavGrid& g, int cell, int move, double abort_ba1,
                     double abort_ba2, Rng& rng) {
  const int target = g.neighbour(cell, move);
  ObservedMove m{cell, move, target < 0 ? cell : target, "morning"};
  if (target < 0) return m;
  const std::uint32_t mask = g.areaMask(target);
  const double rate = (mask & 1u) ? abort_ba1 : (mask & 2u) ? abort_ba2 : 0.0;
  if (uniform01(rng) < rate) m.next_cell = -1;
  return m;
}

TEST(ObservedNavigation, ClassifiesTheFourOutcomes) {
  World w;
  const int from = w.grid.cellId(1, 1);
  const int right = w.grid.cellId(2, 1), below = w.grid.cellId(1, 0);
  EXPECT_EQ(classifyMove(w.grid, from, nav::kRight, right, false), MoveOutcome::kReached);
  EXPECT_EQ(classifyMove(w.grid, from, nav::kRight, from, false), MoveOutcome::kStayed);
  EXPECT_EQ(classifyMove(w.grid, from, nav::kRight, below, false), MoveOutcome::kElsewhere);
  EXPECT_EQ(classifyMove(w.grid, from, nav::kRight, right, true), MoveOutcome::kAborted);
  for (MoveOutcome o : {MoveOutcome::kReached, MoveOutcome::kStayed, MoveOutcome::kElsewhere,
                        MoveOutcome::kAborted})
    EXPECT_EQ(moveOutcomeFromString(toString(o)), o);
  EXPECT_THROW(moveOutcomeFromString("trapped"), ConfigError);
}

TEST(ObservedNavigation, AbortRatesBecomeTheAreasWalkerRates) {
  World w;
  NavigationKnowledge kb(w.grid, {w.geometry, kNavPlog});
  ObservedNavigation seen(kb.space());
  Rng rng = makeRng(7, "observed");
  const double ba1 = 0.3, ba2 = 0.6;
  for (int k = 0; k < 40000; ++k) {  // random walk, restarted at random after an abort
    const int cell = kb.space().cellOf(static_cast<mdp::StateId>(
        uniform01(rng) * static_cast<double>(kb.space().trappedState())));
    seen.add(execute(w.grid, cell, static_cast<int>(uniform01(rng) * 4), ba1, ba2, rng));
  }
  EXPECT_EQ(seen.moves("morning"), 40000u);
  EXPECT_EQ(seen.moves("noon"), 0u);
  const std::optional<AreaKnowledge> k = seen.extract(kb, "morning");
  ASSERT_TRUE(k);
  EXPECT_NEAR(k->noise.success, 1.0, 1e-9);
  ASSERT_EQ(k->areas.size(), 2u);
  EXPECT_EQ(k->areas[0].area, "ba1");
  EXPECT_NEAR(k->areas[0].blocking, ba1, 0.02);
  EXPECT_NEAR(k->areas[1].blocking, ba2, 0.03);
  EXPECT_NEAR(k->areas[0].trap, 1.0, 1e-9);  // an abort is the trapped outcome
  // Procedure 2 now traps a move into ba1 at the observed abort rate.
  ASSERT_EQ(kb.learnedAreas().count("morning"), 1u);
  const mdp::SparseModel model = kb.buildModel({"morning"}, 1.0).dynamics;
  double trapped = 0.0;
  for (const auto& o : model.successors(kb.space().stateOf(w.grid.cellId(1, 1)), nav::kRight))
    if (o.state == kb.space().trappedState()) trapped = o.probability;
  EXPECT_NEAR(trapped, k->areas[0].blocking, 1e-5);
  EXPECT_FALSE(seen.estimate("noon"));
}

TEST(ObservedNavigation, NoEstimateBeforeAFreeMoveAndSharedPools) {
  World w;
  const NavStateSpace space(w.grid);
  ObservedNavigation seen(space);
  const int from = w.grid.cellId(1, 1), into = w.grid.cellId(2, 1);
  seen.add({from, nav::kRight, -1, "morning"});
  EXPECT_FALSE(seen.estimate("morning")) << "the move noise is unknown without a free move";
  auto pool = std::make_shared<mdp::VisitCounts>(space.numStates(), 4);
  pool->add(space.stateOf(w.grid.cellId(0, 1)), nav::kUp, space.stateOf(w.grid.cellId(0, 0)));
  seen.share("morning", pool);  // a free-time learner's samples: a free move
  seen.add({from, nav::kRight, into, "morning"});
  const std::optional<AreaKnowledge> k = seen.estimate("morning");
  ASSERT_TRUE(k);
  EXPECT_EQ(pool->count(space.stateOf(from), nav::kRight), 1u);
  EXPECT_EQ(seen.moves("morning"), 2u);
  EXPECT_THROW(seen.share("noon", std::make_shared<mdp::VisitCounts>(3, 4)), ConfigError);
}

TEST(ObservedNavigation, RefusesWhatIsNotAMoveOfTheGrid) {
  World w;
  const NavStateSpace space(w.grid);
  ObservedNavigation seen(space);
  const int from = w.grid.cellId(1, 1);
  EXPECT_THROW(seen.add({-3, nav::kUp, from, "morning"}), UnknownSymbolError);
  EXPECT_THROW(seen.add({from, 4, from, "morning"}), UnknownSymbolError);
  EXPECT_THROW(seen.add({from, nav::kUp, 1000, "morning"}), UnknownSymbolError);
  EXPECT_THROW(seen.add({from, nav::kUp, from, ""}), UnknownSymbolError);
  EXPECT_EQ(seen.moves("morning"), 0u);
}

TEST(ObservedNavigation, LargestChangeOfTheLearnedProbabilities) {
  AreaKnowledge a;
  a.noise.moves = 10;
  a.noise.success = 0.9;
  a.areas.push_back({"ba1", 0.3, 1.0, 5, 1});
  AreaKnowledge b = a;
  EXPECT_DOUBLE_EQ(largestChange(a, b), 0.0);
  b.areas[0].blocking = 0.42;
  EXPECT_NEAR(largestChange(a, b), 0.12, 1e-12);
  b.noise.success = 0.5;
  EXPECT_NEAR(largestChange(a, b), 0.4, 1e-12);
  b.areas.push_back({"ba2", 0.1, 0.5, 1, 0});
  EXPECT_DOUBLE_EQ(largestChange(a, b), 1.0) << "a newly seen area";
  EXPECT_DOUBLE_EQ(largestChange(std::nullopt, a), 1.0) << "nothing known before";
}

}  // namespace
