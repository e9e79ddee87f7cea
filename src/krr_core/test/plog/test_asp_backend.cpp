/**
 * @file test_asp_backend.cpp
 * @brief The clingo back end on small programs whose answers are derived by hand.
 *
 * Every expected value is derived in the comment next to it from the P-log semantics:
 * measure of a world = product over its randomly selected attribute terms of the assigned
 * probability of the value taken, or of the default (1 - assigned sum) / (unassigned count);
 * P(F | E) = measure of the worlds satisfying F and E / measure of those satisfying E.
 */
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/plog/asp_backend.h"
#include "krr_core/plog/parser.h"

namespace krr {
namespace plog {
namespace {

constexpr double kEps = 1e-12;

Program load(const std::string& name) {
  const std::string path = std::string(KRR_TEST_DATA_DIR) + "/plog/asp/" + name;
  return parseProgram(readFile(path), path);
}

double ask(AspBackend& b, const Program& p, const std::string& query) {
  return b.probability(p, parseQuery(p, query));
}

TEST(AspBackend, MontyHallSwitchingWinsTwoThirds) {
  // prize, selected uniform (1/3 each); open uniform over the doors that are neither.
  // selected=1: prize=1 -> open in {2,3}, 1/2 each; prize=2 -> open=3; prize=3 -> open=2.
  // P(prize=2, open=3 | sel=1) = 1/3 * 1 = 1/3; P(prize=1, open=3 | sel=1) = 1/3 * 1/2 = 1/6.
  // P(prize=2 | sel=1, open=3) = (1/3) / (1/3 + 1/6) = 2/3, P(prize=1 | ...) = 1/3.
  Program p = load("monty_hall.plog");
  AspBackend b;
  std::vector<double> r = b.answerQueries(p);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_NEAR(r[0], 2.0 / 3.0, kEps);
  EXPECT_NEAR(r[1], 1.0 / 3.0, kEps);
  // Both queries share their (empty) interventions and their evidence: one clingo run, in
  // which the evidence is a constraint, so only the worlds satisfying it are enumerated
  // (selected = 1, open = 3: prize = 1 or 2), not all 3*2 + 6*1 = 12.
  EXPECT_EQ(b.stats().clingo_runs, 1u);
  EXPECT_EQ(b.stats().worlds, 2u);
}

TEST(AspBackend, MontyHallDistribution) {
  Program p = load("monty_hall.plog");
  AspBackend b;
  Query ev = parseQuery(p, "?{prize = 1} | obs(selected = 1), obs(open = 3)");
  auto d = b.distribution(p, parseAttributeTerm(p, "prize"), ev.observations);
  ASSERT_EQ(d.size(), 3u);
  EXPECT_EQ(d[0].first, "1");
  EXPECT_EQ(d[2].first, "3");
  EXPECT_NEAR(d[0].second, 1.0 / 3.0, kEps);
  EXPECT_NEAR(d[1].second, 2.0 / 3.0, kEps);
  EXPECT_NEAR(d[2].second, 0.0, kEps);  // the host never opens the prize door
}

TEST(AspBackend, ReasonerShapedEntryPoints) {
  // Same Monty Hall answers through the text entry points.
  Program p = load("monty_hall.plog");
  AspBackend b;
  EXPECT_NEAR(b.probability(p, "?{prize = 2} | obs(selected = 1), obs(open = 3)"), 2.0 / 3.0,
              kEps);
  std::vector<ValueProb> d = b.distribution(p, "prize", "obs(selected = 1), obs(open = 3)");
  ASSERT_EQ(d.size(), 2u);  // prize = 3 has probability 0 and is left out
  EXPECT_EQ(d[0].value, "1");
  EXPECT_NEAR(d[0].probability, 1.0 / 3.0, kEps);
  EXPECT_EQ(d[1].value, "2");
  EXPECT_NEAR(d[1].probability, 2.0 / 3.0, kEps);
  // do(open = 3) cuts the host's choice: the prize stays uniform.
  d = b.distribution(p, "prize", "obs(selected = 1), do(open = 3)");
  ASSERT_EQ(d.size(), 3u);
  EXPECT_NEAR(d[2].probability, 1.0 / 3.0, kEps);
  std::vector<QueryAnswer> a = b.answerProgramQueries(p);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_NEAR(a[1].probability, 1.0 / 3.0, kEps);
  EXPECT_FALSE(a[1].query.empty());
}

TEST(AspBackend, Plog2DialectWithProgramEvidence) {
  // The same game in plog2.0 syntax (random(open, can_open): dynamic range by predicate),
  // evidence obs(selected = 1), obs(open = 3) in the program: P(prize = 2) = 2/3.
  Program p = load("monty_hall_plog2.plog");
  AspBackend b;
  std::vector<double> r = b.answerQueries(p);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_NEAR(r[0], 2.0 / 3.0, kEps);
}

TEST(AspBackend, BiasedDice) {
  // roll(d1): pr(6) = 1/4 assigned, the 5 other values share 3/4: 3/20 each.
  // roll(d2): no pr-atom applies (owner john): 1/6 each.
  Program p = load("dice.plog");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{roll(d1) = 6}"), 0.25, kEps);
  EXPECT_NEAR(ask(b, p, "?{roll(d1) = 1}"), 3.0 / 20.0, kEps);
  EXPECT_NEAR(ask(b, p, "?{roll(d2) = 6}"), 1.0 / 6.0, kEps);
  // even(d1): 6 (1/4) + 2, 4 (3/20 each) = 11/20.
  EXPECT_NEAR(ask(b, p, "?{even(d1)}"), 11.0 / 20.0, kEps);
  // P(roll(d1)=6 | even(d1)) = (1/4) / (11/20) = 5/11.
  EXPECT_NEAR(ask(b, p, "?{roll(d1) = 6} | obs(even(d1))"), 5.0 / 11.0, kEps);
  // Independence: P(both 6) = 1/4 * 1/6 = 1/24.
  EXPECT_NEAR(ask(b, p, "?{roll(d1) = 6, roll(d2) = 6}"), 1.0 / 24.0, kEps);
  // Strong negation in the formula: P(roll(d1) != 6) = 3/4.
  EXPECT_NEAR(ask(b, p, "?{roll(d1) != 6}"), 0.75, kEps);
}

TEST(AspBackend, DynamicRange) {
  // a uniform on {1..4}; b uniform on {a..4}: P(b=4 | a) = 1/(5-a).
  // P(b=4) = 1/4 (1/4 + 1/3 + 1/2 + 1) = 1/4 * 25/12 = 25/48.
  // P(a=4 | b=4) = (1/4 * 1) / (25/48) = 12/25; P(a=1 | b=1) = 1 (b=1 needs a=1).
  // P(b=1) = 1/4 * 1/4 = 1/16.
  Program p = load("dynamic_range.plog");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{b = 4}"), 25.0 / 48.0, kEps);
  EXPECT_NEAR(ask(b, p, "?{a = 4} | obs(b = 4)"), 12.0 / 25.0, kEps);
  EXPECT_NEAR(ask(b, p, "?{a = 1} | obs(b = 1)"), 1.0, kEps);
  EXPECT_NEAR(ask(b, p, "?{b = 1}"), 1.0 / 16.0, kEps);
}

TEST(AspBackend, DynamicRangeUsingSelectionBodyVariables) {
  // y is drawn uniformly among the values above x: x uniform on {1, 2, 3};
  // x = 1: y in {2, 3}; x = 2: y = 3; x = 3: empty range (incoherent world).
  // P(y = 3 | x = 1) = 1/2, P(y = 3 | x = 2) = 1; obs(x = 3) meets the empty range.
  Program p = parseProgram(R"(
s = {1..3}.
x : s.
y : s.
random(x).
random(y : {Z : Z > X}) :- x = X.
)", "<above>");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{y = 3} | obs(x = 1)"), 0.5, kEps);
  EXPECT_NEAR(ask(b, p, "?{y = 3} | obs(x = 2)"), 1.0, kEps);
  EXPECT_THROW(ask(b, p, "?{y = 3} | obs(x = 3)"), IncoherentError);
  EXPECT_THROW(ask(b, p, "?{y = 3}"), IncoherentError);
}

TEST(AspBackend, DefaultThroughNot) {
  // broken: 1/10. light=on: 9/10 when not broken; when broken no pr-atom applies: 1/2.
  // P(on) = 9/10 * 9/10 + 1/10 * 1/2 = 0.81 + 0.05 = 0.86.
  // P(broken | off) = (1/10 * 1/2) / (9/10 * 1/10 + 1/10 * 1/2) = 0.05 / 0.14 = 5/14.
  Program p = load("light.plog");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{light = on}"), 0.86, kEps);
  EXPECT_NEAR(ask(b, p, "?{broken} | obs(light = off)"), 5.0 / 14.0, kEps);
  EXPECT_NEAR(ask(b, p, "?{broken} | obs(light != on)"), 5.0 / 14.0, kEps);
}

TEST(AspBackend, DoIsNotObs) {
  // pr(x) = 0.3, pr(y | x) = 0.9, pr(y | -x) = 0.2.
  // Observing y: P(x | y) = 0.3*0.9 / (0.3*0.9 + 0.7*0.2) = 0.27 / 0.41 = 27/41.
  // Setting y cuts its random selection: P(x | do(y)) = P(x) = 0.3.
  // Setting x: P(y | do(x)) = 0.9, P(y | do(x = false)) = 0.2.
  Program p = load("do_obs.plog");
  AspBackend b;
  std::vector<Query> qs = {parseQuery(p, "?{x} | obs(y)"), parseQuery(p, "?{x} | do(y)"),
                           parseQuery(p, "?{y} | do(x)"), parseQuery(p, "?{y} | do(x = false)"),
                           parseQuery(p, "?{x} | obs(y = false)")};
  std::vector<double> r = b.probabilities(p, qs);
  EXPECT_NEAR(r[0], 27.0 / 41.0, kEps);
  EXPECT_NEAR(r[1], 0.3, kEps);
  EXPECT_NEAR(r[2], 0.9, kEps);
  EXPECT_NEAR(r[3], 0.2, kEps);
  // P(x | -y) = 0.3*0.1 / (0.3*0.1 + 0.7*0.8) = 0.03 / 0.59 = 3/59.
  EXPECT_NEAR(r[4], 3.0 / 59.0, kEps);
  // Four intervention sets ({} for queries 0 and 4, {y}, {x}, {x=false}) in one multi-shot
  // clingo process; without multi-shot, one process per set gives the same answers.
  EXPECT_EQ(b.stats().clingo_runs, 1u);
  AspOptions single;
  single.multi_shot = false;
  AspBackend s(single);
  std::vector<double> r2 = s.probabilities(p, qs);
  EXPECT_EQ(s.stats().clingo_runs, 4u);
  for (std::size_t i = 0; i < r.size(); ++i) EXPECT_NEAR(r[i], r2[i], kEps);
  // The last intervention set has no possible world (x set to two values): the earlier
  // sets' answers survive it.
  std::vector<Query> q2 = {parseQuery(p, "?{x} | obs(y)"),
                           parseQuery(p, "?{y} | do(x), do(x = false)")};
  std::vector<std::string> errors;
  std::vector<double> r3 = b.probabilities(p, q2, &errors);
  EXPECT_NEAR(r3[0], 27.0 / 41.0, kEps);
  EXPECT_TRUE(errors[0].empty());
  EXPECT_NE(errors[1].find("no possible world"), std::string::npos) << errors[1];
}

TEST(AspBackend, FallsBackWhenClingoLacksLua) {
  // A wrapper that refuses scripts, as a clingo built without Lua would.
  char pattern[] = "/tmp/krr_asp_nolua_XXXXXX";
  ASSERT_NE(mkdtemp(pattern), nullptr);
  const std::string wrapper = std::string(pattern) + "/clingo";
  {
    std::ofstream f(wrapper);
    f << "#!/bin/sh\nfor a in \"$@\"; do f=\"$a\"; done\n"
         "if grep -q '#script' \"$f\"; then echo 'error: lua scripting not supported' >&2; "
         "exit 65; fi\nexec clingo \"$@\"\n";
  }
  std::filesystem::permissions(wrapper, std::filesystem::perms::owner_all);
  AspOptions o;
  o.clingo_path = wrapper;
  AspBackend b(o);
  Program p = load("do_obs.plog");
  std::vector<Query> qs = {parseQuery(p, "?{x} | obs(y)"), parseQuery(p, "?{x} | do(y)")};
  std::vector<double> r = b.probabilities(p, qs);
  EXPECT_NEAR(r[0], 27.0 / 41.0, kEps);
  EXPECT_NEAR(r[1], 0.3, kEps);
  // After the failed multi-shot attempt (not counted: it produced no answer sets), one run
  // per intervention set; later calls go straight to one run per set.
  EXPECT_EQ(b.stats().clingo_runs, 2u);
  b.probabilities(p, qs);
  EXPECT_EQ(b.stats().clingo_runs, 4u);
  std::filesystem::remove_all(pattern);
}

TEST(AspBackend, ProgramLevelObsAndDo) {
  // The same program with the evidence written in it.
  Program p = load("do_obs.plog");
  parseInto(p, "obs(y).", "<extra>");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{x}"), 27.0 / 41.0, kEps);
  Program d = load("do_obs.plog");
  parseInto(d, "do(y).", "<extra>");
  EXPECT_NEAR(ask(b, d, "?{x}"), 0.3, kEps);
  EXPECT_NEAR(ask(b, d, "?{y}"), 1.0, kEps);
}

TEST(AspBackend, EvenLoopNonStratified) {
  // c = h with 3/10. The loop p :- not q. q :- not p. gives two worlds per value of c:
  //   c=h: {p, r}, {q, r}  (measure 0.3 each);  c=t: {p}, {q, r}  (0.7 each). Total 2.0.
  // P(r) = (0.3 + 0.3 + 0.7) / 2 = 0.65; P(c=h | r) = 0.6 / 1.3 = 6/13; P(p) = 1/2;
  // P(c=h | p, r) = 0.3 / 0.3 = 1.
  Program p = load("even_loop.plog");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{r}"), 0.65, kEps);
  EXPECT_NEAR(ask(b, p, "?{c = h} | obs(r)"), 6.0 / 13.0, kEps);
  EXPECT_NEAR(ask(b, p, "?{p}"), 0.5, kEps);
  EXPECT_NEAR(ask(b, p, "?{c = h} | obs(p), obs(r)"), 1.0, kEps);
  // A loop that only exists when c = h: c=h gives {p}, {q} (0.3 each), c=t gives {q} (0.7).
  // The number of worlds matters in P-log: P(c=h) = 0.6 / 1.3 = 6/13.
  Program p2 = parseProgram(R"(
coin = {h, t}.
c : coin.
p : boolean.
q : boolean.
random(c).
pr(c = h) = 3/10.
p :- not q, c = h.
q :- not p.
)", "<loop>");
  EXPECT_NEAR(ask(b, p2, "?{c = h}"), 6.0 / 13.0, kEps);
}

TEST(AspBackend, ConstraintConditionsAncestors) {
  // c uniform on {h, t}; d :- c = h; the constraint :- d removes the world c = h, so
  // P(c = h) = 0 and P(c = t) = 1 although c does not depend on d.
  // With pr(c = h) = 3/10 and a second coin e (uniform) and :- d, e = t: the world
  // (h, t) is removed: P(c = h) = 0.3*0.5 / (0.3*0.5 + 0.7) = 0.15 / 0.85 = 3/17.
  Program p = parseProgram(R"(
coin = {h, t}.
c : coin.
d : boolean.
random(c).
d :- c = h.
:- d.
)", "<constraint>");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{c = h}"), 0.0, kEps);
  EXPECT_NEAR(ask(b, p, "?{c = t}"), 1.0, kEps);
  Program p2 = parseProgram(R"(
coin = {h, t}.
c : coin.
e : coin.
d : boolean.
random(c).
random(e).
pr(c = h) = 3/10.
d :- c = h.
:- d, e = t.
)", "<constraint2>");
  EXPECT_NEAR(ask(b, p2, "?{c = h}"), 3.0 / 17.0, kEps);
}

