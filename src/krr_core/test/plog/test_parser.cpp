// Parser tests: both dialects, every construct, error positions (line and column).
#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/plog/parser.h"

using namespace krr;
using namespace krr::plog;

namespace {

const char* kClassic = R"(% paper-style program
person = {alice, bob}.
room = {office1, office2, lab}.
boolean = {true, false}.
cell = {0..5}.
#domain cell(C;C1).
place : person, room -> boolean.
curr_room : person -> room.
curr_cell : cell.
next_cell : cell.
f : person, cell -> room.
leftof(C, C1) :- C1 = C + 1.
place(alice, office1). place(bob, office2).
[r] random(curr_room(P)).
random(curr_cell).
random(next_cell : {C1 : leftof(C, C1)}) :- curr_cell = C.
[r] pr(curr_room(P)=R|place(P,R)=true)=8/10.
pr(next_cell=C1 | curr_cell=C, leftof(C,C1), C <> 3, C mod 2 == 0, C1 div 1 >= 0) = 0.9.
pr(curr_cell = 2) = 0.3.
obs(curr_room(bob) = office2).
obs(curr_room(alice) = lab, false).
do(curr_cell = 2).
?{curr_room(bob)=office2} | obs(curr_cell=1), do(next_cell=3).
:- curr_cell = 5, not curr_room(alice)=lab.
)";

}  // namespace

TEST(PlogParser, ClassicDialectAllConstructs) {
  Program p = parseProgram(kClassic, "a.plog");
  EXPECT_EQ(p.dialect, Dialect::Classic);
  // boolean (builtin) + person, room, cell
  ASSERT_EQ(p.sorts.size(), 4u);
  const SortDecl* cell = p.findSort("cell");
  ASSERT_NE(cell, nullptr);
  EXPECT_TRUE(cell->is_range);
  EXPECT_EQ(cell->values.size(), 6u);
  ASSERT_EQ(p.domains.size(), 1u);
  EXPECT_EQ(p.domains[0].variables, (std::vector<std::string>{"C", "C1"}));
  const AttributeDecl* f = p.findAttribute("f");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->arg_sorts, (std::vector<std::string>{"person", "cell"}));
  EXPECT_EQ(f->range_sort, "room");
  // leftof is an implicit predicate (used as a rule head without declaration)
  const AttributeDecl* l = p.findAttribute("leftof");
  ASSERT_NE(l, nullptr);
  EXPECT_TRUE(l->implicit);
  EXPECT_EQ(l->range_sort, "boolean");
  // rules: leftof rule, two facts, constraint
  ASSERT_EQ(p.rules.size(), 4u);
  EXPECT_EQ(p.rules[0].body[0].kind, Literal::Kind::Comparison);
  EXPECT_EQ(p.rules[0].head->value.name, "true");
  EXPECT_TRUE(p.rules[3].isConstraint());
  EXPECT_TRUE(p.rules[3].body[1].naf);
  // random rules
  ASSERT_EQ(p.random_rules.size(), 3u);
  EXPECT_EQ(p.random_rules[0].label, "r");
  EXPECT_TRUE(p.random_rules[2].has_range);
  EXPECT_EQ(p.random_rules[2].range_var, "C1");
  EXPECT_EQ(p.random_rules[2].body[0].atom.attr.name, "curr_cell");
  EXPECT_EQ(p.random_rules[2].variable_sorts.at("C"), "cell");
  // pr-atoms
  ASSERT_EQ(p.pr_atoms.size(), 3u);
  EXPECT_EQ(p.pr_atoms[0].label, "r");
  EXPECT_DOUBLE_EQ(p.pr_atoms[0].probability, 0.8);
  EXPECT_EQ(p.pr_atoms[0].probability_text, "8/10");
  EXPECT_EQ(p.pr_atoms[0].variable_sorts.at("P"), "person");
  EXPECT_EQ(p.pr_atoms[0].variable_sorts.at("R"), "room");
  EXPECT_EQ(p.pr_atoms[1].body.size(), 5u);
  EXPECT_EQ(p.pr_atoms[1].body[2].op, CompareOp::Ne);
  EXPECT_EQ(p.pr_atoms[1].body[3].lhs.name, "mod");
  EXPECT_EQ(p.pr_atoms[1].body[4].op, CompareOp::Ge);
  EXPECT_EQ(p.pr_atoms[1].body[4].lhs.name, "/");
  EXPECT_TRUE(p.pr_atoms[2].body.empty());
  // obs / do / query
  ASSERT_EQ(p.observations.size(), 2u);
  EXPECT_TRUE(p.observations[0].truth);
  EXPECT_FALSE(p.observations[1].truth);
  ASSERT_EQ(p.interventions.size(), 1u);
  EXPECT_EQ(p.interventions[0].atom.value.value, 2);
  ASSERT_EQ(p.queries.size(), 1u);
  EXPECT_EQ(p.queries[0].formula.size(), 1u);
  EXPECT_EQ(p.queries[0].observations.size(), 1u);
  EXPECT_EQ(p.queries[0].interventions.size(), 1u);
}

