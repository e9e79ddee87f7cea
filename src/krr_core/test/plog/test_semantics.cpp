// P-log semantics on small programs; every expected value is derived by hand in a comment.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

namespace {
constexpr double kEps = 1e-12;

double valueOf(const std::vector<ValueProb>& d, const std::string& v) {
  for (const auto& x : d)
    if (x.value == v) return x.probability;
  return 0.0;
}

/// @brief The native engine alone refuses the query as outside its fragment.
void expectNativeRefuses(const std::string& text, const std::string& query) {
  Reasoner native;
  native.setBackend(Backend::Native);
  native.loadString(text);
  EXPECT_THROW(native.probability(query), OutsideFragmentError) << query;
}
}  // namespace

// Monty Hall (Baral, Gelfond & Rushton 2009). prize and selected are uniform over 3 doors;
// open is uniform over the doors that are neither selected nor the prize. With selected = 1:
//   prize=1 (1/3): open in {2,3}, P(open=2) = 1/2  -> 1/6
//   prize=2 (1/3): open in {3}                      -> 0
//   prize=3 (1/3): open in {2}                      -> 1/3
// P(prize=3 | selected=1, open=2) = (1/3) / (1/3 + 1/6) = 2/3, P(prize=1 | ...) = 1/3.
TEST(PlogSemantics, MontyHall) {
  Reasoner r;
  r.loadFile(std::string(KRR_TEST_DATA_DIR) + "/plog/monty_hall.plog");
  auto answers = r.answerProgramQueries();
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_NEAR(answers[0].probability, 2.0 / 3.0, kEps);
  EXPECT_NEAR(answers[1].probability, 1.0 / 3.0, kEps);
  EXPECT_NEAR(r.probability("?{prize=2}"), 0.0, kEps);
  auto d = r.distribution("prize");
  EXPECT_NEAR(valueOf(d, "1"), 1.0 / 3.0, kEps);
  EXPECT_NEAR(valueOf(d, "3"), 2.0 / 3.0, kEps);
}

// Without observing open, the prize is uniform: P(prize=3 | selected=1) = 1/3.
TEST(PlogSemantics, MontyHallWithoutOpenObservation) {
  Reasoner r;
  r.loadString(R"(doors = {1, 2, 3}.
open, selected, prize : doors.
can_open : doors -> boolean.
can_open(D) = false :- selected = D.
can_open(D) = false :- prize = D.
can_open(D) = true :- not can_open(D) = false.
random(prize). random(selected).
random(open : {X : can_open(X)}).
)");
  EXPECT_NEAR(r.probability("?{prize=3} | obs(selected=1)"), 1.0 / 3.0, kEps);
  // the host never opens the selected door
  EXPECT_NEAR(r.probability("?{open=1} | obs(selected=1)"), 0.0, kEps);
}

// Dice (2009 paper): john's die is fair; mike's die shows 6 with 1/4 and the other faces
// 3/20 each. P(roll(d1)=6) = 1/4; P(even(d1)) = 1/4 + 2 * 3/20 = 0.55; P(even(d2)) = 1/2.
// total = roll(d1) + roll(d2): P(total=12) = 1/4 * 1/6 = 1/24, P(total=2) = 3/20 * 1/6 = 1/40.
// P(roll(d1)=6 | total=12) = 1 and P(total=7 | roll(d1)=1) = 1/6.
TEST(PlogSemantics, Dice) {
  Reasoner r;
  r.loadString(R"(score = {1..6}.
sums = {2..12}.
dice = {d1, d2}.
person = {mike, john}.
roll : dice -> score.
owner : dice -> person.
even : dice -> boolean.
total : sums.
owner(d1) = mike.
owner(d2) = john.
even(D) :- roll(D) = Y, Y mod 2 == 0.
-even(D) :- not even(D).
total = S :- roll(d1) = X, roll(d2) = Y, S = X + Y.
random(roll(D)).
pr(roll(D) = Y | owner(D) = john) = 1/6.
pr(roll(D) = 6 | owner(D) = mike) = 1/4.
pr(roll(D) = Y | owner(D) = mike, Y != 6) = 3/20.
)",
               "dice");
  EXPECT_NEAR(r.probability("?{roll(d1)=6}"), 0.25, kEps);
  EXPECT_NEAR(r.probability("?{even(d1)}"), 0.55, kEps);
  EXPECT_NEAR(r.probability("?{even(d1)=false}"), 0.45, kEps);
  EXPECT_NEAR(r.probability("?{even(d2)}"), 0.5, kEps);
  EXPECT_NEAR(r.probability("?{total=12}"), 1.0 / 24.0, kEps);
  EXPECT_NEAR(r.probability("?{total=2}"), 1.0 / 40.0, kEps);
  EXPECT_NEAR(r.probability("?{roll(d1)=6} | obs(total=12)"), 1.0, kEps);
  EXPECT_NEAR(r.probability("?{total=7} | obs(roll(d1)=1)"), 1.0 / 6.0, kEps);
  // conjunctive formula: both even = 0.55 * 0.5
  EXPECT_NEAR(r.probability("?{even(d1), even(d2)}"), 0.275, kEps);
  // the distribution of the sum sums to 1
  double s = 0;
  for (const auto& v : r.distribution("total")) s += v.probability;
  EXPECT_NEAR(s, 1.0, 1e-12);
}