TEST(AspBackend, TwoDerivedValuesMakeAWorldInconsistent) {
  // d = 1 always, d = 2 when c = h: the world c = h gives d two values and is no possible
  // world. P(c = h) = 0, P(d = 1) = 1.
  Program p = parseProgram(R"(
coin = {h, t}.
n = {1, 2}.
c : coin.
d : n.
random(c).
d = 1.
d = 2 :- c = h.
)", "<two values>");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{c = h}"), 0.0, kEps);
  EXPECT_NEAR(ask(b, p, "?{d = 1}"), 1.0, kEps);
}

TEST(AspBackend, ArithmeticInRuleHeads) {
  // A robot on cells 0..3 moves right: next = C + 1. For C = 3 the instance next = 4 is
  // ill-typed (4 is not a cell) and not part of the ground program; next = 3 :- curr = 3
  // keeps it at the wall. curr uniform: P(next = 3) = P(curr in {2, 3}) = 1/2,
  // P(next = 1) = P(curr = 0) = 1/4, P(next = 0) = 0. (Were next = 4 derived, it would clash
  // with next = 3 and remove the world curr = 3: P(next = 3) would be 1/3.)
  Program p = parseProgram(R"(
cell = {0..3}.
curr : cell.
next : cell.
random(curr).
next = C + 1 :- curr = C.
next = 3 :- curr = 3.
)", "<arith>");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{next = 3}"), 0.5, kEps);
  EXPECT_NEAR(ask(b, p, "?{next = 1}"), 0.25, kEps);
  EXPECT_NEAR(ask(b, p, "?{next = 0}"), 0.0, kEps);
  EXPECT_NE(b.translate(p).find("sort(cell,VC+1)"), std::string::npos) << b.translate(p);
}

