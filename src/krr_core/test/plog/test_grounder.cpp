// Grounder: relevance cone, static evaluation, fact-indexed joins, dynamic ranges.
#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"
#include "krr_core/examples/grid_program.h"
#include "krr_core/plog/grounder.h"
#include "krr_core/plog/parser.h"

using namespace krr;
using namespace krr::plog;
using krr::examples::GridNavigationSpec, krr::examples::makeGridNavigationProgram;

TEST(PlogGrounder, RelevanceConeSkipsUnrelatedAttributes) {
  Program p = parseProgram(R"(s = {a, b}.
x : s. y : s. z : s. w : s.
random(x). random(y). random(z). random(w).
pr(y = a | x = a) = 0.9.
pr(w = a | z = b) = 0.2.
)",
                           "cone");
  std::set<std::string> cone = relevanceCone(p, {"y"});
  EXPECT_EQ(cone, (std::set<std::string>{"x", "y"}));
  GroundProgram g = groundProgram(p, {"y"});
  EXPECT_GE(g.findInstance("x"), 0);
  EXPECT_GE(g.findInstance("y"), 0);
  EXPECT_LT(g.findInstance("z"), 0);  // not grounded: outside the cone
  EXPECT_LT(g.findInstance("w"), 0);
  // constraints pull in the attributes they connect
  Program q = parseProgram(R"(s = {a, b}.
x : s. y : s. z : s.
random(x). random(y). random(z).
:- y = a, z = a.
)",
                           "cone2");
  EXPECT_EQ(relevanceCone(q, {"y"}), (std::set<std::string>{"y", "z"}));
}

// A pr-atom whose body has a fact literal must be grounded by iterating the facts: on a 60x60
// grid (3600 cells) the body curr_cell=C, leftof(C,C1) yields exactly one ground pr-atom per
// leftof fact (59 * 60 = 3540), not 3600^2 candidate pairs.
TEST(PlogGrounder, FactJoinsInsteadOfSortProducts) {
  GridNavigationSpec s;
  s.width = 60;
  s.height = 60;
  Program p = parseProgram(makeGridNavigationProgram(s), "grid60");
  Stopwatch sw;
  GroundProgram g = groundProgram(p, {"next_cell", "curr_cell", "act_move"});
  double secs = sw.seconds();
  int nc = g.findInstance("next_cell");
  ASSERT_GE(nc, 0);
  const GInstance& gi = g.instances[static_cast<size_t>(nc)];
  // 4 moves x 3 times: right/left have 59*60 facts each, up/down 60*59
  EXPECT_EQ(gi.prs.size(), 4u * 3u * 59u * 60u);
  // one selection rule per cell, each with its dynamic range (self + neighbours)
  ASSERT_EQ(gi.selections.size(), 3600u);
  size_t range_total = 0;
  for (const auto& sel : gi.selections) range_total += sel.range.size();
  // self (3600) + 2 * horizontal adjacencies (2*3540) + 2 * vertical (2*3540)
  EXPECT_EQ(range_total, 3600u + 4u * 3540u);
  // static facts were evaluated away: bodies hold only dynamic literals
  for (const auto& pr : gi.prs) EXPECT_LE(pr.body.size(), 4u);
  EXPECT_LT(secs, 5.0);  // generous bound; the benchmark reports the real figure
}

TEST(PlogGrounder, StaticAtomsAndInstances) {
  Program p = parseProgram(R"(n = {0..4}.
#domain n(X; Y).
succ : n, n -> boolean.
even : n -> boolean.
succ(X, Y) :- Y = X + 1.
even(0).
even(Y) :- succ(X, Y), not even(X).
c : n.
random(c).
)",
                           "st");
  // "even(Y) :- succ(X,Y), not even(X)" is recursive through negation: outside the fast path
  EXPECT_THROW(groundProgram(p, {"even"}), Error);
  Program q = parseProgram(R"(n = {0..4}.
#domain n(X; Y).
succ : n, n -> boolean.
two : n, n -> boolean.
succ(X, Y) :- Y = X + 1.
two(X, Y) :- succ(X, Z), succ(Z, Y), Z >= 0.
)",
                           "st2");
  // Z has no sort: it is bound by the succ facts, so grounding works
  GroundProgram g = groundProgram(q, {"two"});
  int two = -1;
  for (size_t i = 0; i < q.attributes.size(); ++i)
    if (q.attributes[i].name == "two") two = static_cast<int>(i);
  EXPECT_TRUE(g.staticHolds(two, "two(0,2)=true"));
  EXPECT_TRUE(g.staticHolds(two, "two(2,4)=true"));
  EXPECT_FALSE(g.staticHolds(two, "two(0,1)=true"));
  EXPECT_EQ(g.static_atoms[static_cast<size_t>(two)].size(), 3u);
}

TEST(PlogGrounder, UntypedVariableIsReported) {
  Program p = parseProgram(R"(s = {a}.
x : s.
p : boolean.
random(x).
p :- Q > 1.
)",
                           "untyped");
  try {
    groundProgram(p, {"p"});
    FAIL();
  } catch (const UnknownSymbolError& e) {
    EXPECT_NE(std::string(e.what()).find("variable Q"), std::string::npos) << e.what();
  }
}
