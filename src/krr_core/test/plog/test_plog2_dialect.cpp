// The plog2.0 dialect as the community writes it (issue 13, part 2). Every program here is our
// own; each expected value is derived by hand in its comment, and every query is answered by
// the default back end (auto) and by clingo (Backend::Asp), which must agree.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

namespace {
constexpr double kEps = 1e-9;

/// @brief P(query) from both back ends; the test fails when they differ.
double both(const std::string& program, const std::string& query) {
  Reasoner native;
  native.loadString(program, "prog.plog");
  Reasoner asp;
  asp.setBackend(Backend::Asp);
  asp.loadString(program, "prog.plog");
  const double a = native.probability(query);
  const double b = asp.probability(query);
  EXPECT_NEAR(a, b, kEps) << "auto and asp disagree on " << query;
  return a;
}

/// @brief The answer to the program's own (first) query from both back ends.
double bothOwnQuery(const std::string& program) {
  Reasoner native;
  native.loadString(program, "prog.plog");
  Reasoner asp;
  asp.setBackend(Backend::Asp);
  asp.loadString(program, "prog.plog");
  auto a = native.answerProgramQueries();
  auto b = asp.answerProgramQueries();
  EXPECT_EQ(a.size(), 1u);
  EXPECT_EQ(b.size(), 1u);
  if (a.empty() || b.empty()) return -1;
  EXPECT_NEAR(a[0].probability, b[0].probability, kEps);
  return a[0].probability;
}

/// @brief The program is refused with a ParseError at line:col.
void expectParseErrorAt(const std::string& program, int line, int col, const std::string& what) {
  try {
    parseProgram(program, "bad.plog");
    ADD_FAILURE() << "accepted; expected an error about " << what;
  } catch (const ParseError& e) {
    EXPECT_EQ(e.location().line, line) << e.what();
    EXPECT_EQ(e.location().column, col) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

/// @brief The program is refused with an error whose text starts with bad.plog:line:col.
void expectErrorAt(const std::string& program, int line, int col, const std::string& what) {
  const std::string where = "bad.plog:" + std::to_string(line) + ":" + std::to_string(col) + ":";
  try {
    parseProgram(program, "bad.plog");
    ADD_FAILURE() << "accepted; expected an error about " << what;
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(where, 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}
}  // namespace

// A user sort {true, false} (here `#bool`, as in the community's Blocks and Poker programs) is
// the boolean range, so bare atoms and `-p` work. Two fair coins: P(both) = 1/4,
// P(both = false) = 3/4; given one head, P(both) = P(c2 heads) = 1/2.
TEST(Plog2Dialect, UserBooleanSortWithBareAtoms) {
  const std::string p = R"(sorts
#bool = {true, false}.
#coin = {c1, c2}.
attributes
heads: #coin -> #bool.
both: #bool.
statements
random(heads(C)).
both :- heads(c1), heads(c2).
-both :- not both.
)";
  EXPECT_NEAR(both(p, "?{both}"), 0.25, kEps);
  EXPECT_NEAR(both(p, "?{both = false}"), 0.75, kEps);
  EXPECT_NEAR(both(p, "?{both} | obs(heads(c1))"), 0.5, kEps);
  // the declaration keeps the user's sort in the program, the range reads as boolean
  Program prog = parseProgram(p, "p.plog");
  ASSERT_NE(prog.findSort("bool"), nullptr);
  EXPECT_EQ(prog.findAttribute("heads")->range_sort, "boolean");
}

// obs(a, y, false): a four-sided die observed not to show 1 leaves {2, 3, 4}:
// P(high) = P(roll > 2) = 2/3. obs(high, true, true) leaves {3, 4}: P(roll = 3) = 1/2.
// do(roll, 4, true) fixes the roll: P(high) = 1.
TEST(Plog2Dialect, ThreeArgumentObsAndDo) {
  const std::string base = R"(sorts
#bool = {true, false}.
#face = 1..4.
attributes
roll: #face.
high: #bool.
statements
random(roll).
high :- roll = R, R > 2.
)";
  EXPECT_NEAR(bothOwnQuery(base + "obs(roll, 1, false).\n?high.\n"), 2.0 / 3.0, kEps);
  EXPECT_NEAR(bothOwnQuery(base + "obs(high, true, true).\n?roll = 3.\n"), 0.5, kEps);
  EXPECT_NEAR(bothOwnQuery(base + "do(roll, 4, true).\n?high.\n"), 1.0, kEps);
  // the same forms in a query condition
  EXPECT_NEAR(both(base, "?{high} | obs(roll, 1, false)"), 2.0 / 3.0, kEps);
  EXPECT_NEAR(both(base, "?{high} | do(roll, 1, true)"), 0.0, kEps);
  // an intervention cannot make a = y false
  expectParseErrorAt(base + "do(roll, 4, false).\n", 10, 13, "must be 'true'");
}

// plog2.0 lets a rule body test an observation. With obs(alarm, true, true) in the program
// `checked` holds in every world: P(checked) = 1. Without it, checked = false: P = 0, and the
// alarm stays a fair coin.
TEST(Plog2Dialect, ObservationTestedInRuleBody) {
  const std::string base = R"(sorts
#bool = {true, false}.
attributes
alarm: #bool.
checked: #bool.
statements
random(alarm).
checked :- obs(alarm, true, true).
checked = false :- not obs(alarm, true, true).
)";
  EXPECT_NEAR(bothOwnQuery(base + "obs(alarm, true, true).\n?checked.\n"), 1.0, kEps);
  EXPECT_NEAR(bothOwnQuery(base + "obs(alarm, true, false).\n?checked.\n"), 0.0, kEps);
  EXPECT_NEAR(both(base, "?{checked}"), 0.0, kEps);
  EXPECT_NEAR(both(base, "?{alarm}"), 0.5, kEps);
  // an observation made by the query would have to change the rules: refused, not misread
  Reasoner r;
  r.loadString(base, "prog.plog");
  EXPECT_THROW(r.probability("?{checked} | obs(alarm)"), Error);
  // do(...) in a body is read (see DoInRuleBodies); a conditional observation is refused
  // with its location
  expectParseErrorAt(base + "obs(alarm, true, true) :- alarm.\n", 10, 24, "must be a fact");
}

// Record sorts f(#s1, #s2) and variables nested in values. pick is uniform over the 4 records
// p(1,a) p(1,b) p(2,a) p(2,b): P(first_is_one) = 1/2, P(letter = a) = 1/2. With
// pr(pick = p(1,a)) = 1/2 the other three get 1/6 each: P(first_is_one) = 1/2 + 1/6 = 2/3 and
// P(letter = b) = 2/6 = 1/3.
TEST(Plog2Dialect, RecordSortsAndNestedVariables) {
  const std::string base = R"(sorts
#n = 1..2.
#c = {a, b}.
#pair = p(#n, #c).
#bool = {true, false}.
attributes
pick: #pair.
first_is_one: #bool.
letter: #c.
statements
random(pick).
first_is_one :- pick = p(1, X).
letter = X :- pick = p(N, X).
)";
  Program prog = parseProgram(base, "p.plog");
  ASSERT_NE(prog.findSort("pair"), nullptr);
  EXPECT_EQ(prog.findSort("pair")->values.size(), 4u);
  EXPECT_NEAR(both(base, "?{first_is_one}"), 0.5, kEps);
  EXPECT_NEAR(both(base, "?{letter = a}"), 0.5, kEps);
  const std::string biased = base + "pr(pick = p(1, a)) = 1/2.\n";
  EXPECT_NEAR(both(biased, "?{first_is_one}"), 2.0 / 3.0, kEps);
  EXPECT_NEAR(both(biased, "?{letter = b}"), 1.0 / 3.0, kEps);
  EXPECT_NEAR(both(biased, "?{pick = p(2, b)}"), 1.0 / 6.0, kEps);
}

