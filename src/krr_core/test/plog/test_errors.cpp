// Incoherence and unsupported-construct errors: typed, naming what and where.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
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

TEST(PlogErrors, UnsupportedConstructsNamed) {
  Reasoner r;
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
