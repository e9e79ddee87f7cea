// Incremental grounding and table queries: after adding or removing knowledge, the reasoner
// patches its cached grounding and recomputes only the affected table rows. Every answer must
// equal what a fresh reasoner loaded with the same program computes from scratch.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

namespace {

const std::string kData = KRR_TEST_DATA_DIR;
const std::string kNavPlog = kData + "/../../../../config/navigation.plog";
const std::string kGeometry = kData + "/kb/tiny_geometry.plog";

// The navigation knowledge base on the 3 x 2 tiny geometry (cell 4 is blocking area ba1).
std::string navProgram() { return readFile(kGeometry) + "\n" + readFile(kNavPlog); }

// Learned knowledge for (cell, move, time): outcome -> k/n, and the learned(...) fact.
std::string learned(int cell, const std::string& move, const std::string& time,
                    const std::vector<std::pair<std::string, std::string>>& outcomes) {
  std::string s;
  for (const auto& [v, p] : outcomes)
    s += "pr(next_cell=" + v + " | curr_cell=" + std::to_string(cell) + ", act_move=" + move +
         ", curr_time=" + time + ") = " + p + ".\n";
  return s + "learned(" + std::to_string(cell) + ", " + move + ", " + time + ").\n";
}

void expectSameTable(const Table& a, const Table& b) {
  ASSERT_EQ(a.rows.size(), b.rows.size());
  for (size_t i = 0; i < a.rows.size(); ++i) {
    const TableRow& x = a.rows[i];
    const TableRow& y = b.rows[i];
    ASSERT_EQ(x.conditioning_values, y.conditioning_values);
    ASSERT_EQ(x.consistent, y.consistent);
    ASSERT_EQ(x.distribution.size(), y.distribution.size())
        << x.conditioning_values[0] << " " << x.conditioning_values[1];
    for (size_t k = 0; k < x.distribution.size(); ++k) {
      EXPECT_EQ(x.distribution[k].value, y.distribution[k].value);
      EXPECT_NEAR(x.distribution[k].probability, y.distribution[k].probability, 1e-14)
          << x.conditioning_values[0] << " " << x.conditioning_values[1] << " -> "
          << x.distribution[k].value;
    }
  }
}

// The table of a fresh reasoner for the given program text.
Table fromScratch(const std::string& text, const std::string& evidence) {
  Reasoner r;
  r.loadString(text, "scratch");
  return r.tableQuery("next_cell", {"curr_cell", "act_move"}, evidence);
}

double prob(const Table& t, const std::string& cell, const std::string& move, const std::string& v) {
  for (const auto& row : t.rows)
    if (row.conditioning_values[0] == cell && row.conditioning_values[1] == move)
      for (const auto& x : row.distribution)
        if (x.value == v) return x.probability;
  return 0.0;
}

}  // namespace

TEST(PlogIncremental, LearnedKnowledgeIsPatchedInAndOutOfTheGrounding) {
  for (const std::string evidence : {"obs(curr_time=noon)", "obs(curr_time=afternoon, false)", ""}) {
    SCOPED_TRACE(evidence);
    Reasoner r;
    r.loadString(navProgram(), "nav");
    const Table t0 = r.tableQuery("next_cell", {"curr_cell", "act_move"}, evidence);
    EXPECT_FALSE(r.stats().ground_incremental);
    EXPECT_EQ(r.stats().table_rows_computed, 24u);

    // Learn two pairs at noon and one in the morning.
    const std::string k1 = learned(3, "right", "noon", {{"4", "2/4"}, {"3", "1/4"}, {"trapped", "1/4"}}) +
                           learned(0, "up", "noon", {{"3", "1/1"}}) +
                           learned(3, "right", "morning", {{"4", "1/2"}, {"0", "1/2"}});
    r.addStatements(k1, "learned");
    const Table t1 = r.tableQuery("next_cell", {"curr_cell", "act_move"}, evidence);
    EXPECT_TRUE(r.stats().ground_incremental);
    EXPECT_EQ(r.stats().table_rows_computed, 2u);  // rows (3, right) and (0, up) only
    expectSameTable(t1, fromScratch(navProgram() + k1, evidence));
    if (evidence == "obs(curr_time=noon)") {
      EXPECT_NEAR(prob(t1, "3", "right", "trapped"), 0.25, 1e-15);
      EXPECT_NEAR(prob(t1, "0", "up", "3"), 1.0, 1e-15);
    }

    // Forget it all: back to the human knowledge, still without grounding again.
    EXPECT_EQ(r.removeStatementsWithTag("learned"), 9u);
    const Table t2 = r.tableQuery("next_cell", {"curr_cell", "act_move"}, evidence);
    EXPECT_TRUE(r.stats().ground_incremental);
    expectSameTable(t2, t0);
  }
}

