/**
 * @file test_cr_rules.cpp
 * @brief Consistency-restoring rules `h :+ body.` (plog2.0 dialect) on small programs whose
 * answers are derived by hand.
 *
 * Semantics (plog2.0's, read from its translation to clingo): a cr-rule instance applies only
 * where it is chosen; the possible worlds are the answer sets of the program (with its
 * observations and the query's evidence) that apply the FEWEST cr-rule instances, counted
 * over the whole program (cardinality, not set inclusion), each distinct world once. The P-log
 * measure is then formed and normalised over these worlds as usual. Every value below was
 * also checked against plog2.0 (`plog2 FILE --algo=naive`) with the evidence as program obs.
 */
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/plog/ast.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

namespace krr {
namespace plog {
namespace {

constexpr double kEps = 1e-9;

const char* kHeader =
    "sorts\n#boolean = {true, false}.\n#item = {i1, i2, i3}.\n"
    "attributes\np: #boolean.\nq: #boolean.\na: #boolean.\nb: #boolean.\nc: #boolean.\n"
    "d: #boolean.\nok: #boolean.\nfixed: #item -> #boolean.\nbroken: #item -> #boolean.\n"
    "statements\n";

/// P(query) with the given back end on kHeader + statements.
double ask(Backend backend, const std::string& statements, const std::string& query) {
  Reasoner r;
  r.setBackend(backend);
  r.loadString(std::string(kHeader) + statements, "cr.plog", Dialect::Plog2);
  return r.probability(query);
}

/// Same answer from the default back end and from clingo.
void expectBoth(const std::string& statements, const std::string& query, double expected) {
  EXPECT_NEAR(ask(Backend::Auto, statements, query), expected, kEps) << query;
  EXPECT_NEAR(ask(Backend::Asp, statements, query), expected, kEps) << query;
}

TEST(CrRules, ParsedAndPrintedBack) {
  Program p = parseProgram(std::string(kHeader) + "random(p) :+.\nq :+ p.\nq :- a.\n", "cr.plog",
                           Dialect::Plog2);
  ASSERT_EQ(p.random_rules.size(), 1u);
  EXPECT_TRUE(p.random_rules[0].consistency_restoring);
  ASSERT_EQ(p.rules.size(), 2u);
  EXPECT_TRUE(p.rules[0].consistency_restoring);
  EXPECT_FALSE(p.rules[1].consistency_restoring);
  EXPECT_TRUE(p.hasConsistencyRestoringRules());
  EXPECT_EQ(toString(p.rules[0]), "q :+ p.");
  EXPECT_EQ(toString(p.random_rules[0]), "random(p) :+.");
  // The export (classic dialect) reads back with the rules still consistency-restoring.
  Program back = parseProgram(toString(p), "export.plog", Dialect::Classic);
  ASSERT_EQ(back.rules.size(), 2u);
  ASSERT_EQ(back.random_rules.size(), 1u);
  EXPECT_TRUE(back.rules[0].consistency_restoring);
  EXPECT_FALSE(back.rules[1].consistency_restoring);
  EXPECT_TRUE(back.random_rules[0].consistency_restoring);
  // `a :+.` right after the attributes is a rule, not an attribute declaration.
  Program p2 = parseProgram(std::string(kHeader) + "a :+.\n", "cr.plog", Dialect::Plog2);
  ASSERT_EQ(p2.rules.size(), 1u);
  EXPECT_TRUE(p2.rules[0].consistency_restoring);
}

TEST(CrRules, NativeEngineRefusesThemAsOutsideItsFragment) {
  EXPECT_THROW(ask(Backend::Native, "random(p).\nq :+.\n", "?{q=true}"), OutsideFragmentError);
}

TEST(CrRules, IgnoredWhenTheProgramIsConsistentWithoutThem) {
  // random(p). q :+.  The program has worlds {p}, {-p} without the cr-rule (cost 0), so it is
  // never applied: q has no value in any world, P(q) = 0 (applied as a fact it would be 1).
  expectBoth("random(p).\nq :+.\n", "?{q=true}", 0.0);
  expectBoth("random(p).\nq :+.\n", "?{p=true}", 0.5);
}

TEST(CrRules, RandomSelectionRestoresConsistency) {
  // plog2.0's simplecrrule.plog: random(p) :+.  r is forced false, r :- not q, q :- p = y.
  // Without the cr-rule p has no value, q fails, r = true clashes with r = false. Applying it
  // (cost 1) gives worlds p = true, p = false, 1/2 each.
  expectBoth("random(p) :+.\nc :- not q.\nc = false.\nq :- p = true.\nq :- p = false.\n",
             "?{p=true}", 0.5);
}

TEST(CrRules, MinimisationIsGlobalOverAllWorlds) {
  // random(p). q :+ p. :- p, not q.  The world p = false is consistent without cr-rules
  // (cost 0); p = true needs one. Only cost-0 worlds remain: P(p) = 0.
  expectBoth("random(p).\nq :+ p.\n:- p, not q.\n", "?{p=true}", 0.0);
  // The same with variables: every broken(X) = true needs fixed(X); the only world of cost 0
  // has no broken item.
  const std::string items = "random(broken(X)).\nfixed(X) :+ broken(X).\n:- broken(X), not fixed(X).\n";
  expectBoth(items, "?{broken(i1)=true}", 0.0);
}

TEST(CrRules, QueryEvidenceTakesPartInTheMinimisation) {
  // With obs(broken(i1)) the program needs fixed(i1) (cost 1); cost 1 also allows no other
  // broken item, so the one world is broken(i1), fixed(i1), -broken(i2), -broken(i3).
  // Conditioning the cost-0 world instead would make the evidence impossible.
  const std::string items = "random(broken(X)).\nfixed(X) :+ broken(X).\n:- broken(X), not fixed(X).\n";
  expectBoth(items, "?{broken(i2)=true} | obs(broken(i1)=true)", 0.0);
  expectBoth(items, "?{fixed(i1)=true} | obs(broken(i1)=true)", 1.0);
  // As program observations, the same answers.
  expectBoth(items + "obs(broken(i1)).\n", "?{fixed(i1)=true}", 1.0);
}

TEST(CrRules, TwoMinimalSetsGiveDistinctWorlds) {
  // random(p), pr(p = true) = 3/10. a :+. b :+. ok :- a, p. ok :- b. :- not ok.
  // No world has cost 0. Cost 1: {a} with p = true (mu .3), {b} with p = true (mu .3),
  // {b} with p = false (mu .7); {a} with p = false violates the constraint.
  // P(a) = .3 / 1.3 = 3/13, P(p) = .6 / 1.3 = 6/13.
  const std::string prog =
      "random(p).\npr(p = true) = 3/10.\na :+.\nb :+.\nok :- a, p.\nok :- b.\n:- not ok.\n";
  expectBoth(prog, "?{a=true}", 3.0 / 13.0);
  expectBoth(prog, "?{p=true}", 6.0 / 13.0);
  // The distribution of p from the same worlds (auto hands it to clingo): 6/13, 7/13.
  Reasoner r;
  r.loadString(std::string(kHeader) + prog, "cr.plog", Dialect::Plog2);
  double pt = -1, pf = -1;
  for (const auto& v : r.distribution("p")) (v.value == "true" ? pt : pf) = v.probability;
  EXPECT_NEAR(pt, 6.0 / 13.0, kEps);
  EXPECT_NEAR(pf, 7.0 / 13.0, kEps);
}

TEST(CrRules, SupportsOfEqualSizeGivingOneWorldCountOnce) {
  // plog2.0's multipleabdsupports.plog: a :+. b :+. a :- b. b :- a. c :- a. c :- b. c :+.
  // obs(c). Cost 1: {a} and {b} both give the world {a, b, c}; {c} gives {c}. Two worlds
  // (not three answer sets): P(a) = 1/2.
  expectBoth("a :+.\nb :+.\na :- b.\nb :- a.\nc :- b.\nc :- a.\nc :+.\nobs(c).\n", "?{a=true}",
             0.5);
}

TEST(CrRules, CardinalityNotSetInclusion) {
  // a :+. b :+. c :+. d :- b, c. ok :- a. ok :- d. :- not ok. random(p).
  // Set-inclusion-minimal supports: {a} and {b, c} (P(a) would be 1/2); the cardinality-
  // minimal one, as in plog2.0, is {a} only: P(a) = 1.
  expectBoth("random(p).\na :+.\nb :+.\nc :+.\nd :- b, c.\nok :- a.\nok :- d.\n:- not ok.\n",
             "?{a=true}", 1.0);
}

TEST(CrRules, HeadlessRuleIsReadAndNeverApplied) {
  // `:+ body.` is plog2.0's cr-rule with the false head 0 != 0: applying it removes the world,
  // so it is never applied and the worlds are those without it. random(p). q :- p. :+ q.
  // r :+ q.: P(p) = 1/2 (plog2.0 naive: 0.5); as the constraint `:- q.` it would be 0.
  Program p = parseProgram(std::string(kHeader) + "random(p).\nq :- p = true.\n:+ q.\n",
                           "cr.plog", Dialect::Plog2);
  ASSERT_EQ(p.rules.size(), 2u);
  EXPECT_FALSE(p.rules[1].head.has_value());
  EXPECT_TRUE(p.rules[1].consistency_restoring);
  EXPECT_EQ(p.rules[1].body.size(), 1u);
  EXPECT_TRUE(p.hasConsistencyRestoringRules());
  // Printed back and read again (classic dialect) it is still a headless cr-rule.
  Program back = parseProgram(toString(p), "export.plog", Dialect::Classic);
  ASSERT_EQ(back.rules.size(), 2u);
  EXPECT_FALSE(back.rules[1].head.has_value());
  EXPECT_TRUE(back.rules[1].consistency_restoring);
  expectBoth("random(p).\nq :- p = true.\n:+ q.\nd :+ q.\n", "?{p=true}", 0.5);
  // With obs(q) the world p = false is removed and no cr-rule restores it: P(p) = 1
  // (plog2.0 naive: 1.0).
  expectBoth("random(p).\nq :- p = true.\n:+ q.\nobs(q).\n", "?{p=true}", 1.0);
  // `:+` needs a body, as in plog2.0's grammar.
  EXPECT_THROW(
      parseProgram(std::string(kHeader) + "random(p).\n:+ .\n", "cr.plog", Dialect::Plog2),
      ParseError);
}

TEST(CrRules, NoWorldWhenNoSetRestoresConsistency) {
  // :- p. :- not p. with random(p) :+. -- inconsistent whatever is applied.
  EXPECT_THROW(ask(Backend::Asp, "random(p) :+.\n:- p.\n:- not p.\n", "?{q=true}"),
               IncoherentError);
}

}  // namespace
}  // namespace plog
}  // namespace krr
