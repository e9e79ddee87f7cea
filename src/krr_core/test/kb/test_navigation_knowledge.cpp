// Procedure 2 (model from the knowledge base) and knowledge extraction on a 3 x 2 grid.
//
//   3 4 5        all cells free; cell 4 is blocking area ba1; shop = 0, room1 = 5.
//   0 1 2
// Human knowledge (config/navigation.plog): walkers(ba1) with P = 0.3 morning, 0.5 noon,
// 0.3 afternoon; a move into a BA cell is blocked when walkers are there (stay 0.7, trapped
// 0.3); otherwise the intended cell gets 0.8 and the other neighbours share the rest evenly.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <tuple>
#include <vector>

#include "../support/nav_fixtures.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/kb/navigation_knowledge.h"

namespace {

using krr::kb::NavigationKnowledge;
using krr::mdp::StateId;

const std::string kData = KRR_TEST_DATA_DIR;
const std::string kNavPlog = krr_test::repoPath("config/navigation.plog");
const std::string kGeometry = kData + "/kb/tiny_geometry.plog";

using krr_test::tinyGrid;

double row(const krr::kb::NavModel& m, const NavigationKnowledge& kb, int cell, int move, int to) {
  const StateId s1 = to < 0 ? kb.space().trappedState() : kb.space().stateOf(to);
  return m.dynamics.getTransitionProbability(kb.space().stateOf(cell), move, s1);
}

constexpr int kUp = 0, kRight = 3;

TEST(NavigationKnowledge, BuildsTheModelByReasoningWithTimeObserved) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  auto m = kb.buildModel({"noon"});
  EXPECT_EQ(m.dynamics.getS(), 7u);  // 6 cells + trapped
  // 3 -> right (into ba1) at noon: walkers 0.5. Blocked: stay 0.7, trapped 0.3.
  // Not blocked: 4 gets 0.8, trapped 0 (explicit), 3 and 0 share 0.2 -> 0.1 each.
  EXPECT_NEAR(row(m, kb, 3, kRight, -1), 0.5 * 0.3, 1e-12);
  EXPECT_NEAR(row(m, kb, 3, kRight, 4), 0.5 * 0.8, 1e-12);
  EXPECT_NEAR(row(m, kb, 3, kRight, 3), 0.5 * 0.7 + 0.5 * 0.1, 1e-12);
  EXPECT_NEAR(row(m, kb, 3, kRight, 0), 0.5 * 0.1, 1e-12);
  // 0 -> right (free space): 1 gets 0.8; 0 and 3 share 0.2.
  EXPECT_NEAR(row(m, kb, 0, kRight, 1), 0.8, 1e-12);
  EXPECT_NEAR(row(m, kb, 0, kRight, 3), 0.1, 1e-12);
  // 2 -> right (into the wall): stays with 0.9; 1 and 5 share 0.1.
  EXPECT_NEAR(row(m, kb, 2, kRight, 2), 0.9, 1e-12);
  EXPECT_NEAR(row(m, kb, 2, kRight, 5), 0.05, 1e-12);
  EXPECT_TRUE(m.dynamics.isTerminal(kb.space().trappedState()));
  EXPECT_EQ(m.numLearned(), 0u);
}

TEST(NavigationKnowledge, MarginalisesUnknownTime) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  // Time unknown: P(walkers) = (0.3 + 0.5 + 0.3) / 3 = 11/30; trapped = 11/30 * 0.3.
  auto all = kb.buildModel({});
  EXPECT_NEAR(row(all, kb, 3, kRight, -1), 11.0 / 30 * 0.3, 1e-12);
  // "Morning or noon": P(walkers) = (0.3 + 0.5) / 2 = 0.4; trapped = 0.12.
  auto mn = kb.buildModel({"morning", "noon"});
  EXPECT_NEAR(row(mn, kb, 3, kRight, -1), 0.4 * 0.3, 1e-12);
  EXPECT_THROW(kb.buildModel({"midnight"}), krr::UnknownSymbolError);
}

krr::mdp::RMaxModel learnCell3Right(const NavigationKnowledge& kb, const std::vector<int>& outcomes) {
  const auto& sp = kb.space();
  krr::mdp::NavigationReward reward;
  auto task = krr::mdp::makeNavigationRMaxTask(sp.numStates(), 4, {sp.placeState("room1")},
                                               {sp.trappedState()}, reward);
  krr::mdp::RMaxModel model(task, 0.95, static_cast<std::uint32_t>(outcomes.size()), 40.0);
  for (int c : outcomes)
    model.observe(sp.stateOf(3), kRight, c < 0 ? sp.trappedState() : sp.stateOf(c));
  return model;
}

