// Issue 24: the P-log front end at scale. Behaviour and budgets, not timings (those are in
// bench_plog_scale): flat arithmetic is folded, a term has a size limit with its location,
// memory budgets end in BudgetExceededError naming the phase and the statement, and
// probability sums within rounding of 1 are renormalised with a warning.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"
#include "krr_core/plog/budget.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

namespace {

std::string flatSum(int terms, const std::string& first) {
  std::string s = first;
  for (int i = 1; i < terms; ++i) s += "+1";
  return s;
}

std::string facts(int n) {
  std::string s;
  for (int i = 0; i < n; ++i) s += "q" + std::to_string(i) + ".\n";
  return s;
}

}  // namespace

TEST(PlogScale, FlatGroundSumIsFoldedAsRead) {
  const std::string text =
      "s = {0..30000}.\na : s.\n[r] random(a).\n?{a = " + flatSum(20000, "1") + "}.\n";
  Program p = parseProgram(text, "sum.plog");
  ASSERT_EQ(p.queries.size(), 1u);
  const Term& v = p.queries[0].formula.at(0).atom.value;
  EXPECT_EQ(v.kind, Term::Kind::Integer);  // one node, not a 20000-deep tree
  EXPECT_EQ(v.value, 20000);
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(text, "sum.plog");
  EXPECT_NEAR(r.probability(p.queries[0]), 1.0 / 30001.0, 1e-12);
}

TEST(PlogScale, FoldingKeepsOverflowAndDivisionForEvaluation) {
  // an operation that overflows or divides by zero is not folded: it stays a term and is
  // reported (or undefined) where it is evaluated, as before
  Program p = parseProgram("s = {1..3}.\np : s -> boolean.\np(X) :- X = 9223372036854775807 + 1.\n"
                           "p(X) :- X = 1 / 0.\n", "o.plog");
  ASSERT_EQ(p.rules.size(), 2u);
  EXPECT_EQ(p.rules[0].body.at(0).rhs.kind, Term::Kind::Binary);
  EXPECT_EQ(p.rules[1].body.at(0).rhs.kind, Term::Kind::Binary);
}

TEST(PlogScale, TermSizeLimitNamesTheOperator) {
  const std::string text = "s = {1..3}.\np : s -> boolean.\nq : s -> boolean.\np(X) :- q(Y), X = " +
                           flatSum(10002, "Y") + ".\n";
  try {
    parseProgram(text, "big.plog");
    FAIL() << "a term with 10001 operators was accepted";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.location().file, "big.plog");
    EXPECT_EQ(e.location().line, 4);
    EXPECT_NE(std::string(e.what()).find("term too large"), std::string::npos) << e.what();
  }
  // at the limit it is read
  const std::string ok = "s = {1..3}.\np : s -> boolean.\nq : s -> boolean.\np(X) :- q(Y), X = " +
                         flatSum(10001, "Y") + ".\n";
  EXPECT_NO_THROW(parseProgram(ok, "ok.plog"));
}

TEST(PlogScale, ManyFactsAndLongRuleChainsAreRead) {
  // 50000 distinct 0-ary facts (50000 implicit predicates) and a 20000-rule chain: both were
  // quadratic (16000 facts: 3.2 s). A generous bound, not a timing: quadratic would need minutes.
  Stopwatch sw;
  Reasoner r;
  r.loadString(facts(50000) + "?{q49999}.\n", "facts.plog");
  EXPECT_EQ(r.program().attributes.size(), 50000u + 0u);
  EXPECT_DOUBLE_EQ(r.probability(r.program().queries.at(0)), 1.0);
  std::string chain;
  for (int i = 0; i < 20000; ++i)
    chain += "b" + std::to_string(i) + " :- b" + std::to_string(i + 1) + ".\n";
  chain += "b20000.\n?{b0}.\n";
  Reasoner c;
  c.loadString(chain, "chain.plog");
  EXPECT_DOUBLE_EQ(c.probability(c.program().queries.at(0)), 1.0);
  EXPECT_LT(sw.seconds(), 60.0);
}