// Sort expressions: + union, * intersection, - difference, parentheses, records in a union.
// #u = {1,2,3,4}: P(x = 4) = 1/4; #i = {2,3}: P(y = 3) = 1/2; #d = {1}: P(z = 1) = 1;
// #e = ({1,2,3} + {7}) - {2,3} = {1,7}: P(w = 7) = 1/2; #r = {f(1), g}: P(v = g) = 1/2.
TEST(Plog2Dialect, SortExpressions) {
  const std::string p = R"(sorts
#a = {1, 2, 3}.
#b = {2, 3, 4}.
#u = #a + #b.
#i = #a * #b.
#d = #a - #b.
#e = (#a + {7}) - #i.
#r = f(#d) + {g}.
attributes
x: #u.
y: #i.
z: #d.
w: #e.
v: #r.
statements
random(x). random(y). random(z). random(w). random(v).
)";
  Program prog = parseProgram(p, "p.plog");
  EXPECT_EQ(prog.findSort("u")->values.size(), 4u);
  EXPECT_EQ(prog.findSort("i")->values.size(), 2u);
  EXPECT_EQ(prog.findSort("d")->values.size(), 1u);
  EXPECT_EQ(prog.findSort("e")->values.size(), 2u);
  EXPECT_NEAR(both(p, "?{x = 4}"), 0.25, kEps);
  EXPECT_NEAR(both(p, "?{y = 3}"), 0.5, kEps);
  EXPECT_NEAR(both(p, "?{z = 1}"), 1.0, kEps);
  EXPECT_NEAR(both(p, "?{w = 7}"), 0.5, kEps);
  EXPECT_NEAR(both(p, "?{v = f(1)}"), 0.5, kEps);
}

