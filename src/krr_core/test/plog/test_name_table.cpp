// NameTable and AttributeIndex (interned names of the P-log front end, issue 24), and the
// grounder paths they made linear: dynamic attributes along a long rule chain, a cone computed
// once (IncrementalGrounder::ClosedCone), facts of attributes outside the cone.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/plog/grounder.h"
#include "krr_core/plog/name_table.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

TEST(PlogNameTable, InternsDenseIdsInOrder) {
  NameTable t;
  EXPECT_TRUE(t.empty());
  EXPECT_EQ(t.find("a"), -1);
  EXPECT_EQ(t.intern("a"), 0);
  EXPECT_EQ(t.intern("b"), 1);
  EXPECT_EQ(t.intern("a"), 0);  // the same name keeps its id
  EXPECT_EQ(t.intern(""), 2);   // the empty name is a name
  EXPECT_EQ(t.size(), 3u);
  EXPECT_EQ(t.find("b"), 1);
  EXPECT_EQ(t.find(""), 2);
  EXPECT_EQ(t.find("c"), -1);
  EXPECT_EQ(t.name(0), "a");
  EXPECT_EQ(t.name(1), "b");
  t.clear();
  EXPECT_EQ(t.size(), 0u);
  EXPECT_EQ(t.find("a"), -1);
  EXPECT_EQ(t.intern("b"), 0);
}

TEST(PlogNameTable, KeepsEveryNameThroughGrowth) {
  // far beyond the first table: every rehash must keep every id
  NameTable t;
  const int n = 50000;
  for (int i = 0; i < n; ++i) ASSERT_EQ(t.intern("name_" + std::to_string(i)), i);
  for (int i = 0; i < n; ++i) {
    ASSERT_EQ(t.find("name_" + std::to_string(i)), i);
    ASSERT_EQ(t.name(i), "name_" + std::to_string(i));
  }
  EXPECT_EQ(t.find("name_" + std::to_string(n)), -1);
  // names that share a long prefix and differ at the end, and reserve() before use
  NameTable u;
  u.reserve(1000);
  const std::string prefix(100, 'x');
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(u.intern(prefix + std::to_string(i)), i);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(u.find(prefix + std::to_string(i)), i);
  EXPECT_EQ(u.find(prefix), -1);
}

TEST(PlogAttributeIndex, UsesTheParsersHintsAndChecksThem) {
  Program p = parseProgram("s = {a, b}.\nx : s.\ny : s.\nrandom(x).\np :- y = a.\n", "idx");
  const AttributeIndex index(p);
  EXPECT_TRUE(index.usesHints());
  const int x = index.find("x"), y = index.find("y"), pp = index.find("p");
  ASSERT_GE(x, 0);
  ASSERT_GE(y, 0);
  ASSERT_GE(pp, 0);
  EXPECT_EQ(p.attributes[static_cast<size_t>(x)].name, "x");
  EXPECT_EQ(index.find("nothing"), -1);
  // the parser set the hints: they name the declarations
  const Rule& r = p.rules.back();
  ASSERT_TRUE(r.head.has_value());
  EXPECT_EQ(r.head->attr.index, pp);
  EXPECT_EQ(r.body.at(0).atom.attr.index, y);
  EXPECT_EQ(p.random_rules.at(0).attr.index, x);
  EXPECT_EQ(index.of(r.head->attr), pp);
  // a hint that names another attribute (a term moved between programs) is not trusted
  AttributeTerm stale = r.body.at(0).atom.attr;
  stale.index = x;
  EXPECT_EQ(index.of(stale), y);
  stale.index = 1000;  // out of range
  EXPECT_EQ(index.of(stale), y);
  AttributeTerm unknown;
  unknown.name = "nothing";
  unknown.index = x;
  EXPECT_EQ(index.of(unknown), -1);
}

TEST(PlogAttributeIndex, NameDeclaredTwiceDisablesHints) {
  // the parser never makes such a program; built by hand, its duplicates map to the first
  // declaration, or to the last one with last_wins (as the grounder always did)
  Program p;
  for (const char* n : {"a", "b", "a"}) {
    AttributeDecl d;
    d.name = n;
    d.range_sort = "boolean";
    p.attributes.push_back(d);
  }
  const AttributeIndex first(p), last(p, true);
  EXPECT_FALSE(first.usesHints());
  EXPECT_EQ(first.find("a"), 0);
  EXPECT_EQ(last.find("a"), 2);
  EXPECT_EQ(first.find("b"), 1);
  AttributeTerm t;
  t.name = "a";
  t.index = 2;
  EXPECT_EQ(first.of(t), 0);  // looked up, not taken from the hint
  EXPECT_EQ(last.of(t), 2);
}