TEST(NavigationKnowledge, LearnedKnowledgeOverridesHumanKnowledgeInItsContextOnly) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  // 4 tries of (3, right) at noon: 4, 4, 3, trapped -> 2/4, 1/4, 1/4.
  auto rm = learnCell3Right(kb, {4, 4, 3, -1});
  ASSERT_TRUE(rm.isKnown(kb.space().stateOf(3), kRight));
  EXPECT_EQ(kb.addLearned(rm.knownPairs(), "noon"), 1u);
  EXPECT_NE(kb.learnedText().find("pr(next_cell=4 | curr_cell=3, act_move=right, curr_time=noon) = 2/4."),
            std::string::npos)
      << kb.learnedText();

  auto noon = kb.buildModel({"noon"});
  EXPECT_NEAR(row(noon, kb, 3, kRight, 4), 0.5, 1e-12);
  EXPECT_NEAR(row(noon, kb, 3, kRight, 3), 0.25, 1e-12);
  EXPECT_NEAR(row(noon, kb, 3, kRight, -1), 0.25, 1e-12);
  EXPECT_NEAR(row(noon, kb, 3, kRight, 0), 0.0, 1e-12);
  EXPECT_TRUE(noon.learned[kb.space().stateOf(3) * 4 + kRight]);
  EXPECT_EQ(noon.numLearned(), 1u);
  // Other pairs at noon keep human knowledge.
  EXPECT_NEAR(row(noon, kb, 0, kRight, 1), 0.8, 1e-12);

  // Morning: nothing learned; human knowledge (walkers 0.3): trapped 0.09.
  auto morning = kb.buildModel({"morning"});
  EXPECT_NEAR(row(morning, kb, 3, kRight, -1), 0.3 * 0.3, 1e-12);
  EXPECT_EQ(morning.numLearned(), 0u);

  // Morning or noon (new circumstances): the reasoner mixes the human morning model and the
  // learned noon model with weights 1/2: trapped = (0.09 + 0.25) / 2; not "learned" overall.
  auto mixed = kb.buildModel({"morning", "noon"});
  EXPECT_NEAR(row(mixed, kb, 3, kRight, -1), (0.09 + 0.25) / 2, 1e-12);
  EXPECT_FALSE(mixed.learned[kb.space().stateOf(3) * 4 + kRight]);
}

TEST(NavigationKnowledge, RelearningReplacesInsteadOfAccumulating) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  kb.addLearned(learnCell3Right(kb, {4, 3, -1}).knownPairs(), "noon");
  // Re-learned with a single outcome: the old outcomes 3 and trapped must disappear
  // (keeping them would make the pr-atoms sum above 1).
  kb.addLearned(learnCell3Right(kb, {4, 4}).knownPairs(), "noon");
  auto noon = kb.buildModel({"noon"});
  EXPECT_NEAR(row(noon, kb, 3, kRight, 4), 1.0, 1e-12);
  EXPECT_NEAR(row(noon, kb, 3, kRight, -1), 0.0, 1e-12);
  kb.clearLearned();
  EXPECT_NEAR(row(kb.buildModel({"noon"}), kb, 3, kRight, -1), 0.15, 1e-12);
}

std::string tempPath(const std::string& name) {
  char tmpl[] = "/tmp/krr_kb_XXXXXX";
  return std::string(::mkdtemp(tmpl)) + "/" + name;
}

TEST(NavigationKnowledge, LearnedKnowledgeSurvivesSaveAndLoad) {
  const std::string path = tempPath("learned.plog");
  {
    NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
    kb.addLearned(learnCell3Right(kb, {4, 4, 3, -1, 4}).knownPairs(), "morning");
    kb.saveLearned(path);
  }
  NavigationKnowledge kb2(tinyGrid(), {kGeometry, kNavPlog});
  kb2.loadLearned(path);
  auto m = kb2.buildModel({"morning"});
  EXPECT_NEAR(row(m, kb2, 3, kRight, 4), 3.0 / 5, 1e-12);
  EXPECT_NEAR(row(m, kb2, 3, kRight, -1), 1.0 / 5, 1e-12);
  EXPECT_EQ(m.numLearned(), 1u);
  // The same file can also be given as a knowledge file.
  NavigationKnowledge kb3(tinyGrid(), {kGeometry, kNavPlog, path});
  EXPECT_NEAR(row(kb3.buildModel({"morning"}), kb3, 3, kRight, 4), 3.0 / 5, 1e-12);
}