// #const n = 3 in a range and in a body: x uniform over 1..3, P(x = n) = 1/3,
// P(big) = P(x >= n - 1) = 2/3. `#generation` is an ordinary sort name: P(gen = 2) = 1/2.
TEST(Plog2Dialect, ConstantsAndOrdinarySortNames) {
  const std::string p = R"(#const n = 3.
sorts
#step = 1..n.
#generation = {1, 2}.
#bool = {true, false}.
attributes
x: #step.
gen: #generation.
big: #bool.
statements
random(x). random(gen).
big :- x = X, X >= n - 1.
?x = n.
)";
  EXPECT_NEAR(bothOwnQuery(p), 1.0 / 3.0, kEps);
  EXPECT_NEAR(both(p, "?{big}"), 2.0 / 3.0, kEps);
  EXPECT_NEAR(both(p, "?{gen = 2}"), 0.5, kEps);
  expectParseErrorAt("#const n = 1.\n#const n = 2.\n", 2, 8, "defined twice");
}

// The error cases of plog2.0's test suite, written afresh: each is refused at file:line:col.
TEST(Plog2Dialect, ErrorsNameTheirLocation) {
  expectParseErrorAt("sorts\n#s = 2..1.\nattributes\nstatements\n", 2, 6, "empty range 2..1");
  expectParseErrorAt("sorts\n#s = {a}.\nattributes\nrandom: #s -> #s.\nstatements\n", 4, 1,
                     "coincides with a P-log keyword");
  expectParseErrorAt("sorts\n#s = {g(x)}.\nattributes\ng: #s -> #s.\nstatements\n", 4, 1,
                     "conflicts with the record g(x)");
  expectParseErrorAt("sorts\n#s = {a}.\n#t = g(#s).\nattributes\ng: #s -> #s.\nstatements\n", 5,
                     1, "conflicts with the record g(a)");
  // plog2.0 has no implicit predicates: an undeclared head is an error
  expectErrorAt("sorts\n#s = {a}.\nattributes\nx: #s.\nstatements\ny = true.\n", 6, 1,
                "undeclared attribute 'y'");
  // the classic dialect still declares predicates implicitly
  EXPECT_NO_THROW(parseProgram("s = {a}.\nx : s.\ny.\n", "ok.plog"));
}

// `h :+ body.` is read as a consistency-restoring rule (semantics in test_cr_rules.cpp), also
// right after the attributes where `a :` could start a declaration.
TEST(Plog2Dialect, ConsistencyRestoringRulesAreRead) {
  const std::string head = "sorts\n#bool = {true, false}.\nattributes\na: #bool.\nb: #bool.\n"
                           "statements\n";
  Program p = parseProgram(head + "a :+ b.\na:+.\nrandom(a) :+.\n", "cr.plog");
  ASSERT_EQ(p.rules.size(), 2u);
  EXPECT_TRUE(p.rules[0].consistency_restoring);
  EXPECT_EQ(p.rules[0].body.size(), 1u);
  EXPECT_TRUE(p.rules[1].consistency_restoring);
  EXPECT_TRUE(p.rules[1].body.empty());
  ASSERT_EQ(p.random_rules.size(), 1u);
  EXPECT_TRUE(p.random_rules[0].consistency_restoring);
  expectParseErrorAt(head + "a :+ b\n", 8, 1, "'.'");
}

// do(...) tested in a rule body (plog2.0's section3_notpublished/example6): the body literal
// holds for the argument tuples of the program's do statements; do(agent, f, y) with a
// first argument that is no attribute is the agent form: the agent sets f = y.
TEST(Plog2Dialect, DoInRuleBodies) {
  const std::string head =
      "sorts\n#boolean = {true, false}.\n#attribute_term = {f, g}.\n#agent = {a, b}.\n"
      "attributes\nalarm: #boolean.\nauthorized: #agent, #attribute_term -> #boolean.\n"
      "f: #boolean.\ng: #boolean.\nstatements\n"
      "alarm :- do(A, f, true), not authorized(A, f).\nrandom(f).\nrandom(g).\n";
  // do(a, f, true): f = true by intervention, and the body test holds for A = a (a is not
  // authorized): alarm in every world.
  EXPECT_NEAR(both(head + "do(a, f, true).\n", "?{alarm = true}"), 1.0, kEps);
  EXPECT_NEAR(both(head + "do(a, f, true).\n", "?{f = true}"), 1.0, kEps);
  // authorized(a, f): the rule never fires.
  EXPECT_NEAR(both(head + "do(a, f, true).\nauthorized(a, f).\n", "?{alarm = true}"), 0.0, kEps);
  // An action on g does not match do(A, f, true); f stays random (1/2).
  EXPECT_NEAR(both(head + "do(b, g, true).\n", "?{alarm = true}"), 0.0, kEps);
  EXPECT_NEAR(both(head + "do(b, g, true).\n", "?{f = true}"), 0.5, kEps);
}