// Unassigned probability is split evenly: only P(roll=6)=1/4 is given for mike's die, so each
// other face gets (1 - 1/4)/5 = 0.15.
TEST(PlogSemantics, UnassignedProbabilitySplitEvenly) {
  Reasoner r;
  r.loadString(R"(score = {1..6}.
roll : score.
random(roll).
pr(roll = 6) = 1/4.
)");
  auto d = r.distribution("roll");
  ASSERT_EQ(d.size(), 6u);
  EXPECT_NEAR(valueOf(d, "6"), 0.25, kEps);
  for (int v = 1; v <= 5; ++v) EXPECT_NEAR(valueOf(d, std::to_string(v)), 0.15, kEps);
  // four colours, P(r) = 0.4: g, b, y get 0.2 each
  r.loadString("c = {r, g, b, y}. col : c. random(col). pr(col = r) = 0.4.");
  EXPECT_NEAR(r.probability("?{col=g}"), 0.2, kEps);
  EXPECT_NEAR(r.probability("?{col=y}"), 0.2, kEps);
  // all assigned = 1 while b, y remain possible: they get probability 0 (coherent)
  r.loadString("c = {r, g, b, y}. col : c. random(col). pr(col = r) = 0.5. pr(col = g) = 0.5.");
  EXPECT_NEAR(r.probability("?{col=b}"), 0.0, kEps);
  EXPECT_NEAR(r.probability("?{col=g}"), 0.5, kEps);
}

// Dynamic range: x uniform on 1..4, y uniform on {z : z >= x}.
// P(y=4) = 1/4 * (1/4 + 1/3 + 1/2 + 1) = 25/48; P(y=1) = 1/4 * 1/4 = 1/16.
// P(x=4 | y=4) = (1/4) / (25/48) = 12/25.
TEST(PlogSemantics, DynamicRange) {
  Reasoner r;
  r.loadString(R"(s = {1..4}.
x : s. y : s.
ok : s -> boolean.
ok(Z) :- x = X, Z >= X.
random(x).
random(y : {Z : ok(Z)}).
)");
  EXPECT_NEAR(r.probability("?{y=4}"), 25.0 / 48.0, kEps);
  EXPECT_NEAR(r.probability("?{y=1}"), 1.0 / 16.0, kEps);
  EXPECT_NEAR(r.probability("?{x=4} | obs(y=4)"), 12.0 / 25.0, kEps);
  // static dynamic-range condition (classic syntax with a selection-rule body)
  r.loadString(R"(s = {1..4}.
x : s. y : s.
random(x).
random(y : {Z : Z > X}) :- x = X.
)");
  // x=4 leaves an empty range for y: incoherent
  EXPECT_THROW(r.probability("?{y=4}"), IncoherentError);
  // with x fixed by do, P(y=3 | do(x=1)) = 1/3
  EXPECT_NEAR(r.probability("?{y=3} | do(x=1)"), 1.0 / 3.0, kEps);
}

