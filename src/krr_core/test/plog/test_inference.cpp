// Table queries (Procedure 2's inner loop) and the reasoner API around them.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/examples/grid_program.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;
using krr::examples::GridNavigationSpec, krr::examples::makeGridNavigationProgram;

namespace {

GridNavigationSpec smallGrid() {
  GridNavigationSpec s;
  s.width = 4;
  s.height = 3;
  s.walls = {{2, 1}};
  s.areas = {{"a0", 0, 0, 1, 0, 0.3, 0.7}, {"a1", 3, 2, 3, 2, 0.5, 0.6}};
  return s;
}

double probOf(const TableRow& row, const std::string& v) {
  for (const auto& x : row.distribution)
    if (x.value == v) return x.probability;
  return 0.0;
}

}  // namespace

// Every row of the table equals the corresponding single query with do() conditioning.
TEST(PlogInference, TableEqualsSingleQueries) {
  Reasoner r;
  r.loadString(makeGridNavigationProgram(smallGrid()), "grid");
  Table t = r.tableQuery("next_cell", {"curr_cell", "act_move"});
  const auto cells = r.sortValues("cell");
  const auto moves = r.sortValues("move");
  ASSERT_EQ(cells.size(), 11u);  // 12 cells minus one wall
  ASSERT_EQ(t.rows.size(), cells.size() * moves.size());
  for (const auto& row : t.rows) {
    ASSERT_TRUE(row.consistent);
    double sum = 0;
    for (const auto& v : row.distribution) sum += v.probability;
    EXPECT_NEAR(sum, 1.0, 1e-12);
    EXPECT_NEAR(row.undefined_probability, 0.0, 1e-15);
    for (const auto& c1 : cells) {
      double single = r.probability("?{next_cell=" + c1 + "} | do(curr_cell=" +
                                    row.conditioning_values[0] + "), do(act_move=" +
                                    row.conditioning_values[1] + ")");
      EXPECT_NEAR(probOf(row, c1), single, 1e-12)
          << row.conditioning_values[0] << " " << row.conditioning_values[1] << " -> " << c1;
    }
  }
}

// Hand-derived entries of the grid program (4x3, wall at (2,1) = cell 6).
// Cell 0 is in area a0 (walkers 0.3, blocking 0.7); success by time: 0.4*0.95 + 0.3*0.8 +
// 0.3*0.9 = 0.89. Moving right from 0: reachable = {0, 1, 4}.
//   blocked (0.3): stay 0.7, others (1 - 0.7)/2 = 0.15 each;
//   not blocked (0.7): cell 1 gets the success rate s_t, the other two (1 - s_t)/2.
//   P(1) = 0.3*0.15 + 0.7*0.89 = 0.668; P(0) = 0.3*0.7 + 0.7*(0.11/2) = 0.2485;
//   P(4) = 0.3*0.15 + 0.7*0.055 = 0.0835.
// Cell 5 (not in an area) moving right: (2,1) is a wall, reachable = {5, 1, 4, 9}: no success
// pr-atom applies, the default makes next_cell uniform: 1/4 each.
TEST(PlogInference, GridEntriesByHand) {
  Reasoner r;
  r.loadString(makeGridNavigationProgram(smallGrid()), "grid");
  Table t = r.tableQuery("next_cell", {"curr_cell", "act_move"});
  auto find = [&](const std::string& c, const std::string& m) -> const TableRow& {
    for (const auto& row : t.rows)
      if (row.conditioning_values[0] == c && row.conditioning_values[1] == m) return row;
    throw Error("row not found");
  };
  const TableRow& r0 = find("0", "right");
  EXPECT_NEAR(probOf(r0, "1"), 0.668, 1e-12);
  EXPECT_NEAR(probOf(r0, "0"), 0.2485, 1e-12);
  EXPECT_NEAR(probOf(r0, "4"), 0.0835, 1e-12);
  EXPECT_EQ(r0.distribution.size(), 3u);
  const TableRow& r5 = find("5", "right");
  ASSERT_EQ(r5.distribution.size(), 4u);
  for (const auto& v : r5.distribution) EXPECT_NEAR(v.probability, 0.25, 1e-12);
}