TEST(PlogIncremental, ReplacementsDuplicatesAndRemovalByValue) {
  Reasoner r;
  r.loadString(navProgram(), "nav");
  r.tableQuery("next_cell", {"curr_cell", "act_move"});
  std::string text = learned(1, "up", "morning", {{"4", "3/5"}, {"1", "2/5"}});
  r.addStatements(text, "learned");
  // An identical fact is not added twice.
  EXPECT_EQ(r.addStatements("learned(1, up, morning).", "other"), 0u);
  // Same pr-atoms with new probabilities replace the old ones.
  const std::string relearned = learned(1, "up", "morning", {{"4", "1/5"}, {"1", "4/5"}});
  r.addStatements(relearned, "learned");
  Table t = r.tableQuery("next_cell", {"curr_cell", "act_move"});
  expectSameTable(t, fromScratch(navProgram() + relearned, ""));
  const std::string morning = "obs(curr_time=morning)";
  EXPECT_NEAR(prob(r.tableQuery("next_cell", {"curr_cell", "act_move"}, morning), "1", "up", "4"), 0.2, 1e-15);

  // removeStatements: by atom and body, whatever the probability given.
  Program p = parseProgram(navProgram(), "nav");
  parseInto(p, learned(1, "up", "morning", {{"4", "9/10"}, {"1", "1/10"}}), "x");
  std::vector<PrAtom> prs(p.pr_atoms.end() - 2, p.pr_atoms.end());
  std::vector<Rule> facts(p.rules.end() - 1, p.rules.end());
  EXPECT_EQ(r.removeStatements({}, prs), 2u);
  t = r.tableQuery("next_cell", {"curr_cell", "act_move"});
  EXPECT_TRUE(r.stats().ground_incremental);
  // learned(1, up, morning) still holds: the human defaults stay off and nothing is assigned,
  // so next_cell is uniform over its range there.
  expectSameTable(t, fromScratch(navProgram() + "learned(1, up, morning).\n", ""));
  EXPECT_EQ(r.removeStatements(facts, {}), 1u);
  expectSameTable(r.tableQuery("next_cell", {"curr_cell", "act_move"}), fromScratch(navProgram(), ""));

  // A fact stated twice in a loaded program: both copies count.
  Reasoner twice;
  twice.loadString(navProgram() + "learned(1, up, morning).\nlearned(1, up, morning).\n", "twice");
  twice.tableQuery("next_cell", {"curr_cell", "act_move"});
  EXPECT_EQ(twice.removeStatements(facts, {}), 2u);
  expectSameTable(twice.tableQuery("next_cell", {"curr_cell", "act_move"}), fromScratch(navProgram(), ""));
  EXPECT_TRUE(twice.stats().ground_incremental);

  // Parsed statements can be added without text.
  r.addStatements(facts, prs, "learned");
  EXPECT_NEAR(prob(r.tableQuery("next_cell", {"curr_cell", "act_move"}, morning), "1", "up", "4"), 0.9, 1e-15);
  t = r.tableQuery("next_cell", {"curr_cell", "act_move"});
  expectSameTable(t, fromScratch(navProgram() + learned(1, "up", "morning", {{"4", "9/10"}, {"1", "1/10"}}), ""));
}

TEST(PlogIncremental, OtherChangesGroundAgain) {
  Reasoner r;
  r.loadString(navProgram(), "nav");
  r.tableQuery("next_cell", {"curr_cell", "act_move"});
  // A rule with a body changes derived knowledge: full grounding, correct answer.
  const std::string rule = "blocked(0, right) :- walkers(ba1) = true.\n";
  r.addStatements(rule, "x");
  Table t = r.tableQuery("next_cell", {"curr_cell", "act_move"});
  EXPECT_FALSE(r.stats().ground_incremental);
  expectSameTable(t, fromScratch(navProgram() + rule, ""));
  // A fact of an attribute that is not a guard (in_ba is used in rule bodies).
  const std::string fact = "in_ba(1, ba1).\n";
  r.addStatements(fact, "x");
  t = r.tableQuery("next_cell", {"curr_cell", "act_move"});
  EXPECT_FALSE(r.stats().ground_incremental);
  expectSameTable(t, fromScratch(navProgram() + rule + fact, ""));
  r.removeStatementsWithTag("x");
  expectSameTable(r.tableQuery("next_cell", {"curr_cell", "act_move"}), fromScratch(navProgram(), ""));
}

TEST(PlogIncremental, SingleQueriesAndErrorsAfterPatches) {
  Reasoner r;
  r.loadString(navProgram(), "nav");
  const std::string q = "?{next_cell=trapped} | do(curr_cell=3), do(act_move=right), obs(curr_time=noon)";
  EXPECT_NEAR(r.probability(q), 0.5 * 0.3, 1e-15);
  r.addStatements(learned(3, "right", "noon", {{"trapped", "1/4"}, {"4", "3/4"}}), "learned");
  EXPECT_NEAR(r.probability(q), 0.25, 1e-15);
  EXPECT_TRUE(r.stats().ground_incremental);
  // learned(...) is a boolean attribute: a second value for the same arguments is an error.
  r.addStatements("learned(3, right, noon) = false.", "bad");
  EXPECT_THROW(r.probability(q), IncoherentError);
  r.removeStatementsWithTag("bad");
  EXPECT_NEAR(r.probability(q), 0.25, 1e-15);
  // pr-atoms that overflow a distribution are still reported.
  r.addStatements("pr(next_cell=0 | curr_cell=3, act_move=right, curr_time=noon) = 1/2.", "bad");
  EXPECT_THROW(r.probability(q), IncoherentError);
  r.removeStatementsWithTag("bad");
  EXPECT_NEAR(r.probability(q), 0.25, 1e-15);
  r.removeStatementsWithTag("learned");
  EXPECT_NEAR(r.probability(q), 0.5 * 0.3, 1e-15);
}