// Defaults with negation as failure: birds fly unless abnormal; penguins are abnormal.
// P(penguin(B)) = 0.2, so P(flies(tweety)) = 0.8, and observing that tweety does not fly
// makes it a penguin: P(penguin(tweety) | obs(flies(tweety), false)) = 1.
TEST(PlogSemantics, DefaultsWithNot) {
  Reasoner r;
  r.loadString(R"(bird = {tweety, sam}.
flies : bird -> boolean.
ab : bird -> boolean.
penguin : bird -> boolean.
random(penguin(B)).
pr(penguin(B) = true) = 0.2.
ab(B) :- penguin(B).
flies(B) :- not ab(B).
)");
  EXPECT_NEAR(r.probability("?{flies(tweety)}"), 0.8, kEps);
  EXPECT_NEAR(r.probability("?{flies(tweety)} | obs(flies(sam))"), 0.8, kEps);
  EXPECT_NEAR(r.probability("?{penguin(tweety)} | obs(flies(tweety), false)"), 1.0, kEps);
  EXPECT_NEAR(r.probability("?{penguin(tweety)} | obs(neg flies(tweety))"), 1.0, kEps);
  // "not" in the query formula: P(not flies(sam)) = 0.2
  EXPECT_NEAR(r.probability("?{not flies(sam)}"), 0.2, kEps);
}

// do vs obs. rain ~ 0.3; sprinkler ~ 0.1 if rain, 0.5 otherwise; wet if either.
// P(rain | obs(sprinkler)) = 0.3*0.1 / (0.3*0.1 + 0.7*0.5) = 0.03/0.38;
// P(rain | do(sprinkler)) = 0.3 (the intervention cuts the dependence);
// P(wet) = 1 - 0.7*0.5 = 0.65; P(wet | do(sprinkler=false)) = 0.3.
TEST(PlogSemantics, DoVersusObs) {
  Reasoner r;
  r.loadString(R"(rain : boolean. sprinkler : boolean. wet : boolean.
random(rain).
random(sprinkler).
pr(rain = true) = 0.3.
pr(sprinkler = true | rain = true) = 0.1.
pr(sprinkler = true | rain = false) = 0.5.
wet :- rain = true.
wet :- sprinkler = true.
)");
  EXPECT_NEAR(r.probability("?{rain} | obs(sprinkler)"), 0.03 / 0.38, kEps);
  EXPECT_NEAR(r.probability("?{rain} | do(sprinkler)"), 0.3, kEps);
  EXPECT_NEAR(r.probability("?{wet}"), 0.65, kEps);
  EXPECT_NEAR(r.probability("?{wet} | do(sprinkler=false)"), 0.3, kEps);
  // P(rain | obs(wet)) = 0.3 / 0.65
  EXPECT_NEAR(r.probability("?{rain} | obs(wet)"), 0.3 / 0.65, kEps);
}

// pr-atoms conditioned on other attributes, the paper's example:
// pr(curr_room(P)=R | place(P,R)=true) = 8/10; the other two rooms get 0.1 each.
// With mismatched labels the pr-atom does not apply and the room is uniform (1/3).
TEST(PlogSemantics, PaperCurrRoomAndLabels) {
  const std::string base = R"(person = {alice, bob}.
room = {office1, office2, lab}.
place : person, room -> boolean.
curr_room : person -> room.
place(alice, office1).
place(bob, office2).
)";
  Reasoner r;
  r.loadString(base + "[r] random(curr_room(P)).\n[r] pr(curr_room(P)=R|place(P,R)=true)=8/10.\n");
  EXPECT_NEAR(r.probability("?{curr_room(bob)=office2}"), 0.8, kEps);
  EXPECT_NEAR(r.probability("?{curr_room(bob)=lab}"), 0.1, kEps);
  EXPECT_NEAR(r.probability("?{curr_room(alice)=office1}"), 0.8, kEps);
  r.loadString(base + "[r] random(curr_room(P)).\n[q] pr(curr_room(P)=R|place(P,R)=true)=8/10.\n");
  EXPECT_NEAR(r.probability("?{curr_room(bob)=office2}"), 1.0 / 3.0, kEps);
}

// Program-level obs and do apply to every query; a constraint removes worlds.
// x, y uniform on {a, b}; constraint ":- x = y" leaves (a,b) and (b,a): P(x=a) = 1/2,
// P(y=b | x=a) = 1. With obs(x = a) in the program, P(y = b) = 1.
TEST(PlogSemantics, ConstraintsAndProgramEvidence) {
  Reasoner r;
  r.loadString(R"(s = {a, b}.
x : s. y : s.
random(x). random(y).
pr(x = a) = 0.9.
:- x = y.
)");
  // worlds: (a,b) 0.9*0.5, (b,a) 0.1*0.5 -> P(x=a) = 0.9
  EXPECT_NEAR(r.probability("?{x=a}"), 0.9, kEps);
  EXPECT_NEAR(r.probability("?{y=b} | obs(x=a)"), 1.0, kEps);
  r.addStatements("obs(x = b).");
  EXPECT_NEAR(r.probability("?{y=a}"), 1.0, kEps);
}