TEST(AspBackend, LabelsAndVariablesInPrAtoms) {
  // pr-atom with a variable value restricted by a body: pr(a(X) = Y | Y = X) = 1/2 for the
  // selection rule labelled r only. a(1): 1 gets 1/2, {2, 3} share 1/2: 1/4 each.
  // b(X) is selected by an unlabelled rule: the labelled pr-atom does not apply: 1/3 each.
  Program p = parseProgram(R"(
n = {1..3}.
a : n -> n.
b : n -> n.
[r] random(a(X)).
random(b(X)).
[r] pr(a(X) = Y | Y = X) = 1/2.
)", "<labels>");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{a(1) = 1}"), 0.5, kEps);
  EXPECT_NEAR(ask(b, p, "?{a(1) = 3}"), 0.25, kEps);
  EXPECT_NEAR(ask(b, p, "?{a(2) = 2, a(3) = 1}"), 0.5 * 0.25, kEps);
  EXPECT_NEAR(ask(b, p, "?{b(1) = 1}"), 1.0 / 3.0, kEps);
}

TEST(AspBackend, AssignedSumAboveOneIsIncoherent) {
  Program p = parseProgram(R"(
coin = {h, t}.
c : coin.
random(c).
pr(c = h) = 7/10.
pr(c = t) = 6/10.
)", "<bad>");
  AspBackend b;
  EXPECT_THROW(ask(b, p, "?{c = h}"), IncoherentError);
}

