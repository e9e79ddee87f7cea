// Area knowledge: pooled estimates of what the knowledge base says is shared (walker and trap
// rates per blocking area, move noise elsewhere), written back as P-log. With counts in the
// exact proportions of the simulator, the estimates are the simulator's parameters, and the
// knowledge base's model computed from them (Procedure 2) is the simulator's true model.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <string>

#include "../support/nav_fixtures.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/kb/area_knowledge.h"
#include "krr_core/kb/simulated_navigation.h"
#include "krr_core/nav/blockage_simulator.h"

namespace {

using namespace krr;
using namespace krr::kb;

const std::string kData = KRR_TEST_DATA_DIR;
const std::string kNavPlog = krr_test::repoPath("config/navigation.plog");

/// 5 x 3 grid of 1 m cells; blocking area ba1 = column 2 (all rows), ba2 = cell (4, 0).
struct World {
  nav::NavGrid grid;
  std::string geometry;
  nav::SimulatorConfig sim;
  World() {
    using krr_test::place;
    grid = krr_test::makeGrid(5, 3, krr_test::places({place("shop", 0, 1), place("room1", 4, 1)},
                                                     {{"ba1", {2.0, 0.0, 3.0, 3.0}},
                                                      {"ba2", {4.0, 0.0, 5.0, 1.0}}}));
    geometry = krr_test::tempDir("area") + "/geometry.plog";
    writeFileAtomic(geometry, grid.toPlog("area_test"));
    sim.move_success = 0.9;
    sim.slip_stay = 0.06;
    sim.slip_lateral = 0.04;
    sim.trap_probability = 0.25;
    sim.trap_reference_cell_size = 0.0;  // no rescaling: 0.25 per blocked move
  }
};

/// Counts in the exact proportions of the simulator's distributions (n per (cell, move)).
mdp::VisitCounts exactCounts(const nav::BlockageSimulator& sim, const NavStateSpace& space,
                             const nav::Context& ctx, double n) {
  mdp::VisitCounts c(space.numStates(), 4);
  for (mdp::StateId s = 0; s < space.trappedState(); ++s)
    for (int m = 0; m < 4; ++m)
      for (const auto& [cell, p] : sim.trueDistribution(space.cellOf(s), m, ctx)) {
        const mdp::StateId s1 = cell == sim.trappedState() ? space.trappedState() : space.stateOf(cell);
        const auto k = static_cast<std::uint32_t>(std::lround(p * n));
        if (k) c.add(s, static_cast<mdp::ActionId>(m), s1, k);
      }
  return c;
}

TEST(AreaKnowledge, EstimatesAreTheSimulatorsParameters) {
  World w;
  const nav::BlockageSimulator sim(w.grid, w.sim);
  const NavStateSpace space(w.grid);
  const nav::Context ctx(-1, 0.4);
  const AreaKnowledge k = estimateAreaKnowledge(exactCounts(sim, space, ctx, 1e6), space, "morning");
  EXPECT_NEAR(k.noise.success, 0.9, 1e-5);
  EXPECT_NEAR(k.noise.lateral, 0.02, 1e-5);   // slip_lateral / 2 per existing side
  EXPECT_NEAR(k.noise.wall_stay, 1.0, 1e-9);
  ASSERT_EQ(k.areas.size(), 2u);
  for (const AreaEstimate& a : k.areas) {
    EXPECT_NEAR(a.blocking, 0.4, 1e-4) << a.area;
    EXPECT_NEAR(a.trap, 0.25, 1e-4) << a.area;
  }
  EXPECT_EQ(k.areas[0].area, "ba1");
}

TEST(AreaKnowledge, TheKnowledgeBaseModelFromTheEstimatesIsTheTrueModel) {
  World w;
  const nav::BlockageSimulator sim(w.grid, w.sim);
  NavigationKnowledge kb(w.grid, {w.geometry, kNavPlog});
  const nav::Context ctx(-1, 0.4);
  const AreaKnowledge k =
      estimateAreaKnowledge(exactCounts(sim, kb.space(), ctx, 1e6), kb.space(), "morning");
  kb.setLearnedAreas("morning", areaKnowledgeText(k));
  const mdp::SparseModel model = kb.buildModel({"morning"}, 1.0).dynamics;
  const mdp::SparseModel truth = trueDynamics(sim, kb.space(), ctx);
  double worst = 0.0;
  for (mdp::StateId s = 0; s < kb.space().trappedState(); ++s)
    for (mdp::ActionId a = 0; a < 4; ++a) {
      std::vector<double> p(kb.space().numStates(), 0.0), q(kb.space().numStates(), 0.0);
      for (const auto& o : model.successors(s, a)) p[o.state] += o.probability;
      for (const auto& o : truth.successors(s, a)) q[o.state] += o.probability;
      for (std::size_t i = 0; i < p.size(); ++i) worst = std::max(worst, std::fabs(p[i] - q[i]));
    }
  EXPECT_LT(worst, 1e-4) << "the P-log rules do not reproduce the simulator's structure";
  // Another time of day keeps the human defaults (walkers 0.5 at noon, blocked: trapped 0.3).
  const mdp::SparseModel noon = kb.buildModel({"noon"}, 1.0).dynamics;
  const mdp::StateId into = kb.space().stateOf(w.grid.cellId(1, 1));  // right: into ba1
  double trapped = 0.0;
  for (const auto& o : noon.successors(into, nav::kRight))
    if (o.state == kb.space().trappedState()) trapped = o.probability;
  EXPECT_NEAR(trapped, 0.5 * 0.3, 1e-9);
}

TEST(AreaKnowledge, SavedAndReloadedKnowledgeGivesTheSameModel) {
  World w;
  const nav::BlockageSimulator sim(w.grid, w.sim);
  NavigationKnowledge kb(w.grid, {w.geometry, kNavPlog});
  const nav::Context ctx(-1, 0.7);
  kb.setLearnedAreas("morning", areaKnowledgeText(estimateAreaKnowledge(
                                    exactCounts(sim, kb.space(), ctx, 1e5), kb.space(), "morning")));
  const std::string file = w.geometry + ".learned";
  kb.saveLearned(file);
  NavigationKnowledge again(w.grid, {w.geometry, kNavPlog});
  again.loadLearned(file);
  EXPECT_EQ(again.learnedText(), kb.learnedText());
  const auto a = kb.buildModel({"morning"}).dynamics, b = again.buildModel({"morning"}).dynamics;
  for (mdp::StateId s = 0; s < kb.space().trappedState(); ++s)
    for (mdp::ActionId m = 0; m < 4; ++m) {
      std::vector<std::pair<mdp::StateId, double>> pa, pb;
      for (const auto& o : a.successors(s, m)) pa.emplace_back(o.state, o.probability);
      for (const auto& o : b.successors(s, m)) pb.emplace_back(o.state, o.probability);
      EXPECT_EQ(pa, pb);
    }
  // Replacing the knowledge of a time replaces it; clearing forgets it.
  kb.clearLearned();
  EXPECT_TRUE(kb.learnedAreas().empty());
  EXPECT_EQ(kb.learnedText().find("walkers"), std::string::npos);
}

TEST(AreaKnowledge, FewSkewedSamplesStillGiveACoherentModel) {
  // Every free move seen slipped sideways from a cell with one lateral neighbour: the pooled
  // lateral rate alone would give 2 * 1.0 > 1 for cells with two sides.
  World w;
  NavigationKnowledge kb(w.grid, {w.geometry, kNavPlog});
  mdp::VisitCounts c(kb.space().numStates(), 4);
  const mdp::StateId corner = kb.space().stateOf(w.grid.cellId(0, 0));  // up: side is (1, 0)
  c.add(corner, nav::kUp, kb.space().stateOf(w.grid.cellId(1, 0)), 5);
  const AreaKnowledge k = estimateAreaKnowledge(c, kb.space(), "morning");
  EXPECT_LE(k.noise.success + 2 * k.noise.lateral, 1.0);
  ASSERT_NO_THROW(kb.setLearnedAreas("morning", areaKnowledgeText(k)));
  const mdp::SparseModel model = kb.buildModel({"morning"}, 1.0).dynamics;
  for (mdp::StateId s = 0; s < kb.space().trappedState(); ++s)
    for (mdp::ActionId a = 0; a < 4; ++a) {
      double sum = 0.0;
      for (const auto& o : model.successors(s, a)) sum += o.probability;
      EXPECT_NEAR(sum, 1.0, 1e-9);
    }
}

TEST(AreaKnowledge, BadInputIsRefused) {
  World w;
  NavigationKnowledge kb(w.grid, {w.geometry, kNavPlog});
  EXPECT_THROW(estimateAreaKnowledge(mdp::VisitCounts(3, 4), kb.space(), "morning"), ConfigError);
  // Only moves into areas: the noise cannot be estimated.
  mdp::VisitCounts only(kb.space().numStates(), 4);
  only.add(kb.space().stateOf(w.grid.cellId(1, 1)), nav::kRight, kb.space().trappedState(), 3);
  EXPECT_THROW(estimateAreaKnowledge(only, kb.space(), "morning"), ConfigError);
  EXPECT_THROW(kb.setLearnedAreas("midnight", "learned_noise(morning)."), UnknownSymbolError);
  EXPECT_THROW(kb.setLearnedAreas("morning", "pr(walkers(ba9)=true) = 1/2."), Error);
  EXPECT_TRUE(kb.learnedAreas().empty());  // a refused update changes nothing
}

}  // namespace
