// Incoherence and unsupported-construct errors: typed, naming what and where.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"
#include "krr_core/plog/asp_backend.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

namespace {
std::string errorOf(Reasoner& r, const std::string& query) {
  try {
    r.probability(query);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

// pr(c=r) = 0.7 and pr(c=g | x = a) = 0.5 sum to 1.2 in the worlds where x = a.
TEST(PlogErrors, AssignedProbabilitiesAboveOne) {
  Reasoner r;
  r.loadString(R"(c = {r, g, b}.
s = {a, b}.
col : c. x : s.
random(x). random(col).
pr(col = r) = 0.7.
pr(col = g | x = a) = 0.5.
)",
               "sum.plog");
  std::string e;
  try {
    r.probability("?{col = b}");
  } catch (const IncoherentError& ex) {
    e = ex.what();
  }
  EXPECT_NE(e.find("col"), std::string::npos) << e;
  EXPECT_NE(e.find("sum to 1.2"), std::string::npos) << e;
  EXPECT_NE(e.find("sum.plog:5:1"), std::string::npos) << e;
  EXPECT_NE(e.find("sum.plog:6:1"), std::string::npos) << e;
  // when x = b is forced the offending pr-atom no longer applies: coherent, P(col=g)=0.15
  EXPECT_NEAR(r.probability("?{col = g} | do(x = b)"), 0.15, 1e-12);
}

TEST(PlogErrors, ProbabilityOutsideUnitInterval) {
  Reasoner r;
  EXPECT_THROW(r.loadString("s = {a, b}. x : s. random(x). pr(x = a) = 3/2."), IncoherentError);
  EXPECT_THROW(r.loadString("s = {a, b}. x : s. random(x). pr(x = a) = 1.5."), IncoherentError);
}

// obs(col = b) when b gets probability 0 (pr(r) + pr(g) = 1): evidence of probability zero.
TEST(PlogErrors, ZeroProbabilityEvidence) {
  Reasoner r;
  r.loadString("c = {r, g, b}. col : c. random(col). pr(col = r) = 0.5. pr(col = g) = 0.5.",
               "zero.plog");
  try {
    r.probability("?{col = r} | obs(col = b)");
    FAIL();
  } catch (const IncoherentError& e) {
    EXPECT_NE(std::string(e.what()).find("probability zero"), std::string::npos) << e.what();
  }
  // contradictory observations
  EXPECT_THROW(r.probability("?{col = r} | obs(col = r), obs(col = g)"), IncoherentError);
}

TEST(PlogErrors, UndeclaredAttributeOrRange) {
  Reasoner r;
  // attribute used without declaration (no range)
  try {
    r.loadString("s = {a}.\nrandom(x).", "undecl.plog");
    FAIL();
  } catch (const UnknownSymbolError& e) {
    EXPECT_NE(std::string(e.what()).find("undecl.plog:2:8"), std::string::npos) << e.what();
  }
  // range sort not declared
  EXPECT_THROW(r.loadString("x : colours.\nrandom(x)."), UnknownSymbolError);
  // query on an unknown attribute
  r.loadString("s = {a}. x : s. random(x).");
  EXPECT_THROW(r.probability("?{y = a}"), UnknownSymbolError);
  EXPECT_THROW(r.probability("?{x = zz}"), UnknownSymbolError);
  EXPECT_THROW(r.distribution("nothere"), UnknownSymbolError);
}

TEST(PlogErrors, EmptyDynamicRange) {
  Reasoner r;
  r.loadString(R"(s = {1..3}.
x : s. y : s.
random(x).
random(y : {Z : Z > X}) :- x = X.
)",
               "empty.plog");
  std::string e = errorOf(r, "?{y = 3}");
  EXPECT_NE(e.find("empty dynamic range"), std::string::npos) << e;
  EXPECT_NE(e.find("empty.plog:4:1"), std::string::npos) << e;
}

// The native engine names the construct that puts a program outside its fragment (with the
// default back end `auto`, such programs are answered through clingo: see the end).
TEST(PlogErrors, UnsupportedConstructsNamed) {
  Reasoner r;
  r.setBackend(Backend::Native);
  // non-stratified negation among static predicates
  r.loadString(R"(p : boolean. q : boolean. s = {a}. x : s. random(x).
p :- not q.
q :- not p.
)");
  std::string e = errorOf(r, "?{p}");
  EXPECT_NE(e.find("non-stratified"), std::string::npos) << e;
  EXPECT_NE(e.find("ASP back end"), std::string::npos) << e;
  // cyclic negation through random attributes
  r.loadString(R"(s = {a, b}. x : s. p : boolean. q : boolean.
random(x).
p :- x = a, not q.
q :- not p.
)");
  e = errorOf(r, "?{p}");
  EXPECT_NE(e.find("cyclic"), std::string::npos) << e;
  // a rule defining a random attribute
  r.loadString("s = {a, b}. x : s. random(x). x = a :- x = b.");
  e = errorOf(r, "?{x = a}");
  EXPECT_NE(e.find("fast path"), std::string::npos) << e;
  EXPECT_THROW(r.probability("?{x = a}"), OutsideFragmentError);
  {
    // The same three programs under `auto`. Static even loop: answer sets {p} and {q} in
    // every world, P(p) = 1/2. Loop through x: x = a gives {p} and {q}, x = b only {q}, so
    // P(p) = (1/2) / (3/2) = 1/3. x = a :- x = b removes the world x = b: P(x = a) = 1.
    Reasoner a;
    a.loadString("p : boolean. q : boolean. s = {a}. x : s. random(x).\np :- not q.\nq :- not p.\n");
    EXPECT_NEAR(a.probability("?{p}"), 0.5, 1e-12);
    a.loadString("s = {a, b}. x : s. p : boolean. q : boolean.\nrandom(x).\n"
                 "p :- x = a, not q.\nq :- not p.\n");
    EXPECT_NEAR(a.probability("?{p}"), 1.0 / 3.0, 1e-12);
    a.loadString("s = {a, b}. x : s. random(x). x = a :- x = b.");
    EXPECT_NEAR(a.probability("?{x = a}"), 1.0, 1e-12);
  }
  // do() on a static attribute
  r.loadString("s = {a, b}. x : s. y : s. random(x). y = a.");
  e = errorOf(r, "?{x = a} | do(y = b)");
  EXPECT_NE(e.find("do(y=b)"), std::string::npos) << e;
  // 'not' before an attribute equality
  EXPECT_THROW(r.loadString("s = {a}. x : s. y : s. p : boolean. random(x). random(y). "
                            "p :- not x = y."),
               Error);
}

TEST(PlogErrors, TwoSelectionRulesFiring) {
  Reasoner r;
  r.loadString(R"(s = {a, b}. x : s. y : s.
random(x).
random(y) :- x = a.
random(y) :- x != b.
)");
  EXPECT_THROW(r.probability("?{y = a}"), IncoherentError);
}

TEST(PlogErrors, ConflictingPrAtoms) {
  Reasoner r;
  r.loadString(R"(s = {a, b}. x : s. y : s.
random(x). random(y).
pr(y = a | x = a) = 0.3.
pr(y = a) = 0.4.
)");
  EXPECT_THROW(r.probability("?{y = a}"), IncoherentError);
}

// ---------------------------------------------------------------------------------------------
// Hostile input (issue 12): checked arithmetic, empty dynamic ranges, grounding budgets and
// queries without meaning. Each must end in a typed error naming file:line:col, never in a
// signal, a hang or a silently wrong answer.
// ---------------------------------------------------------------------------------------------

namespace {
// What the parser says about `text` ("" when it is accepted).
std::string parseErrorOf(const std::string& text, const std::string& name = "arith.plog") {
  try {
    parseProgram(text, name);
  } catch (const ParseError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(PlogHostile, ParserArithmeticIsChecked) {
  // INT64_MIN / -1 traps on x86 (SIGFPE) when computed with the hardware instruction
  std::string e = parseErrorOf("n = {(0-9223372036854775807-1)/(0-1)}.");
  EXPECT_NE(e.find("arith.plog:1:31: integer overflow"), std::string::npos) << e;
  e = parseErrorOf("n = {1, 9223372036854775807 + 1}.");
  EXPECT_NE(e.find("arith.plog:1:29: integer overflow"), std::string::npos) << e;
  e = parseErrorOf("n = {3037000500 * 3037000500}.");
  EXPECT_NE(e.find("integer overflow"), std::string::npos) << e;
  e = parseErrorOf("n = {0 - 9223372036854775807 - 2}.");
  EXPECT_NE(e.find("integer overflow"), std::string::npos) << e;
  e = parseErrorOf("n = {-(0-9223372036854775807-1)}.");
  EXPECT_NE(e.find("arith.plog:1:6: integer overflow"), std::string::npos) << e;
  e = parseErrorOf("n = {7 mod (1-1)}.");
  EXPECT_NE(e.find("arith.plog:1:8: division by zero"), std::string::npos) << e;
  // INT64_MIN mod -1 is 0 (also a trap with the hardware instruction)
  Program p = parseProgram("n = {(0-9223372036854775807-1) mod (0-1)}.", "m.plog");
  ASSERT_EQ(p.findSort("n")->values.size(), 1u);
  EXPECT_EQ(p.findSort("n")->values[0].value, 0);
}

TEST(PlogHostile, RangeSizeCannotOverflow) {
  std::string e = parseErrorOf("n = {-5000000000000000000..5000000000000000000}.", "range.plog");
  EXPECT_NE(e.find("range.plog:1:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("too large"), std::string::npos) << e;
  e = parseErrorOf("#n = -9223372036854775807..9223372036854775807.", "range.plog");
  EXPECT_NE(e.find("too large"), std::string::npos) << e;
  // a range ending at INT64_MAX terminates (x <= hi is always true there)
  Program p = parseProgram("n = {9223372036854775806..9223372036854775807}.", "max.plog");
  EXPECT_EQ(p.findSort("n")->values.size(), 2u);
  EXPECT_TRUE(p.findSort("n")->is_range);
  // unions of ranges are bounded as a whole
  e = parseErrorOf("#n = 1..1000000 + 1000001..1000005.", "union.plog");
  EXPECT_NE(e.find("more than 1000000 values"), std::string::npos) << e;
}

TEST(PlogHostile, GrounderArithmeticIsChecked) {
  Reasoner r;
  r.loadString(R"(n = {9223372036854775806..9223372036854775807}.
x : n. random(x).
q : n -> boolean.
q(Y) :- x = X, Y = X * 2.
)",
               "ground.plog");
  std::string e = errorOf(r, "?{q(9223372036854775807)}");
  EXPECT_NE(e.find("ground.plog:4:22: integer overflow in 'X*2'"), std::string::npos) << e;
  EXPECT_NE(e.find("statement at ground.plog:4:1"), std::string::npos) << e;
  // static evaluation, division and negation
  r.loadString(R"(n = {-9223372036854775807..-9223372036854775806}.
m : n -> boolean.
m(-9223372036854775807).
k(Y) :- m(X), Y = (X - 1) / (0 - 1).
)",
               "static.plog");
  e = errorOf(r, "?{k(1)}");
  EXPECT_NE(e.find("static.plog:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("integer overflow"), std::string::npos) << e;
}

TEST(PlogHostile, EmptyDynamicRangeInEveryWorld) {
  // no ok(X) holds: the selection rule always applies with no possible value (was SIGFPE)
  const std::string text = R"(s = {a, b, c}.
b : s.
ok : s -> boolean.
random(b : {X : ok(X)}).
)";
  Reasoner r;
  r.loadString(text, "every.plog");
  std::string e = errorOf(r, "?{b = a}");
  EXPECT_NE(e.find("every.plog:4:1: random attribute b has an empty dynamic range"),
            std::string::npos)
      << e;
  EXPECT_THROW(r.distribution("b"), IncoherentError);
  EXPECT_THROW(r.tableQuery("b", {}), IncoherentError);
  // the clingo back end agrees: incoherent, naming the random rule
  if (std::system("clingo --version > /dev/null 2>&1") == 0) {
    AspBackend asp;
    Program p = parseProgram(text, "every.plog");
    std::vector<std::string> errors;
    asp.probabilities(p, {parseQuery(p, "?{b = a}")}, &errors);
    ASSERT_EQ(errors.size(), 1u);
    EXPECT_NE(errors[0].find("every.plog:4:1"), std::string::npos) << errors[0];
  }
}

TEST(PlogHostile, EmptyDynamicRangeInSomeWorlds) {
  // ok(a) holds only when c = x: where c = y the range of b is empty
  const std::string text = R"(s = {a, b, c}.
t = {x, y}.
c : t.
b : s.
ok : s -> boolean.
random(c).
ok(a) :- c = x.
random(b : {X : ok(X)}).
)";
  Reasoner r;
  r.loadString(text, "some.plog");
  std::string e = errorOf(r, "?{b = a}");
  EXPECT_NE(e.find("some.plog:8:1: random attribute b has an empty dynamic range"),
            std::string::npos)
      << e;
  // evidence excluding the worlds with the empty range: answered
  EXPECT_NEAR(r.probability("?{b = a} | obs(c = x)"), 1.0, 1e-12);
  EXPECT_NEAR(r.probability("?{b = a} | do(c = x)"), 1.0, 1e-12);
  if (std::system("clingo --version > /dev/null 2>&1") == 0) {
    AspBackend asp;
    Program p = parseProgram(text, "some.plog");
    std::vector<std::string> errors;
    std::vector<double> v = asp.probabilities(
        p, {parseQuery(p, "?{b = a}"), parseQuery(p, "?{b = a} | obs(c = x)")}, &errors);
    ASSERT_EQ(errors.size(), 2u);
    EXPECT_NE(errors[0].find("some.plog:8:1"), std::string::npos) << errors[0];
    EXPECT_TRUE(errors[1].empty()) << errors[1];
    EXPECT_NEAR(v[1], 1.0, 1e-12);
  }
}

TEST(PlogHostile, GroundingStaysInDeclaredSorts) {
  // p(X + 1) :- p(X). used to count forever; outside sort n the atom is simply not ground
  Reasoner r;
  r.loadString(R"(n = {0..5}.
p : n -> boolean.
p(0).
p(X + 1) :- p(X).
)",
               "sorts.plog");
  Stopwatch sw;
  EXPECT_NEAR(r.probability("?{p(5)}"), 1.0, 1e-12);
  EXPECT_NEAR(r.probability("?{p(3)}"), 1.0, 1e-12);
  EXPECT_LT(sw.seconds(), 2.0);
}

TEST(PlogHostile, GroundingBudgetNamesTheRule) {
  // an implicitly declared predicate has no sort to stop at: the budget does
  const std::string text = "n = {0..5}.\np(0).\np(X + 1) :- p(X).\n";
  Reasoner r;
  GroundingLimits lim;
  lim.max_ground_atoms = 2000;
  r.setLimits(lim);
  r.loadString(text, "budget.plog");
  Stopwatch sw;
  std::string e;
  try {
    r.probability("?{p(3)}");
  } catch (const BudgetExceededError& ex) {
    e = ex.what();
  }
  EXPECT_NE(e.find("budget.plog:3:1: grounding budget exhausted"), std::string::npos) << e;
  EXPECT_NE(e.find("2000 ground atoms"), std::string::npos) << e;
  // the time budget, with the size budgets off
  lim.max_ground_atoms = 0;
  lim.max_ground_statements = 0;
  lim.max_ground_seconds = 0.3;
  r.setLimits(lim);
  e.clear();
  try {
    r.probability("?{p(3)}");
  } catch (const BudgetExceededError& ex) {
    e = ex.what();
  }
  EXPECT_NE(e.find("budget.plog:3:1: grounding time budget"), std::string::npos) << e;
  EXPECT_LT(sw.seconds(), 10.0);
  // the reasoner stays usable
  r.loadString("s = {a, b}. x : s. random(x).", "ok.plog");
  EXPECT_NEAR(r.probability("?{x = a}"), 0.5, 1e-12);
  // defaults are a few million atoms / statements
  EXPECT_GE(GroundingLimits().max_ground_atoms, 1000000u);
  EXPECT_GT(GroundingLimits().max_inference_seconds, 0.0);
}

TEST(PlogHostile, ContradictoryInterventions) {
  Reasoner r;
  r.loadString(R"(person = {john, bob}.
curr_person : person.
random(curr_person).
)",
               "do.plog");
  std::string e = errorOf(r, "?{curr_person = bob} | do(curr_person=bob), do(curr_person=john)");
  EXPECT_NE(e.find("contradictory interventions"), std::string::npos) << e;
  EXPECT_NE(e.find("do(curr_person=bob)"), std::string::npos) << e;
  EXPECT_NE(e.find("do(curr_person=john)"), std::string::npos) << e;
  EXPECT_THROW(r.distribution("curr_person", "do(curr_person=bob), do(curr_person=john)"),
               IncoherentError);
  // the same intervention twice is fine
  EXPECT_NEAR(r.probability("?{curr_person = bob} | do(curr_person=bob), do(curr_person=bob)"),
              1.0, 1e-12);
  // against a program-level do()
  r.loadString("person = {john, bob}. curr_person : person. random(curr_person).\n"
               "do(curr_person = john).\n",
               "do2.plog");
  e = errorOf(r, "?{curr_person = bob} | do(curr_person=bob)");
  EXPECT_NE(e.find("contradictory interventions"), std::string::npos) << e;
  EXPECT_NE(e.find("do2.plog:2:4"), std::string::npos) << e;
}

TEST(PlogHostile, UnknownConstantInQuery) {
  Reasoner r;
  r.loadString(R"(item = {coke, coffee}.
room = {room1, room2}.
person = {john, bob}.
curr_person : person.
curr_item : person -> item.
curr_room : person -> room.
random(curr_person). random(curr_item(P)). random(curr_room(P)).
request(I, R, P) :- curr_item(P)=I, curr_room(P)=R, curr_person=P.
edge(hall, lab).
)",
               "office.plog");
  // request is declared implicitly (untyped arguments): carol is in no sort and no statement
  std::string e = errorOf(r, "?{request(coke, room2, carol)}");
  EXPECT_NE(e.find("unknown value 'carol'"), std::string::npos) << e;
  EXPECT_NE(e.find("argument 3 of 'request'"), std::string::npos) << e;
  EXPECT_THROW(r.probability("?{curr_person = bob} | obs(request(coke, room9, bob))"),
               UnknownSymbolError);
  // typed positions: the parser's own "unknown value" error
  EXPECT_THROW(r.probability("?{curr_room(carol) = room2}"), UnknownSymbolError);
  EXPECT_THROW(r.probability("?{curr_room(bob) = room9}"), UnknownSymbolError);
  // known constants still answer, also constants that only statements mention
  EXPECT_NEAR(r.probability("?{request(coke, room2, bob)}"), 0.5 * 0.5 * 0.5, 1e-12);
  EXPECT_NEAR(r.probability("?{edge(hall, lab)}"), 1.0, 1e-12);
  EXPECT_NEAR(r.probability("?{edge(lab, hall)}"), 0.0, 1e-12);
}