TEST(AspBackend, ConflictingPrAtomsAreIncoherent) {
  // Two pr-atoms give c = h a probability when d holds: equal values are accepted (0.3),
  // different ones are incoherent.
  const std::string base = "coin = {h, t}.\nc : coin.\nd : boolean.\nd.\nrandom(c).\n"
                           "pr(c = h) = 3/10.\n";
  AspBackend b;
  Program same = parseProgram(base + "pr(c = h | d) = 0.3.\n", "<same>");
  EXPECT_NEAR(ask(b, same, "?{c = h}"), 0.3, kEps);
  Program diff = parseProgram(base + "pr(c = h | d) = 4/10.\n", "<diff>");
  EXPECT_THROW(ask(b, diff, "?{c = h}"), IncoherentError);
  // Under obs(c = t)... still incoherent: the world c = t also has both pr-atoms applicable.
  EXPECT_THROW(ask(b, diff, "?{c = t} | obs(c = t)"), IncoherentError);
}

TEST(AspBackend, ImpossibleEvidenceIsIncoherent) {
  Program p = parseProgram(R"(
coin = {h, t}.
c : coin.
random(c).
pr(c = h) = 1.
)", "<certain>");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{c = h}"), 1.0, kEps);
  // c = t is a possible world of measure 0: zero total measure.
  EXPECT_THROW(ask(b, p, "?{c = h} | obs(c = t)"), IncoherentError);
  // No possible world at all (a constraint kills every world).
  parseInto(p, ":- c = h. :- c = t.", "<kill>");
  EXPECT_THROW(ask(b, p, "?{c = h}"), IncoherentError);
}