// Conditioning by observation instead of intervention gives the same table here, because
// curr_cell and act_move have no ancestors (obs and do coincide for root attributes).
TEST(PlogInference, TableWithObservationsMatchesDoForRoots) {
  Reasoner r;
  r.loadString(makeGridNavigationProgram(smallGrid()), "grid");
  Table a = r.tableQuery("next_cell", {"curr_cell", "act_move"});
  Table b = r.tableQuery("next_cell", {"curr_cell", "act_move"}, "", false);
  ASSERT_EQ(a.rows.size(), b.rows.size());
  for (size_t i = 0; i < a.rows.size(); ++i) {
    ASSERT_EQ(a.rows[i].distribution.size(), b.rows[i].distribution.size());
    for (size_t k = 0; k < a.rows[i].distribution.size(); ++k)
      EXPECT_NEAR(a.rows[i].distribution[k].probability, b.rows[i].distribution[k].probability,
                  1e-12);
  }
}

// Evidence in a table query: with obs(curr_time = noon) and walkers(a0) = false forced,
// moving right from cell 0 succeeds with 0.8; the other two cells get 0.1 each.
TEST(PlogInference, TableWithEvidence) {
  Reasoner r;
  r.loadString(makeGridNavigationProgram(smallGrid()), "grid");
  Table t = r.tableQuery("next_cell", {"curr_cell", "act_move"},
                         "obs(curr_time = noon), do(walkers(a0) = false)");
  for (const auto& row : t.rows)
    if (row.conditioning_values[0] == "0" && row.conditioning_values[1] == "right") {
      EXPECT_NEAR(probOf(row, "1"), 0.8, 1e-12);
      EXPECT_NEAR(probOf(row, "0"), 0.1, 1e-12);
      EXPECT_NEAR(probOf(row, "4"), 0.1, 1e-12);
    }
}

// Learned knowledge replaces instead of duplicating: re-learning the same pr-atom updates it.
// Cell 1 moving up, morning, no walkers: reachable {1, 0, 2, 5}; the generic pr-atom gives
// P(5) = 0.95 and the default splits 0.05 over {0, 1, 2}: P(0) = 0.05/3. Learning
// pr(next_cell=0 | ...) = 0.02 makes P(0) = 0.02 (and 1, 2 get 0.015 each); re-learning 0.03
// updates it in place; removing the tag restores 0.05/3.
TEST(PlogInference, AddStatementsReplacesLearnedPrAtoms) {
  Reasoner r;
  r.loadString(makeGridNavigationProgram(smallGrid()), "grid");
  const std::string q =
      "?{next_cell=0} | do(curr_cell=1), do(act_move=up), do(curr_time=morning), "
      "do(walkers(a0)=false)";
  EXPECT_NEAR(r.probability(q), 0.05 / 3, 1e-12);
  size_t n0 = r.program().pr_atoms.size();
  EXPECT_EQ(r.addStatements("pr(next_cell=0 | curr_cell=1, act_move=up, curr_time=morning) = 0.02.",
                            "learned"),
            1u);
  EXPECT_EQ(r.program().pr_atoms.size(), n0 + 1);
  EXPECT_NEAR(r.probability(q), 0.02, 1e-12);
  // re-learning (body literals in another order) updates in place
  r.addStatements("pr(next_cell=0 | act_move=up, curr_cell=1, curr_time=morning) = 0.03.",
                  "learned");
  EXPECT_EQ(r.program().pr_atoms.size(), n0 + 1);
  EXPECT_NEAR(r.probability(q), 0.03, 1e-12);
  EXPECT_NEAR(r.probability("?{next_cell=2} | do(curr_cell=1), do(act_move=up), "
                            "do(curr_time=morning), do(walkers(a0)=false)"),
              0.01, 1e-12);  // (1 - 0.95 - 0.03) / 2
  EXPECT_EQ(r.removeStatementsWithTag("learned"), 1u);
  EXPECT_NEAR(r.probability(q), 0.05 / 3, 1e-12);
}

TEST(PlogInference, Introspection) {
  Reasoner r;
  r.loadString(makeGridNavigationProgram(smallGrid()), "grid");
  EXPECT_EQ(r.sortValues("move"), (std::vector<std::string>{"up", "down", "left", "right"}));
  EXPECT_EQ(r.attributeRange("curr_time"),
            (std::vector<std::string>{"morning", "noon", "afternoon"}));
  EXPECT_EQ(r.attributeRange("walkers"), (std::vector<std::string>{"true", "false"}));
  EXPECT_THROW(r.sortValues("nosuchsort"), UnknownSymbolError);
  auto d = r.distribution("curr_time");
  ASSERT_EQ(d.size(), 3u);
  EXPECT_NEAR(d[2].probability, 0.3, 1e-12);  // afternoon: 1 - 0.4 - 0.3
}