TEST(PlogNameTable, LongChainEndingInRandomAttributeIsDynamicThroughout) {
  // b_i :- b_{i+1}, ..., b_n :- r = t with r random: every b_i is derived from r, so every one
  // is dynamic (found by propagation along the chain, in any rule order)
  const int n = 3000;
  std::string text = "t2 = {t, f}.\nr : t2.\nrandom(r).\npr(r = t) = 0.3.\n";
  for (int i = n - 1; i >= 0; --i)  // heads before their bodies' definitions, reversed
    text += "b" + std::to_string(i) + " :- b" + std::to_string(i + 1) + ".\n";
  text += "b" + std::to_string(n) + " :- r = t.\n";
  Reasoner rs;
  rs.setBackend(Backend::Native);
  rs.loadString(text, "chain");
  EXPECT_NEAR(rs.probability("?{b0}"), 0.3, 1e-12);
  EXPECT_NEAR(rs.probability("?{b1500}"), 0.3, 1e-12);
  const Program& p = rs.program();
  const GroundProgram g = groundProgram(p, {"b0"});
  for (const char* a : {"b0", "b1", "b3000", "r"}) {
    const int i = AttributeIndex(p).find(a);
    ASSERT_GE(i, 0) << a;
    EXPECT_TRUE(g.attr_dynamic[static_cast<size_t>(i)]) << a;
  }
}

TEST(PlogNameTable, ClosedConeGroundsLikeTheNamedAttributes) {
  Program p = parseProgram(R"(s = {a, b}.
x : s. y : s. z : s. w : s.
random(x). random(y). random(z). random(w).
pr(y = a | x = a) = 0.9.
pr(w = a | z = b) = 0.2.
)",
                           "closed");
  const std::set<std::string> cone = relevanceCone(p, {"y"});
  IncrementalGrounder named(p, std::set<std::string>{"y"});
  IncrementalGrounder closed(p, IncrementalGrounder::ClosedCone{cone});
  ASSERT_EQ(named.ground()->instances.size(), closed.ground()->instances.size());
  for (size_t i = 0; i < named.ground()->instances.size(); ++i)
    EXPECT_EQ(named.ground()->instances[i].name, closed.ground()->instances[i].name);
  EXPECT_GE(closed.ground()->findInstance("x"), 0);
  EXPECT_LT(closed.ground()->findInstance("z"), 0);
}

TEST(PlogNameTable, FactsOutsideTheConeArePatchedWithoutRegrounding) {
  // `other` is an extensional attribute that nothing reads: its facts come and go without a
  // new grounding of the query's cone, and the answers stay those of the program
  Reasoner rs;
  rs.setBackend(Backend::Native);
  rs.loadString(R"(s = {a, b}.
x : s.
random(x).
learned(a).
pr(x = a | not learned(b)) = 0.8.
other(1). other(2).
)",
                "outside");
  EXPECT_NEAR(rs.probability("?{x = a}"), 0.8, 1e-12);
  const size_t full = rs.stats().full_groundings;
  rs.addStatements("other(3).", "t");
  EXPECT_NEAR(rs.probability("?{x = a}"), 0.8, 1e-12);
  EXPECT_EQ(rs.removeStatementsWithTag("t"), 1u);
  EXPECT_EQ(rs.removeStatements(parseProgram("other(1).", "r").rules, {}), 1u);
  EXPECT_NEAR(rs.probability("?{x = a}"), 0.8, 1e-12);
  EXPECT_EQ(rs.stats().full_groundings, full);
  // a guard fact inside the cone still switches the pr-atom off
  rs.addStatements("learned(b).", "g");
  EXPECT_NEAR(rs.probability("?{x = a}"), 0.5, 1e-12);
  rs.removeStatementsWithTag("g");
  EXPECT_NEAR(rs.probability("?{x = a}"), 0.8, 1e-12);
}

namespace {

/// Every atom's hint and every name of the program's shared table name the same declaration.
void expectIdsMatchNames(const Program& p) {
  ASSERT_TRUE(p.attribute_names != nullptr);
  EXPECT_TRUE(p.attribute_names->indexes(p.attributes));
  const AttributeIndex index(p);
  EXPECT_TRUE(index.shared());
  for (size_t i = 0; i < p.attributes.size(); ++i) {
    EXPECT_EQ(p.attribute_names->find(p.attributes[i].name), static_cast<int>(i))
        << p.attributes[i].name;
    EXPECT_EQ(index.find(p.attributes[i].name), static_cast<int>(i)) << p.attributes[i].name;
  }
  auto check = [&](const AttributeTerm& t) {
    if (t.index < 0) {  // made without a hint (obs(...) tests): found by its name
      EXPECT_GE(index.find(t.name), 0) << t.name;
      return;
    }
    ASSERT_LT(static_cast<size_t>(t.index), p.attributes.size()) << t.name;
    EXPECT_EQ(p.attributes[static_cast<size_t>(t.index)].name, t.name);
    EXPECT_EQ(p.attributes[static_cast<size_t>(t.index)].arg_sorts.size(), t.args.size()) << t.name;
  };
  for (const auto& r : p.rules) {
    if (r.head) check(r.head->attr);
    for (const auto& l : r.body)
      if (l.kind == Literal::Kind::Atom) check(l.atom.attr);
  }
  for (const auto& r : p.random_rules) check(r.attr);
}

}  // namespace