TEST(AspBackend, TwoSelectionRulesForOneTermAreIncoherent) {
  Program p = parseProgram(R"(
coin = {h, t}.
c : coin.
random(c).
random(c : {X : X = h}).
)", "<twice>");
  AspBackend b;
  try {
    ask(b, p, "?{c = h}");
    FAIL() << "no error";
  } catch (const IncoherentError& e) {
    EXPECT_NE(std::string(e.what()).find("two random selection rules"), std::string::npos)
        << e.what();
  }
}

TEST(AspBackend, EmptyDynamicRangeIsIncoherent) {
  // When a = 1 no value of b is allowed: b's selection fires with an empty range.
  Program p = parseProgram(R"(
n = {1..2}.
a : n.
b : n.
allowed : n -> boolean.
allowed(X) :- a = 2.
random(a).
random(b : {X : allowed(X)}).
)", "<empty>");
  AspBackend b;
  try {
    ask(b, p, "?{b = 1}");
    FAIL() << "no error";
  } catch (const IncoherentError& e) {
    EXPECT_NE(std::string(e.what()).find("dynamic range of b"), std::string::npos) << e.what();
  }
  // With a = 2 observed the world with the empty range is excluded: b uniform on {1, 2}.
  EXPECT_NEAR(ask(b, p, "?{b = 1} | obs(a = 2)"), 0.5, kEps);
}