TEST(NavigationKnowledge, LearnedEntriesListWhatWasLearned) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  EXPECT_TRUE(kb.learnedEntries().empty());
  kb.addLearned(learnCell3Right(kb, {4, 4, 3, -1, 4}).knownPairs(), "noon");
  const auto entries = kb.learnedEntries();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].cell, 3);
  EXPECT_EQ(entries[0].move, kRight);
  EXPECT_EQ(entries[0].time, "noon");
  EXPECT_EQ(entries[0].denominator, 5);
  long sum = 0, k4 = 0, trapped = 0;
  for (const auto& [value, k] : entries[0].outcomes) {
    sum += k;
    if (value == "4") k4 = k;
    if (value == "trapped") trapped = k;
  }
  EXPECT_EQ(sum, 5);
  EXPECT_EQ(k4, 3);
  EXPECT_EQ(trapped, 1);
  kb.clearLearned();
  EXPECT_TRUE(kb.learnedEntries().empty());
}

// Rebuilds after extraction are incremental (the reasoner patches its grounding and recomputes
// the changed rows only); they must give exactly what a fresh knowledge base computes.
TEST(NavigationKnowledge, IncrementalRebuildsEqualAFreshKnowledgeBase) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  auto expectSame = [&](const std::vector<std::string>& times) {
    const std::string path = tempPath("learned.plog");
    kb.saveLearned(path);
    NavigationKnowledge fresh(tinyGrid(), {kGeometry, kNavPlog, path});
    const auto a = kb.buildModel(times), b = fresh.buildModel(times);
    const std::size_t S = kb.space().numStates();
    for (StateId s = 0; s + 1 < S; ++s)
      for (krr::mdp::ActionId m = 0; m < 4; ++m)
        for (StateId s1 = 0; s1 < S; ++s1)
          ASSERT_NEAR(a.dynamics.getTransitionProbability(s, m, s1),
                      b.dynamics.getTransitionProbability(s, m, s1), 1e-14)
              << "s " << s << " a " << m << " s1 " << s1;
  };
  kb.buildModel({"noon"});
  kb.addLearned(learnCell3Right(kb, {4, 4, 3, -1}).knownPairs(), "noon");
  expectSame({"noon"});
  EXPECT_TRUE(kb.reasoner().stats().ground_incremental);
  EXPECT_EQ(kb.reasoner().stats().table_rows_computed, 1u);
  kb.addLearned(learnCell3Right(kb, {4, 0}).knownPairs(), "morning");
  kb.addLearned(learnCell3Right(kb, {-1, -1, 4}).knownPairs(), "noon");  // re-learned
  expectSame({"noon"});
  expectSame({"morning", "noon"});
  expectSame({});
  kb.clearLearned();
  expectSame({"noon"});
  EXPECT_TRUE(kb.reasoner().stats().ground_incremental);
}

/// R-Max known pairs: each (cell, move) tried with these outcomes (cells; -1 = trapped), all
/// the same number of times.
krr::mdp::RMaxModel learnPairs(const NavigationKnowledge& kb,
                               const std::vector<std::tuple<int, int, std::vector<int>>>& tries) {
  const auto& sp = kb.space();
  krr::mdp::NavigationReward reward;
  auto task = krr::mdp::makeNavigationRMaxTask(sp.numStates(), 4, {sp.placeState("room1")},
                                               {sp.trappedState()}, reward);
  krr::mdp::RMaxModel model(task, 0.95, 2, 40.0);
  for (const auto& [cell, move, outcomes] : tries)
    for (int c : outcomes)
      model.observe(sp.stateOf(cell), static_cast<krr::mdp::ActionId>(move),
                    c < 0 ? sp.trappedState() : sp.stateOf(c));
  return model;
}