// Variables bound through arithmetic, static rules with recursion (transitive closure).
// Three cells in a row; conn is the transitive closure of edge; x uniform over cells;
// P(conn(x, 2)) counts x in {0, 1}: 2/3.
TEST(PlogSemantics, StaticRecursionAndArithmetic) {
  Reasoner r;
  r.loadString(R"(cell = {0..2}.
#domain cell(C; C1; C2).
edge : cell, cell -> boolean.
conn : cell, cell -> boolean.
x : cell.
reach2 : boolean.
edge(C, C1) :- C1 = C + 1.
conn(C, C1) :- edge(C, C1).
conn(C, C2) :- conn(C, C1), edge(C1, C2).
random(x).
reach2 :- x = C, conn(C, 2).
)");
  EXPECT_NEAR(r.probability("?{reach2}"), 2.0 / 3.0, kEps);
  EXPECT_NEAR(r.probability("?{conn(0, 2)}"), 1.0, kEps);
  EXPECT_NEAR(r.probability("?{conn(2, 0)}"), 0.0, kEps);
}

// plog2 dialect end to end: Monty Hall again.
TEST(PlogSemantics, Plog2MontyHall) {
  Reasoner r;
  r.loadString(R"(sorts
#door = {1,2,3}.
attributes
open: #door.
selected: #door.
prize: #door.
can_open: #door -> #boolean.
statements
can_open(D) = false :- selected = D.
can_open(D) = false :- prize = D.
can_open(D) = true :- not can_open(D) = false.
random(prize).
random(selected).
random(open, can_open).
obs(selected, 1).
obs(open, 2).
? prize = 3.
)");
  auto a = r.answerProgramQueries();
  ASSERT_EQ(a.size(), 1u);
  EXPECT_NEAR(a[0].probability, 2.0 / 3.0, kEps);
  // the same program as a data file, with a second query: P(prize=1 | selected=1, open=2)
  r.loadFile(std::string(KRR_TEST_DATA_DIR) + "/plog/monty_hall_plog2.plog");
  a = r.answerProgramQueries();
  ASSERT_EQ(a.size(), 2u);
  EXPECT_NEAR(a[0].probability, 2.0 / 3.0, kEps);
  EXPECT_NEAR(a[1].probability, 1.0 / 3.0, kEps);
}

// A constraint on a sibling conditions the common ancestor: x ~ {a: 0.5, b: 0.5};
// y = x's copy via pr-atoms (pr(y=a | x=a) = 1, pr(y=b | x=b) = 1); z uniform on {a, b} when
// x = a and z = b when x = b. ":- z = b" removes (x=a,z=b) (mass 1/4) and (x=b) (mass 1/2):
// only (x=a, z=a) remains, so P(y = a) = 1 although the constraint never mentions y or x.
TEST(PlogSemantics, ConstraintOnSiblingConditionsAncestor) {
  Reasoner r;
  r.loadString(R"(s = {a, b}.
x : s. y : s. z : s.
random(x). random(y). random(z).
pr(y = a | x = a) = 1.
pr(y = b | x = b) = 1.
pr(z = b | x = b) = 1.
:- z = b.
)");
  EXPECT_NEAR(r.probability("?{y = a}"), 1.0, kEps);
  // without the constraint: 1/2
  r.loadString(R"(s = {a, b}.
x : s. y : s. z : s.
random(x). random(y). random(z).
pr(y = a | x = a) = 1.
pr(y = b | x = b) = 1.
pr(z = b | x = b) = 1.
)");
  EXPECT_NEAR(r.probability("?{y = a}"), 0.5, kEps);
}

// A derived attribute that would get two values makes the world inconsistent (no answer set):
// x uniform on {a, b, c}; d = 1 if x != c... d = 1 :- x = a.  d = 2 :- x != c.
// x = a derives d = 1 and d = 2: that world is removed. Remaining: x = b (d = 2), x = c (no d):
// P(x = b) = 1/2, even for a query that does not mention d.
TEST(PlogSemantics, TwoDerivedValuesRemoveTheWorld) {
  Reasoner r;
  r.loadString(R"(s = {a, b, c}.
n = {1, 2}.
x : s. d : n.
random(x).
d = 1 :- x = a.
d = 2 :- x != c.
)");
  EXPECT_NEAR(r.probability("?{x = b}"), 0.5, kEps);
  EXPECT_NEAR(r.probability("?{x = a}"), 0.0, kEps);
  EXPECT_NEAR(r.probability("?{d = 2}"), 0.5, kEps);
}