TEST(AspBackend, MissingClingoIsAnError) {
  Program p = load("light.plog");
  AspOptions o;
  o.clingo_path = "/nonexistent/dir/clingo";
  AspBackend b(o);
  try {
    ask(b, p, "?{light = on}");
    FAIL() << "no error";
  } catch (const IncoherentError&) {
    FAIL() << "wrong error type";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/clingo"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("ASP translation"), std::string::npos) << e.what();
  }
}

TEST(AspBackend, ClingoErrorIsReportedWithItsMessage) {
  // An implicit (untyped) predicate whose variable is bound by nothing: unsafe for clingo.
  Program p = parseProgram(R"(
n = {1..2}.
a : n.
random(a).
r(1).
q(X) :- not r(X).
)", "<unsafe>");
  AspBackend b;
  try {
    ask(b, p, "?{a = 1}");
    FAIL() << "no error";
  } catch (const Error& e) {
    // clingo's locations are mapped back to the P-log statement; the temporary file, gone
    // after the call, is not named.
    const std::string what = e.what();
    EXPECT_NE(what.find("unsafe"), std::string::npos) << what;
    EXPECT_NE(what.find("<unsafe>:6:1: (line "), std::string::npos) << what;
    EXPECT_EQ(what.find("program.lp"), std::string::npos) << what;
    EXPECT_EQ(what.find("/tmp"), std::string::npos) << what;
  }
}