// A fact whose constant is outside the declared sort (nasa/F.plog's misspelt
// `streering_sensor2`) has no well-sorted ground instance: P-log's sorted grounding, and
// plog2.0, leave it out. We do too, never silently: a warning names file:line:col and the value;
// strict sorts make it an error.
TEST(Plog2Dialect, IllSortedFactsAreLeftOutWithAWarning) {
  const std::string p =
      "sorts\n#boolean = {true, false}.\n#c = {x, y}.\n#k = 1..2.\nattributes\n"
      "link: #c, #c -> #boolean.\nkind: #c -> #k.\nup: #boolean.\nstatements\n"
      "link(x, y).\nlink(x, zz).\nkind(x) = 3.\nkind(y) = 2.\nrandom(up).\n";
  Reasoner r;
  r.loadString(p, "sorted.plog");
  ASSERT_EQ(r.warnings().size(), 2u);
  EXPECT_EQ(r.warnings()[0].rfind("sorted.plog:11:9: warning:", 0), 0u) << r.warnings()[0];
  EXPECT_NE(r.warnings()[0].find("'zz'"), std::string::npos) << r.warnings()[0];
  EXPECT_EQ(r.warnings()[1].rfind("sorted.plog:12:11: warning:", 0), 0u) << r.warnings()[1];
  EXPECT_NE(r.warnings()[1].find("'3'"), std::string::npos) << r.warnings()[1];
  // The well-sorted facts stay; kind(x) has no value (its only fact is left out).
  EXPECT_NEAR(both(p, "?{link(x, y)}"), 1.0, kEps);
  EXPECT_NEAR(both(p, "?{kind(y) = 2}"), 1.0, kEps);
  EXPECT_NEAR(both(p, "?{kind(x) = 1}"), 0.0, kEps);
  EXPECT_NEAR(both(p, "?{kind(x) = 2}"), 0.0, kEps);
  // Added statements warn too.
  r.addStatements("kind(y) = 7.\n", "", "more.plog");
  ASSERT_EQ(r.warnings().size(), 3u);
  EXPECT_EQ(r.warnings()[2].rfind("more.plog:1:11: warning:", 0), 0u) << r.warnings()[2];
  // Strict sorts: an error at the value.
  Reasoner strict;
  strict.setStrictSorts(true);
  try {
    strict.loadString(p, "sorted.plog");
    ADD_FAILURE() << "ill-sorted fact accepted with strict sorts";
  } catch (const UnknownSymbolError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("sorted.plog:11:9:", 0), 0u) << e.what();
  }
  ParseOptions o;
  o.strict_sorts = true;
  EXPECT_THROW(parseProgram(p, "sorted.plog", Dialect::Auto, o), UnknownSymbolError);
  // Values outside their sort elsewhere (queries) are still errors.
  EXPECT_THROW(r.probability("?{kind(zz) = 1}"), UnknownSymbolError);
}

// The classic dialect as the classic solver's examples write it (issue 13, part 3): #domain and
// declarations before the sorts they name, `a : s.` whose arity comes from use, labels with
// arguments, and one predicate name used with two arities. Each item is ann's with 3/4:
// P(has(bob)) = 1 - P(ann owns both) = 1 - 9/16 = 7/16; P(has(ann, i1)) = 3/4.
TEST(ClassicDialect, ExamplesAsTheClassicSolverWritesThem) {
  const std::string p = R"(#domain item(I).
#domain person(P).
owner : person.
item = {i1, i2}.
person = {ann, bob}.
[r(I)] random(owner(I)).
[r(I)] pr(owner(I) = ann) = 3/4.
has(P, I) :- owner(I) = P.
has(P) :- has(P, I).
?{has(bob)}.
)";
  EXPECT_NEAR(bothOwnQuery(p), 7.0 / 16.0, kEps);
  EXPECT_NEAR(both(p, "?{has(ann, i1)}"), 0.75, kEps);
  Program prog = parseProgram(p, "p.plog");
  ASSERT_EQ(prog.findAttribute("owner")->arg_sorts.size(), 1u);
  EXPECT_EQ(prog.findAttribute("owner")->arg_sorts[0], "item");
  // a sort that is never declared is still an error, at the place that names it
  expectErrorAt("#domain nowhere(X).\ns = {a}.\n", 1, 9, "unknown sort 'nowhere'");
  expectErrorAt("x : nowhere.\ns = {a}.\n", 1, 5, "unknown sort 'nowhere'");
}