TEST(PlogParser, Plog2Dialect) {
  const char* text = R"(sorts
#door = {1,2,3}.
#n = 1..3.
#u = {a,b}+{c}+#n.
attributes
open: #door.
prize: #door.
can_open: #door -> #boolean.
statements
can_open(D) = false :- prize = D.
can_open(D) = true :- not can_open(D) = false.
random(prize).
random(open, can_open).
obs(prize, 1).
do(prize, 2).
? open = 3.
? {open = 2} | obs(prize, 1), do(open, 3).
)";
  Program p = parseProgram(text, "b.plog");
  EXPECT_EQ(p.dialect, Dialect::Plog2);
  EXPECT_EQ(p.findSort("n")->values.size(), 3u);
  EXPECT_TRUE(p.findSort("n")->is_range);
  EXPECT_EQ(p.findSort("u")->values.size(), 6u);  // a, b, c, 1, 2, 3
  EXPECT_EQ(p.findAttribute("can_open")->arg_sorts[0], "door");
  ASSERT_EQ(p.random_rules.size(), 2u);
  EXPECT_TRUE(p.random_rules[1].has_range);
  ASSERT_EQ(p.random_rules[1].range_body.size(), 1u);
  EXPECT_EQ(p.random_rules[1].range_body[0].atom.attr.name, "can_open");
  EXPECT_EQ(p.rules[0].variable_sorts.at("D"), "door");
  EXPECT_EQ(p.observations[0].literal.atom.value.value, 1);
  EXPECT_EQ(p.interventions[0].atom.value.value, 2);
  ASSERT_EQ(p.queries.size(), 2u);
  EXPECT_EQ(p.queries[0].formula[0].atom.attr.name, "open");
  EXPECT_EQ(p.queries[1].interventions[0].atom.value.value, 3);
}

TEST(PlogParser, DialectCanBeForced) {
  // a program whose statements are fine in both dialects
  Program p = parseProgram("s = {a}. x : s. random(x).", "c", Dialect::Plog2);
  EXPECT_EQ(p.dialect, Dialect::Plog2);
  EXPECT_EQ(p.random_rules.size(), 1u);
}

TEST(PlogParser, AttributeEqualitiesAndStrongNegation) {
  const char* text = R"(s = {a, b}.
x : s. y : s.
p : s -> boolean.
q : boolean.
random(x). random(y).
q :- x = y.
q :- x != y, -p(a).
q :- neg p(b).
)";
  Program p = parseProgram(text, "d");
  // x = y between two attributes: x = _V, y = _V
  ASSERT_EQ(p.rules[0].body.size(), 2u);
  EXPECT_EQ(p.rules[0].body[0].kind, Literal::Kind::Atom);
  EXPECT_EQ(p.rules[0].body[1].kind, Literal::Kind::Atom);
  EXPECT_EQ(p.rules[0].body[0].atom.value, p.rules[0].body[1].atom.value);
  // x != y: x = _V1, y = _V2, _V1 != _V2; -p(a) is p(a) = false
  ASSERT_EQ(p.rules[1].body.size(), 4u);
  EXPECT_EQ(p.rules[1].body[2].kind, Literal::Kind::Comparison);
  EXPECT_EQ(p.rules[1].body[3].atom.value.name, "false");
  EXPECT_EQ(p.rules[2].body[0].atom.value.name, "false");
}

TEST(PlogParser, MultipleAttributeDeclarationAndComments) {
  Program p = parseProgram("d = {1,2}. % comment\nopen, selected, prize : d.\n", "e");
  EXPECT_NE(p.findAttribute("open"), nullptr);
  EXPECT_NE(p.findAttribute("selected"), nullptr);
  EXPECT_NE(p.findAttribute("prize"), nullptr);
}