TEST(PlogScale, ParsingOverTheMemoryBudgetIsABudgetError) {
  ParseOptions o;
  o.memory_budget = 4u << 20;  // 4 MiB: 200000 facts need far more
  try {
    parseProgram(facts(200000), "many.plog", Dialect::Auto, o);
    FAIL() << "no budget error";
  } catch (const BudgetExceededError& e) {
    const std::string w = e.what();
    EXPECT_EQ(w.rfind("many.plog:", 0), 0u) << w;
    EXPECT_NE(w.find("memory budget of 4 MiB exhausted while"), std::string::npos) << w;
  }
  // with the default budget the same text is read
  EXPECT_NO_THROW(parseProgram(facts(200000), "many.plog"));
}

TEST(PlogScale, GroundingOverTheMemoryBudgetIsABudgetErrorNamingTheStatement) {
  // `any` reads every one of the 2300^2 instances of p: its relevance cone is all of them
  // (a query about one instance grounds that one only: answered below, on the same budget)
  const std::string text =
      "n = {1..2300}.\np : n, n -> boolean.\n[r] random(p(X,Y)).\nany : boolean.\n"
      "any :- p(X, Y) = true.\n?{any}.\n?{p(1,1)=true}.\n";
  Reasoner r;
  GroundingLimits lim;
  lim.max_ground_atoms = 0;  // only the memory budget stops it
  lim.max_ground_statements = 0;
  lim.memory_budget = 32u << 20;
  r.setLimits(lim);
  r.setBackend(Backend::Native);
  r.loadString(text, "rel.plog");
  try {
    r.probability(r.program().queries.at(0));
    FAIL() << "no budget error";
  } catch (const BudgetExceededError& e) {
    const std::string w = e.what();
    EXPECT_EQ(w.rfind("rel.plog:3:", 0), 0u) << w;  // the selection rule being ground
    EXPECT_NE(w.find("exhausted while grounding"), std::string::npos) << w;
  }
  EXPECT_NEAR(r.probability(r.program().queries.at(1)), 0.5, 1e-12);
}

TEST(PlogScale, MemoryGuardCountsWhatIsAboutToBeAllocated) {
  MemoryGuard g(1u << 20);
  EXPECT_NO_THROW(g.check("testing", SourceLocation{"f", 1, 2}, 1000));
  try {
    g.check("testing", SourceLocation{"f", 1, 2}, 2u << 20);
    FAIL();
  } catch (const BudgetExceededError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("f:1:2: memory budget of 1 MiB exhausted while testing", 0),
              0u)
        << e.what();
  }
}

namespace {
std::string dice(const std::string& pa) {
  return "v = {a, b, c}.\nx : v.\n[r] random(x).\npr(x=a) = " + pa +
         ".\npr(x=b) = 0.25.\npr(x=c) = 0.25.\n?{x=a}.\n";
}
}  // namespace

TEST(PlogScale, ProbabilitySumsWithinRoundingAreRenormalisedWithAWarning) {
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(dice("0.5000000001"), "round.plog");
  EXPECT_TRUE(r.warnings().empty());
  const double p = r.probability(r.program().queries.at(0));
  EXPECT_NEAR(p, 0.5000000001 / 1.0000000001, 1e-15);
  ASSERT_EQ(r.warnings().size(), 1u);
  EXPECT_EQ(r.warnings()[0].rfind("round.plog:4:1: warning:", 0), 0u) << r.warnings()[0];
  EXPECT_NE(r.warnings()[0].find("renormalised"), std::string::npos);
}

// The ASP back end renormalised nothing and said nothing (the world measure kept 1.0000000001):
// it now repairs and reports as the native engine does, in the same words.
TEST(PlogScale, TheAspBackEndRenormalisesAndReportsSumsWithinRounding) {
  Reasoner native, asp;
  native.setBackend(Backend::Native);
  asp.setBackend(Backend::Asp);
  for (Reasoner* r : {&native, &asp}) r->loadString(dice("0.5000000001"), "round.plog");
  const double p = asp.probability(asp.program().queries.at(0));
  EXPECT_NEAR(p, 0.5000000001 / 1.0000000001, 1e-15);
  native.probability(native.program().queries.at(0));
  ASSERT_EQ(asp.warnings().size(), 1u);
  EXPECT_EQ(asp.warnings(), native.warnings());
  const std::string q = "?{x=b} | obs(x <> c)";
  EXPECT_NEAR(asp.probability(q), 0.25 / 0.7500000001, 1e-15);
  EXPECT_EQ(asp.warnings().size(), 1u);  // once
}