// replaceLearned = forget that time's pairs, then addLearned; but what is learned again
// unchanged is not rewritten (fewer rows recomputed).
TEST(NavigationKnowledge, ReplacingLearnedPairsEqualsClearingAndAdding) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  const auto morning = learnPairs(kb, {{0, kUp, {3, 3}}}).knownPairs();
  const auto first = learnPairs(kb, {{3, kRight, {4, -1}}, {0, kRight, {1, 1}},
                                     {1, kUp, {4, 4}}}).knownPairs();
  // (3, right) again the same, (0, right) changed, (1, up) gone, (2, up) new
  const auto second = learnPairs(kb, {{3, kRight, {4, -1}}, {0, kRight, {1, 0}},
                                      {2, kUp, {5, 5}}}).knownPairs();
  kb.addLearned(morning, "morning");
  EXPECT_EQ(kb.replaceLearned(first, "noon"), 3u);
  kb.buildModel({"noon"});
  EXPECT_EQ(kb.replaceLearned(second, "noon"), 3u);
  const auto noon = kb.buildModel({"noon"});
  EXPECT_EQ(kb.reasoner().stats().table_rows_computed, 3u);  // (0, right), (1, up), (2, up)
  EXPECT_EQ(kb.learnedPairCount("noon"), 3u);
  EXPECT_EQ(kb.learnedPairCount(), 4u);

  NavigationKnowledge fresh(tinyGrid(), {kGeometry, kNavPlog});
  fresh.addLearned(morning, "morning");
  fresh.addLearned(second, "noon");
  EXPECT_EQ(kb.learnedText(), fresh.learnedText());
  for (const std::vector<std::string>& times :
       {std::vector<std::string>{"noon"}, {"morning"}, {"morning", "noon"}}) {
    const auto a = kb.buildModel(times), b = fresh.buildModel(times);
    for (StateId s = 0; s + 1 < kb.space().numStates(); ++s)
      for (krr::mdp::ActionId m = 0; m < 4; ++m)
        for (StateId s1 = 0; s1 < kb.space().numStates(); ++s1)
          ASSERT_NEAR(a.dynamics.getTransitionProbability(s, m, s1),
                      b.dynamics.getTransitionProbability(s, m, s1), 1e-14);
    EXPECT_EQ(a.learned, b.learned);
  }
  // (1, up) is back on human knowledge: into ba1, free of walkers (0.5 at noon) 0.8
  EXPECT_NEAR(row(noon, kb, 1, kUp, 4), 0.5 * 0.8, 1e-12);
}

TEST(NavigationKnowledge, MalformedLearnedFileIsRejectedAndNothingIsLost) {
  NavigationKnowledge kb(tinyGrid(), {kGeometry, kNavPlog});
  kb.addLearned(learnCell3Right(kb, {4, 4}).knownPairs(), "noon");
  const std::string path = tempPath("bad.plog");
  krr::writeFileAtomic(path, "learned(3, right, noon).\npr(next_cell=4 | curr_cell=3) = 1/2.\n");
  try {
    kb.loadLearned(path);
    FAIL() << "expected ParseError";
  } catch (const krr::ParseError& e) {
    EXPECT_EQ(e.location().file, path);
    EXPECT_EQ(e.location().line, 2);
  }
  krr::writeFileAtomic(path, "pr(next_cell=4 | curr_cell=3, act_move=up, curr_time=noon) = 1/1.\n");
  EXPECT_THROW(kb.loadLearned(path), krr::ParseError);  // no learned(...) fact
  krr::writeFileAtomic(path, "pr(next_cell=4 | curr_cell=3, act_move=up,\n");
  EXPECT_THROW(kb.loadLearned(path), krr::ParseError);  // truncated
  // What was learned before is intact.
  EXPECT_NEAR(row(kb.buildModel({"noon"}), kb, 3, kRight, 4), 1.0, 1e-12);
  // 3 -> up leaves the grid: human knowledge says stay with 0.9; trapped is explicitly 0
  // (the move is not blocked), so 4 and 0 share the remaining 0.1.
  EXPECT_NEAR(row(kb.buildModel({"noon"}), kb, 3, kUp, 3), 0.9, 1e-12);
  EXPECT_NEAR(row(kb.buildModel({"noon"}), kb, 3, kUp, 0), 0.05, 1e-12);
}

TEST(NavigationKnowledge, GeometryForAnotherGridIsRejected) {
  const auto grid =
      krr_test::makeGrid(4, 2, krr_test::places({}, {{"ba1", {1.0, 1.0, 2.0, 2.0}}}));
  EXPECT_THROW(NavigationKnowledge(grid, {kGeometry, kNavPlog}), krr::ConfigError);
}

}  // namespace