// The paper's Section III snippets together (dialog side). All attributes are independent:
// P(curr_s(coffee, office1, alice, 0, false)) = P(curr_item(alice)=coffee) (1/2)
//   * P(curr_room(alice)=office1) (0.8, alice's own office) * P(curr_person=alice) (1/2)
//   * P(curr_cell=0) (1/4) * P(curr_succ=false) (1/2) = 0.025.
// serve(I,R,P) is determined by the act_ attributes: with all three fixed by do, it holds
// with probability 1; with only act_item fixed, P(serve(coffee,lab,alice)) = 1/3 * 1/2.
TEST(PlogSemantics, PaperSnippets) {
  Reasoner r;
  r.loadString(R"(person = {alice, bob}.
item = {coffee, sandwich}.
room = {office1, office2, lab}.
cell = {0..3}.
boolean = {true, false}.
place : person, room -> boolean.
curr_item : person -> item.
curr_room : person -> room.
curr_person : person.
curr_cell : cell.
curr_succ : boolean.
act_item : item. act_room : room. act_person : person.
serve : item, room, person -> boolean.
curr_s : item, room, person, cell, boolean -> boolean.
place(alice, office1). place(bob, office2).
random(curr_item(P)). random(curr_room(P)). random(curr_person). random(curr_cell).
random(curr_succ). random(act_item). random(act_room). random(act_person).
pr(curr_room(P)=R|place(P,R)=true)=8/10.
serve(I,R,P) :- act_item=I, act_room=R, act_person=P.
curr_s(I,R,P,C,S) :- curr_item(P)=I, curr_room(P)=R,
            curr_person=P, curr_cell=C, curr_succ=S.
)",
               "paper");
  EXPECT_NEAR(r.probability("?{curr_s(coffee, office1, alice, 0, false)}"), 0.025, kEps);
  EXPECT_NEAR(r.probability("?{serve(coffee, lab, alice)} | do(act_item=coffee), "
                            "do(act_room=lab), do(act_person=alice)"),
              1.0, kEps);
  EXPECT_NEAR(r.probability("?{serve(coffee, lab, alice)} | do(act_item=coffee)"), 1.0 / 6.0,
              kEps);
}

// Positive recursion through random attributes (least fixpoint per world): six directed random
// edges among three nodes, each present with 0.5. 3 is reachable from 1 iff edge(1,3) or
// (edge(1,2) and edge(2,3)): P = 1 - (1 - 0.5) * (1 - 0.25) = 0.625.
TEST(PlogSemantics, PositiveRecursionThroughRandomAttributes) {
  Reasoner r;
  r.loadString(R"(node = {1..3}.
#domain node(X; Y; Z).
edge : node, node -> boolean.
path : node, node -> boolean.
random(edge(X, Y)) :- X != Y.
pr(edge(X, Y) = true) = 0.5.
path(X, Y) :- edge(X, Y).
path(X, Z) :- path(X, Y), edge(Y, Z).
)");
  EXPECT_NEAR(r.probability("?{path(1, 3)}"), 0.625, kEps);
  // given that 1 -> 3 is not an edge, 3 is reachable only through 2: 0.25
  EXPECT_NEAR(r.probability("?{path(1, 3)} | obs(edge(1, 3) = false)"), 0.25, kEps);
  // a node reaches itself only through a cycle: 1->2->1, 1->3->1, 1->2->3->1, 1->3->2->1
  // P(path(1,1)) = 1 - P(no cycle through 1), computed by enumerating the 16 relevant
  // combinations of the four edges touching 1 and the two edges between 2 and 3:
  // path(1,1) iff (e12 & (e21 | e23&e31)) | (e13 & (e31 | e32&e21)).
  double p = 0;
  for (int m = 0; m < 64; ++m) {
    bool e12 = m & 1, e21 = m & 2, e13 = m & 4, e31 = m & 8, e23 = m & 16, e32 = m & 32;
    bool reach = (e12 && (e21 || (e23 && e31))) || (e13 && (e31 || (e32 && e21)));
    if (reach) p += 1.0 / 64;
  }
  EXPECT_NEAR(r.probability("?{path(1, 1)}"), p, kEps);
}