TEST(AspBackend, ClingoLocationsMapToPlogStatements) {
  const std::string asp = "% header\n%@ a.plog:3:1\np :- q.\nr.\n%@ a.plog:9:2\ns(X) :- t.\n";
  EXPECT_EQ(pLogLocations("/tmp/x/program.lp:3:1-8: error: bad\n", "/tmp/x/program.lp", asp),
            "a.plog:3:1: (line 3 of its ASP translation): error: bad\n");
  EXPECT_EQ(pLogLocations("/tmp/x/program.lp:6:1-10: info: unsafe\n  /tmp/x/program.lp:6:3: X",
                          "/tmp/x/program.lp", asp),
            "a.plog:9:2: (line 6 of its ASP translation): info: unsafe\n  a.plog:9:2: (line 6 "
            "of its ASP translation): X");
  // Lines before any marker, or beyond the program, belong to the translation itself.
  EXPECT_EQ(pLogLocations("/tmp/x/program.lp:1:1: e", "/tmp/x/program.lp", asp),
            "<translation>: (line 1 of its ASP translation): e");
  EXPECT_EQ(pLogLocations("no location", "/tmp/x/program.lp", asp), "no location");
}

TEST(AspBackend, TimeoutKillsClingo) {
  // 2^22 worlds cannot be enumerated in 50 ms.
  std::string text = "n = {1..22}.\nf : n -> boolean.\nrandom(f(X)).\n";
  Program p = parseProgram(text, "<big>");
  AspOptions o;
  o.timeout_s = 0.05;
  AspBackend b(o);
  try {
    ask(b, p, "?{f(1)}");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("time limit"), std::string::npos) << e.what();
  }
  // Too many worlds for the output budget: 2^10 worlds print far more than 1000 bytes.
  Program small = parseProgram("n = {1..10}.\nf : n -> boolean.\nrandom(f(X)).\n", "<mid>");
  AspOptions tight;
  tight.max_output_bytes = 1000;
  AspBackend limited(tight);
  try {
    ask(limited, small, "?{f(1)}");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("max_output_bytes"), std::string::npos) << e.what();
  }
  o.timeout_s = 0.0;
  EXPECT_THROW(AspBackend(o).probability(p, parseQuery(p, "?{f(1)}")), ConfigError);
}

// A process killed while clingo runs (Ctrl-C on plog, `timeout`, kill -9 of a node) takes its
// clingo with it: nothing keeps computing past the caller's life and its time limit.
TEST(AspBackend, ClingoDiesWithItsParent) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // 2^24 worlds: clingo is still enumerating when the parent is killed.
    Program p = parseProgram("n = {1..24}.\nf : n -> boolean.\nrandom(f(X)).\n", "<big>");
    AspOptions o;
    o.timeout_s = 120;
    AspBackend b(o);
    try {
      ask(b, p, "?{f(1)}");
    } catch (...) {
    }
    _exit(0);
  }
  // Find the clingo whose parent is the child.
  auto clingoOf = [](pid_t parent) {
    for (const auto& e : std::filesystem::directory_iterator("/proc")) {
      const std::string name = e.path().filename().string();
      if (name.find_first_not_of("0123456789") != std::string::npos) continue;
      std::ifstream stat(e.path() / "stat");
      std::string line;
      if (!std::getline(stat, line)) continue;
      const auto close = line.rfind(')');
      if (close == std::string::npos || line.find("(clingo)") == std::string::npos) continue;
      std::istringstream rest(line.substr(close + 2));
      char state;
      long ppid = 0;
      rest >> state >> ppid;
      if (ppid == parent && state != 'Z') return static_cast<pid_t>(std::stol(name));
    }
    return static_cast<pid_t>(-1);
  };
  pid_t clingo = -1;
  for (int i = 0; i < 200 && clingo < 0; ++i) {
    usleep(20000);
    clingo = clingoOf(child);
  }
  ASSERT_GT(clingo, 0) << "clingo did not start";
  kill(child, SIGKILL);
  int st = 0;
  waitpid(child, &st, 0);
  bool gone = false;
  for (int i = 0; i < 200 && !gone; ++i) {
    usleep(10000);
    // gone, or a zombie waiting for whoever adopted it to reap it
    std::ifstream stat("/proc/" + std::to_string(clingo) + "/stat");
    std::string line;
    if (!std::getline(stat, line)) {
      gone = true;
    } else {
      const auto close = line.rfind(')');
      gone = close != std::string::npos && close + 2 < line.size() && line[close + 2] == 'Z';
    }
  }
  if (!gone) kill(clingo, SIGKILL);
  EXPECT_TRUE(gone) << "clingo " << clingo << " outlived its parent";
}

