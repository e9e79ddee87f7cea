// Issue 24: a computation the reasoner refuses (a grounding or inference budget exhausted, a
// memory budget, a parse error in a query, an incoherent patch of a cached grounding) leaves
// the Reasoner as it was: the next queries on the same object are answered, correctly, and
// from the groundings cached before. A grounding stopped on its time budget used to leave an
// empty entry in the grounding cache, and the next query crashed in Reasoner::trimLog.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/plog/budget.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

namespace {

// `trip` grounds 1501^3 combinations (none satisfies the rule): stopped by any small budget.
// `big` has 2300^2 random instances, all of them in the relevance cone of `any_big`: over a
// 32 MiB memory budget. The coins are quick; their relevance cones are disjoint from trip's and
// big's.
const std::string kProgram = R"(
num = {0..1500}.
#domain num(X), num(Y), num(Z).
trip : boolean.
trip :- X + Y + Z = 9000.
n = {1..2300}.
big : n, n -> boolean.
[b] random(big(A, B)).
any_big : boolean.
any_big :- big(A, B) = true.
coin = {1..3}.
side = {h, t}.
#domain coin(C).
flip : coin -> side.
[f] random(flip(C)).
[f] pr(flip(C) = h) = 3/10.
both : boolean.
both :- flip(1) = h, flip(2) = h.
)";

// Queries answered on `r` and their exact values (flip(1)=h: 0.3, both: 0.09).
void expectCoinsAnswered(Reasoner& r) {
  EXPECT_NEAR(r.probability("?{flip(1) = h}"), 0.3, 1e-12);
  EXPECT_NEAR(r.probability("?{both}"), 0.09, 1e-12);
  EXPECT_NEAR(r.probability("?{flip(3) = t} | obs(flip(2) = h)"), 0.7, 1e-12);
  const Table t = r.tableQuery("both", {"flip(1)"});
  ASSERT_EQ(t.rows.size(), 2u);
  ASSERT_EQ(t.rows[0].distribution.size(), 1u);  // do(flip(1)=h): both iff flip(2)=h
  EXPECT_NEAR(t.rows[0].distribution[0].probability, 0.3, 1e-12);
}

GroundingLimits timeLimits(double seconds) {
  GroundingLimits l;
  l.max_ground_seconds = seconds;
  l.max_inference_seconds = seconds;
  return l;
}

void budgetStoppedThenAnswered(Backend backend) {
  Reasoner r;
  r.setBackend(backend);
  r.loadString(kProgram, "kb.plog");
  r.setLimits(timeLimits(0.3));
  EXPECT_NEAR(r.probability("?{flip(1) = h}"), 0.3, 1e-12);  // a cached grounding first
  const size_t groundings = r.stats().full_groundings;
  const std::string exported = r.exportProgram();
  EXPECT_THROW(r.probability("?{trip}"), BudgetExceededError);
  EXPECT_EQ(r.stats().full_groundings, groundings);  // the stopped grounding is not counted
  EXPECT_EQ(r.exportProgram(), exported);
  // twice: the second stop must not find anything of the first
  EXPECT_THROW(r.probability("?{trip}"), BudgetExceededError);
  expectCoinsAnswered(r);
  // flip(1)'s grounding, made before the stops, is still the cached one
  const size_t after = r.stats().full_groundings;
  EXPECT_NEAR(r.probability("?{flip(2) = h}"), 0.3, 1e-12);
  EXPECT_EQ(r.stats().full_groundings, after);
  // and knowledge still patches it
  r.addStatements("[f] pr(flip(C) = h) = 1/2.", "learned");
  EXPECT_NEAR(r.probability("?{flip(1) = h}"), 0.5, 1e-12);
  EXPECT_TRUE(r.stats().ground_incremental);
}

}  // namespace

TEST(PlogRefused, QueryAfterAGroundingStoppedOnItsTimeBudgetNative) {
  budgetStoppedThenAnswered(Backend::Native);
}

TEST(PlogRefused, QueryAfterAGroundingStoppedOnItsTimeBudgetAuto) {
  budgetStoppedThenAnswered(Backend::Auto);
}

TEST(PlogRefused, QueryAfterAGroundingStoppedOnItsMemoryBudget) {
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(kProgram, "kb.plog");
  EXPECT_NEAR(r.probability("?{flip(1) = h}"), 0.3, 1e-12);
  GroundingLimits lim;
  lim.max_ground_atoms = 0;  // only the memory budget stops it
  lim.max_ground_statements = 0;
  lim.memory_budget = 32u << 20;
  r.setLimits(lim);
  try {
    r.probability("?{any_big}");
    FAIL() << "no budget error";
  } catch (const BudgetExceededError& e) {
    EXPECT_NE(std::string(e.what()).find("memory budget"), std::string::npos) << e.what();
  }
  expectCoinsAnswered(r);
  // one instance of big: its cone is that instance (GroundingLimits::cone_restrict_min_instances)
  EXPECT_NEAR(r.probability("?{big(1, 1) = true}"), 0.5, 1e-12);
}

TEST(PlogRefused, QueryAfterAParseErrorInAQuery) {
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(kProgram, "kb.plog");
  EXPECT_NEAR(r.probability("?{both}"), 0.09, 1e-12);
  EXPECT_THROW(r.probability("?{flip(1) = }"), ParseError);
  EXPECT_THROW(r.probability("?{flip(7) = h}"), Error);  // 7 is not a coin
  EXPECT_THROW(r.distribution("flip(", ""), ParseError);
  EXPECT_THROW(r.tableQuery("both", {"flip(1)"}, "obs(flip(2) = )"), ParseError);
  expectCoinsAnswered(r);
}

TEST(PlogRefused, QueryAfterAPatchRefusedAsIncoherent) {
  // `learned` guards the default pr-atom (patched in place when its facts change); it has two
  // head values from the start, so adding a fact never changes the relevance cones.
  const std::string text = R"(
coin = {1..3}.
side = {h, t}.
#domain coin(C).
flip : coin -> side.
other : coin -> side.
learned : coin -> side.
[f] random(flip(C)).
[o] random(other(C)).
[f] pr(flip(C) = h | not learned(C) = h) = 3/10.
learned(2) = t.
learned(3) = h.
)";
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(text, "guard.plog");
  EXPECT_NEAR(r.probability("?{flip(1) = h}"), 0.3, 1e-12);
  EXPECT_NEAR(r.probability("?{other(1) = h}"), 0.5, 1e-12);
  r.addStatements("learned(1) = h.", "ok");
  EXPECT_NEAR(r.probability("?{flip(1) = h}"), 0.5, 1e-12);
  EXPECT_TRUE(r.stats().ground_incremental);
  r.addStatements("learned(1) = t.", "bad");  // a second value: the patch refuses it
  EXPECT_THROW(r.probability("?{flip(1) = h}"), IncoherentError);
  EXPECT_THROW(r.probability("?{other(1) = h}"), IncoherentError);
  EXPECT_EQ(r.removeStatementsWithTag("bad"), 1u);
  EXPECT_NEAR(r.probability("?{other(2) = t}"), 0.5, 1e-12);
  EXPECT_NEAR(r.probability("?{flip(1) = h}"), 0.5, 1e-12);
  EXPECT_NEAR(r.probability("?{flip(2) = h}"), 0.3, 1e-12);
  EXPECT_NEAR(r.probability("?{flip(3) = h}"), 0.5, 1e-12);
}