// Rules away from the queried attribute that remove or split possible worlds (issue 13).
// Odd loop: `e :- a. e :- not e.` has an answer set only where a holds (where a is false,
// `e :- not e` has none), so P(a) = 1, not the prior 1/2.
TEST(PlogSemantics, OddLoopAwayFromTheQueryRemovesWorlds) {
  const std::string text =
      "a : boolean.\ne : boolean.\nrandom(a).\ne :- a.\ne :- not e.\n?{a}.\n";
  expectNativeRefuses(text, "?{a}");
  Reasoner r;  // default back end: auto
  EXPECT_EQ(r.backend(), Backend::Auto);
  r.loadString(text);
  EXPECT_NEAR(r.probability("?{a}"), 1.0, kEps);
  EXPECT_EQ(r.stats().last_backend, Backend::Asp);
  // The refusal is remembered: the next query on the same attributes goes to clingo directly.
  EXPECT_NEAR(r.answerProgramQueries().at(0).probability, 1.0, kEps);
  EXPECT_EQ(r.stats().asp_answers, 2u);
}

// Even loop: `b :- not c, a. c :- not b, a.` gives two answer sets where a is true (each
// with the measure 1/2 of a = true) and one where a is false (1/2):
// P(a = false) = (1/2) / (1/2 + 1/2 + 1/2) = 1/3.
TEST(PlogSemantics, EvenLoopAwayFromTheQuerySplitsWorlds) {
  const std::string text =
      "a : boolean.\nb : boolean.\nc : boolean.\nrandom(a).\n"
      "b :- not c, a.\nc :- not b, a.\n";
  expectNativeRefuses(text, "?{a = false}");
  Reasoner r;
  r.loadString(text);
  EXPECT_NEAR(r.probability("?{a = false}"), 1.0 / 3.0, kEps);
  auto d = r.distribution("a");
  EXPECT_NEAR(valueOf(d, "false"), 1.0 / 3.0, kEps);
  EXPECT_NEAR(valueOf(d, "true"), 2.0 / 3.0, kEps);
  // A table through clingo, one row per do(a = v): each row is certain of its value.
  Table t = r.tableQuery("a", {"a"});
  ASSERT_EQ(t.rows.size(), 2u);
  for (const auto& row : t.rows) {
    ASSERT_EQ(row.distribution.size(), 1u);
    EXPECT_EQ(row.distribution[0].value, row.conditioning_values[0]);
    EXPECT_NEAR(row.distribution[0].probability, 1.0, kEps);
  }
  // Locally stratified negation stays native: `d :- not a.` has no loop.
  Reasoner s;
  s.loadString("a : boolean.\nd : boolean.\nrandom(a).\nd :- not a.\n");
  EXPECT_NEAR(s.probability("?{d}"), 0.5, kEps);
  EXPECT_EQ(s.stats().last_backend, Backend::Native);
}

// A rule that fixes a random attribute removes the worlds where the selection chose another
// value: `random(a). random(b). a :- b.` leaves (a,b) in {TT, TF, FF}, each 1/4, so
// P(b) = (1/4) / (3/4) = 1/3. The native engine refuses the rule; auto answers through clingo.
TEST(PlogSemantics, RuleDefiningARandomAttributeGoesToClingo) {
  const std::string text = "a : boolean.\nb : boolean.\nrandom(a).\nrandom(b).\na :- b.\n";
  expectNativeRefuses(text, "?{b}");
  Reasoner r;
  r.loadString(text);
  EXPECT_NEAR(r.probability("?{b}"), 1.0 / 3.0, kEps);
}

// A random selection over a dynamic range that is empty in some world, away from the query:
// both back ends refuse (IncoherentError) instead of answering from the query's cone.
TEST(PlogSemantics, EmptyDynamicRangeAwayFromTheQueryIsRefused) {
  const std::string text =
      "s = {1, 2, 3}.\nok : s -> boolean.\nx : s.\nb : boolean.\nrandom(b).\n"
      "ok(1) :- b.\nrandom(x : {X : ok(X)}).\n";
  for (Backend backend : {Backend::Native, Backend::Auto, Backend::Asp}) {
    SCOPED_TRACE(backendName(backend));
    Reasoner r;
    r.setBackend(backend);
    r.loadString(text);
    EXPECT_THROW(r.probability("?{b}"), IncoherentError);
  }
}

TEST(PlogSemantics, BackendNames) {
  for (Backend b : {Backend::Native, Backend::Asp, Backend::Auto})
    EXPECT_EQ(parseBackend(backendName(b)), b);
  EXPECT_THROW(parseBackend("clingo"), ConfigError);
}