TEST(AspBackend, TemporaryFilesAreRemovedOrKeptOnRequest) {
  char pattern[] = "/tmp/krr_asp_test_XXXXXX";
  ASSERT_NE(mkdtemp(pattern), nullptr);
  const std::string dir = pattern;
  const char* old = std::getenv("TMPDIR");
  const std::string saved = old ? old : "";
  setenv("TMPDIR", dir.c_str(), 1);
  auto count = [&dir]() {
    std::size_t n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      (void)e;
      ++n;
    }
    return n;
  };
  Program p = load("light.plog");
  AspBackend b;
  EXPECT_NEAR(ask(b, p, "?{light = on}"), 0.86, kEps);
  EXPECT_EQ(count(), 0u);
  AspOptions o;
  o.clingo_path = "/nonexistent/clingo";
  AspBackend failing(o);
  EXPECT_THROW(ask(failing, p, "?{light = on}"), Error);
  EXPECT_EQ(count(), 0u);  // removed on the error path too
  AspOptions keep;
  keep.keep_files = true;
  AspBackend keeping(keep);
  ask(keeping, p, "?{light = on}");
  EXPECT_EQ(count(), 1u);
  if (old) {
    setenv("TMPDIR", saved.c_str(), 1);
  } else {
    unsetenv("TMPDIR");
  }
  std::filesystem::remove_all(dir);
}

TEST(AspBackend, TranslationShowsTheEncoding) {
  Program p = load("monty_hall.plog");
  AspBackend b;
  const std::string asp = b.translate(p);
  EXPECT_NE(asp.find("1 { val(open,WY) : poss(2,open,WY) } 1 :- sel(2,open), poss(2,open,_)."),
            std::string::npos)
      << asp;
  EXPECT_NE(asp.find("sel(0,prize) :- not intervene(prize)."), std::string::npos) << asp;
  EXPECT_NE(asp.find("val(can_open(VD),true) :- sort(doors,VD), not val(can_open(VD),false)."),
            std::string::npos)
      << asp;
  // The translation alone is a valid clingo program with the 12 worlds of the game.
  ClingoResult r = runClingo(asp, AspOptions());
  EXPECT_TRUE(r.satisfiable);
  EXPECT_EQ(r.models.size(), 12u);
}

TEST(AspBackend, TermScanner) {
  auto parts = splitAspTerms("p(a,\"x y\") q r(f(1,2),-3)", ' ');
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_EQ(parts[1], "q");
  AspAtom a = parseAspAtom(parts[2]);
  EXPECT_EQ(a.name, "r");
  ASSERT_EQ(a.args.size(), 2u);
  EXPECT_EQ(a.args[0], "f(1,2)");
  EXPECT_EQ(a.args[1], "-3");
  AspAtom s = parseAspAtom(parts[0]);
  ASSERT_EQ(s.args.size(), 2u);
  EXPECT_EQ(s.args[1], "\"x y\"");
}

}  // namespace
}  // namespace plog
}  // namespace krr