TEST(PlogParser, QueryAndTermEntryPoints) {
  Program p = parseProgram("s = {a, b}. x : s. f : s -> s. random(x). random(f(X)).", "f");
  Query q = parseQuery(p, "{x=a} | obs(f(a)=b), do(f(b)=a)");
  EXPECT_EQ(q.formula.size(), 1u);
  EXPECT_EQ(q.observations.size(), 1u);
  Query q2 = parseQuery(p, "?{x=a}.");
  EXPECT_EQ(q2.formula.size(), 1u);
  AttributeTerm t = parseAttributeTerm(p, "f(b)");
  EXPECT_EQ(t.name, "f");
  EXPECT_EQ(t.args[0].name, "b");
  EXPECT_THROW(parseAttributeTerm(p, "f(Z)"), ParseError);
}

TEST(PlogParser, ParseIntoAddsToExistingProgram) {
  Program p = parseProgram("s = {a, b}. x : s. random(x).", "g");
  parseInto(p, "pr(x = a) = 0.25.", "learned");
  ASSERT_EQ(p.pr_atoms.size(), 1u);
  EXPECT_EQ(p.pr_atoms[0].loc.file, "learned");
  // on error the program is unchanged
  EXPECT_THROW(parseInto(p, "pr(x = c) = 0.25.", "bad"), UnknownSymbolError);
  EXPECT_EQ(p.pr_atoms.size(), 1u);
}

struct ErrorCase {
  const char* text;
  int line;
  int col;
  const char* fragment;
};

TEST(PlogParser, ErrorPositionsLineAndColumn) {
  const ErrorCase cases[] = {
      // missing period: the next statement's first token is reported
      {"s = {a, b}.\nx : s\nrandom(x).", 3, 1, "random"},
      // bad token inside a pr-atom probability
      {"s = {a}.\nx : s.\nrandom(x).\npr(x = a) = high.", 4, 13, "probability"},
      // unexpected character
      {"s = {a}.\n  x : s @", 2, 9, "unexpected character"},
      // unclosed brace in a sort declaration
      {"s = {a, b.\n", 1, 10, "'}'"},
      // missing ')' in random
      {"s = {a}.\nx : s.\nrandom(x :- y.", 3, 10, "')'"},
      // end of input inside a rule
      {"s = {a}.\np : s -> boolean.\np(a) :- ", 3, 9, "end of input"},
  };
  for (const auto& c : cases) {
    try {
      parseProgram(c.text, "bad.plog");
      ADD_FAILURE() << "no error for: " << c.text;
    } catch (const ParseError& e) {
      EXPECT_EQ(e.location().file, "bad.plog");
      EXPECT_EQ(e.location().line, c.line) << e.what();
      EXPECT_EQ(e.location().column, c.col) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.fragment), std::string::npos) << e.what();
    }
  }
}

TEST(PlogParser, UnknownSymbolsNameSymbolAndLocation) {
  try {
    parseProgram("s = {a}.\nx : t.\n", "u.plog");
    FAIL();
  } catch (const UnknownSymbolError& e) {
    EXPECT_NE(std::string(e.what()).find("u.plog:2:5"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'t'"), std::string::npos);
  }
  try {
    parseProgram("s = {a}.\nx : s.\nrandom(x).\npr(x = b) = 0.5.", "u.plog");
    FAIL();
  } catch (const UnknownSymbolError& e) {
    EXPECT_NE(std::string(e.what()).find("u.plog:4:8"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'b'"), std::string::npos);
  }
  try {
    parseProgram("s = {a}.\nx : s.\nrandom(y).", "u.plog");
    FAIL();
  } catch (const UnknownSymbolError& e) {
    EXPECT_NE(std::string(e.what()).find("u.plog:3:8"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'y'"), std::string::npos);
  }
  // undeclared predicate used only in a body
  EXPECT_THROW(parseProgram("s = {a}.\nx : s.\nrandom(x) :- q(a).", "u"), UnknownSymbolError);
  // wrong arity
  EXPECT_THROW(parseProgram("s = {a}.\nx : s -> s.\nrandom(x).", "u"), UnknownSymbolError);
}