TEST(PlogAttributeNames, ParserInternsEachNameOnceAndIdsNameTheirDeclarations) {
  // facts and rules whose implicit predicates are used before they are defined (declared in
  // head order, interned in order of use), one predicate overloaded by arity (renamed r_2),
  // an explicit declaration after a use in a body, obs tested in a body
  const std::string text = R"(s = {a, b}.
x : s.
random(x).
q :- r(a), x = a.
u :- w.
r(a).
r(a, b).
t :- r(a, b).
w.
v :- not obs(x, b).
obs(x = a).
)";
  const Program p = parseProgram(text, "ids");
  expectIdsMatchNames(p);
  const AttributeIndex index(p);
  for (const char* n : {"x", "q", "r", "r_2", "t", "u", "w", "v", "obs"})
    EXPECT_GE(index.find(n), 0) << n;
  EXPECT_EQ(p.attributes[static_cast<size_t>(index.find("r"))].arg_sorts.size(), 1u);
  EXPECT_EQ(p.attributes[static_cast<size_t>(index.find("r_2"))].arg_sorts.size(), 2u);
  Reasoner rs;
  rs.setBackend(Backend::Native);
  rs.loadString(text, "ids");
  EXPECT_NEAR(rs.probability("?{q}"), 1.0, 1e-12);  // x = a is observed
  EXPECT_NEAR(rs.probability("?{t}"), 1.0, 1e-12);
  EXPECT_NEAR(rs.probability("?{u}"), 1.0, 1e-12);
  EXPECT_NEAR(rs.probability("?{v}"), 1.0, 1e-12);
}

TEST(PlogAttributeNames, ManyFactsInOrderShareTheParsersTable) {
  // the bench's shape (ids in declaration order: the table is handed over as it is), with a
  // head repeated and a rule whose body names a later fact
  std::string text = "a :- q7.\n";
  for (int i = 0; i < 3000; ++i) text += "q" + std::to_string(i) + ".\n";
  text += "q5.\n";
  const Program p = parseProgram(text, "facts");
  expectIdsMatchNames(p);
  EXPECT_EQ(p.attributes.size(), 3001u);
  Reasoner rs;
  rs.setBackend(Backend::Native);
  rs.loadString(text, "facts");
  EXPECT_NEAR(rs.probability("?{a}"), 1.0, 1e-12);
  EXPECT_NEAR(rs.probability("?{q2999}"), 1.0, 1e-12);
}

TEST(PlogAttributeNames, StaleTableIsNotUsed) {
  Program p = parseProgram("s = {a, b}.\nx : s.\nrandom(x).\ny :- x = a.\n", "stale");
  ASSERT_TRUE(p.attribute_names != nullptr);
  // edited by hand after parsing: the shared table no longer names the declarations
  Program renamed = p;
  const int y = AttributeIndex(p).find("y");
  ASSERT_GE(y, 0);
  renamed.attributes[static_cast<size_t>(y)].name = "z";
  EXPECT_FALSE(renamed.attribute_names->indexes(renamed.attributes));
  const AttributeIndex ri(renamed);
  EXPECT_FALSE(ri.shared());
  EXPECT_EQ(ri.find("z"), y);
  EXPECT_EQ(ri.find("y"), -1);
  Program added = p;
  AttributeDecl d;
  d.name = "x";  // a duplicate, appended
  d.range_sort = "boolean";
  added.attributes.push_back(d);
  const AttributeIndex first(added), last(added, true);
  EXPECT_FALSE(first.shared());
  EXPECT_FALSE(first.usesHints());
  EXPECT_EQ(first.find("x"), AttributeIndex(p).find("x"));
  EXPECT_EQ(last.find("x"), static_cast<int>(added.attributes.size() - 1));
  // a copy that nobody edited keeps using it
  const Program copy = p;
  EXPECT_TRUE(AttributeIndex(copy).shared());
}

TEST(PlogAttributeNames, StatementsAddedLaterDeclareNewPredicates) {
  Reasoner rs;
  rs.setBackend(Backend::Native);
  rs.loadString("s = {a, b}.\nx : s.\nrandom(x).\nf.\n", "base");
  rs.addStatements("g :- f, x = a.\nh.\n", "t");
  expectIdsMatchNames(rs.program());
  EXPECT_NEAR(rs.probability("?{g}"), 0.5, 1e-12);
  EXPECT_NEAR(rs.probability("?{h}"), 1.0, 1e-12);
  rs.addStatements("k :- h.\n", "t2");
  EXPECT_NEAR(rs.probability("?{k}"), 1.0, 1e-12);
}