TEST(PlogScale, ProbabilitySumsOffByMoreThanRoundingAreRefusedWithTheirLocations) {
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(dice("0.500001"), "off.plog");
  try {
    r.probability(r.program().queries.at(0));
    FAIL() << "sum 1.000001 accepted";
  } catch (const IncoherentError& e) {
    EXPECT_NE(std::string(e.what()).find("off.plog:4:1"), std::string::npos) << e.what();
  }
}

// Every possible value assigned and the sum below 1 by more than rounding: the missing mass
// would belong to no value, so the world's measure silently shrank (0.49 + 0.25 + 0.25 was
// answered 0.49 / 0.99 = 0.4949 by both back ends). Refused like a sum above 1, by both.
TEST(PlogScale, ProbabilitySumsBelowOneOverEveryValueAreRefusedByBothBackEnds) {
  for (Backend b : {Backend::Native, Backend::Asp}) {
    Reasoner r;
    r.setBackend(b);
    r.loadString(dice("0.49"), "short.plog");
    try {
      const double p = r.probability(r.program().queries.at(0));
      ADD_FAILURE() << backendName(b) << ": sum 0.99 over every value answered " << p;
    } catch (const IncoherentError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("all the possible values of x sum to 0.99"), std::string::npos) << m;
      EXPECT_NE(m.find("short.plog:4:1"), std::string::npos) << m;
    }
  }
}

// Below 1 within rounding over every value: renormalised and reported; below 1 with a value
// left unassigned: the rest is that value's, no repair and no warning.
TEST(PlogScale, ProbabilitySumsBelowOneWithinRoundingOrWithFreeValuesAreAnswered) {
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(dice("0.4999999999"), "round.plog");
  EXPECT_NEAR(r.probability(r.program().queries.at(0)), 0.4999999999 / 0.9999999999, 1e-15);
  ASSERT_EQ(r.warnings().size(), 1u);
  EXPECT_NE(r.warnings()[0].find("renormalised"), std::string::npos) << r.warnings()[0];
  for (Backend b : {Backend::Native, Backend::Asp}) {
    Reasoner free;
    free.setBackend(b);
    free.loadString("v = {a, b, c}.\nx : v.\n[r] random(x).\npr(x=a) = 0.25.\npr(x=b) = 0.25.\n"
                    "?{x=c}.\n",
                    "free.plog");
    EXPECT_NEAR(free.probability(free.program().queries.at(0)), 0.5, 1e-15) << backendName(b);
    EXPECT_TRUE(free.warnings().empty()) << backendName(b);
  }
}

// A part of a probability that does not fit a double: 10^400 / (2 * 10^400) was inf / inf =
// nan, refused as "outside [0,1]"; 1 / 10^400 was silently 0. Refused at the number's token.
TEST(PlogScale, ProbabilityNumbersBeyondADoubleAreRefusedAtTheirToken) {
  const std::string big = "1" + std::string(400, '0'), big2 = "2" + std::string(400, '0');
  const std::string head = "v = {a, b}.\nx : v.\n[r] random(x).\n";
  for (const auto& [pr, col] : {std::pair<std::string, std::string>{big + "/" + big2, "11"},
                                {"1/" + big, "13"}}) {
    try {
      parseProgram(head + "pr(x=a) = " + pr + ".\n", "big.plog");
      ADD_FAILURE() << pr.substr(0, 50) << " accepted";
    } catch (const ParseError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.rfind("big.plog:4:" + col + ": number ", 0), 0u) << m;
      EXPECT_NE(m.find("too large for a double"), std::string::npos) << m;
    }
  }
}

TEST(PlogScale, ExactDecimalsNeedNoRepair) {
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString("v = {a, b, c}.\nx : v.\n[r] random(x).\npr(x=a) = 0.1.\npr(x=b) = 0.2.\n"
               "pr(x=c) = 0.7.\n?{x=a}.\n",
               "exact.plog");
  EXPECT_NEAR(r.probability(r.program().queries.at(0)), 0.1, 1e-15);
  EXPECT_TRUE(r.warnings().empty());
}
