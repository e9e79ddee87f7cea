// Issue 24: grounding stays inside the query's relevance cone at the level of attribute
// instances. A query about one atom of a large random relation grounds that atom only; the
// restricted grounding answers like the full one (differential test on random small programs
// with observations, do-statements, pr-atoms, rule chains, constraints and dynamic ranges);
// a cone that is large stays large, and its budgets still hold.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"
#include "krr_core/plog/budget.h"
#include "krr_core/plog/grounder.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

namespace {

std::string bigRelation(int n) {
  return "n = {1.." + std::to_string(n) + "}.\np : n, n -> boolean.\nrandom(p(X, Y)).\n";
}

/// A native reasoner whose groundings are restricted to the query's instances always
/// (restricted) or never (the full grounding of the cone's attributes).
std::unique_ptr<Reasoner> makeReasoner(const std::string& text, bool restricted) {
  auto r = std::make_unique<Reasoner>();
  r->setBackend(Backend::Native);
  GroundingLimits lim;
  lim.cone_restrict_min_instances = restricted ? 0 : std::numeric_limits<std::size_t>::max();
  r->setLimits(lim);
  r->loadString(text, "cone.plog");
  return r;
}

}  // namespace

TEST(PlogRelevanceCone, OneAtomOfAHugeRelation) {
  // 2300 x 2300 = 5.29 M instances of p; the query reads one of them.
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(bigRelation(2300), "big.plog");
  Stopwatch sw;
  EXPECT_NEAR(r.probability("?{p(1,1)=true}"), 0.5, 1e-12);
  EXPECT_TRUE(r.stats().ground_restricted);
  EXPECT_EQ(r.stats().ground_instances, 1u);
  EXPECT_LE(r.stats().ground_statements, 1u);
  // conditioned on another atom (independent), and on itself
  EXPECT_NEAR(r.probability("?{p(1,1)=true} | obs(p(2,7)=false)"), 0.5, 1e-12);
  EXPECT_EQ(r.stats().ground_instances, 2u);
  EXPECT_NEAR(r.probability("?{p(1,1)=true} | obs(p(1,1)=true)"), 1.0, 1e-12);
  EXPECT_NEAR(r.probability("?{p(5,9)=false} | do(p(5,9)=true)"), 0.0, 1e-12);
  const auto d = r.distribution("p(3,4)");
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NEAR(d[0].probability, 0.5, 1e-12);
  EXPECT_EQ(r.stats().ground_instances, 1u);
  // one grounding per distinct query (the oldest dropped past a bound): many stay cheap
  for (int i = 1; i <= 200; ++i)
    ASSERT_NEAR(r.probability("?{p(" + std::to_string(i) + "," + std::to_string(2301 - i) +
                              ")=true}"), 0.5, 1e-12);
  EXPECT_NEAR(r.probability("?{p(1,1)=true}"), 0.5, 1e-12);
  EXPECT_EQ(r.stats().ground_instances, 1u);
  EXPECT_LT(sw.seconds(), 5.0);  // (a full grounding ran out of its memory budget)
}

TEST(PlogRelevanceCone, RuleChainsAndPrAtomsOverAHugeRelation) {
  // q(X) reads p(X, X) and r(X); pr-atoms of p read r. The cone of q(7) is q(7), p(7,7), r(7).
  const std::string text = bigRelation(2000) +
                           "r : n -> boolean.\nrandom(r(X)).\npr(r(X) = true) = 0.2.\n"
                           "pr(p(X, Y) = true | r(X) = true) = 0.9.\n"
                           "q : n -> boolean.\nq(X) = true :- p(X, X) = true, r(X) = true.\n";
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(text, "chain.plog");
  // P(q(7)) = P(r(7)) * P(p(7,7) | r(7)) = 0.2 * 0.9
  EXPECT_NEAR(r.probability("?{q(7)=true}"), 0.18, 1e-12);
  EXPECT_TRUE(r.stats().ground_restricted);
  EXPECT_EQ(r.stats().ground_instances, 3u);
  // P(r(7) | p(7,7)) = 0.2 * 0.9 / (0.2 * 0.9 + 0.8 * 0.5)
  EXPECT_NEAR(r.probability("?{r(7)=true} | obs(p(7,7)=true)"), 0.18 / (0.18 + 0.4), 1e-12);
  EXPECT_NEAR(r.probability("?{q(7)=true} | do(r(7)=true)"), 0.9, 1e-12);
}

TEST(PlogRelevanceCone, ALargeConeIsGroundEntirely) {
  // `any` reads every atom of p: the cone is all of p, and the answer is 1 - 2^-16.
  const std::string text = bigRelation(4) + "any : boolean.\nany = true :- p(X, Y) = true.\n";
  for (bool restricted : {true, false}) {
    std::unique_ptr<Reasoner> r = makeReasoner(text, restricted);
    EXPECT_NEAR(r->probability("?{any=true}"), 1.0 - std::pow(2.0, -16), 1e-12);
    EXPECT_EQ(r->stats().ground_instances, 17u);
    EXPECT_NEAR(r->probability("?{p(2,3)=true} | obs(any=true)"), 0.5 / (1.0 - std::pow(2.0, -16)),
                1e-12);
    EXPECT_NEAR(r->probability("?{any=true} | obs(p(2,3)=false)"), 1.0 - std::pow(2.0, -15),
                1e-12);
  }
  // A constraint couples every atom of p: every cone holds all of them.
  const std::string constrained = bigRelation(3) + ":- p(1, 1) = true, p(2, 2) = true.\n";
  std::unique_ptr<Reasoner> r = makeReasoner(constrained, true);
  EXPECT_NEAR(r->probability("?{p(1,1)=true}"), 1.0 / 3.0, 1e-12);
  EXPECT_EQ(r->stats().ground_instances, 9u);
}

TEST(PlogRelevanceCone, AnAttributeDemandedAtManyPatternsIsGroundEntirely) {
  // 256 instances of p demanded: 256 ground; one more: all 400^2 (kMaxDemandPatterns)
  for (int k : {256, 257}) {
    Reasoner r;
    r.setBackend(Backend::Native);
    r.loadString(bigRelation(400), "many.plog");
    std::string q = "?{";
    for (int i = 1; i <= k; ++i) q += (i > 1 ? ", p(" : "p(") + std::to_string(i) + "," + std::to_string(i) + ")=true";
    EXPECT_NEAR(std::log2(r.probability(q + "}")), -k, 1e-9);
    EXPECT_EQ(r.stats().ground_instances, k == 256 ? 256u : 160000u);
  }
}

TEST(PlogRelevanceCone, BudgetsHoldWhenTheConeIsLarge) {
  const std::string text = bigRelation(2300) + "any : boolean.\nany = true :- p(X, Y) = true.\n";
  Reasoner r;
  r.setBackend(Backend::Native);
  GroundingLimits lim;
  lim.max_ground_atoms = 100000;
  r.setLimits(lim);
  r.loadString(text, "large.plog");
  std::string e;
  try {
    r.probability("?{any=true}");
  } catch (const BudgetExceededError& ex) {
    e = ex.what();
  }
  EXPECT_NE(e.find("large.plog:"), std::string::npos) << e;
  EXPECT_NE(e.find("grounding budget exhausted"), std::string::npos) << e;
  // the same reasoner still answers a query whose cone is small
  EXPECT_NEAR(r.probability("?{p(9,9)=true}"), 0.5, 1e-12);
}

TEST(PlogRelevanceCone, AddedPrAtomsPatchOrRegroundTheRestrictedGrounding) {
  const std::string text =
      bigRelation(1000) + "r : n -> boolean.\nrandom(r(X)).\npr(r(X) = true) = 0.2.\n";
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(text, "kb.plog");
  EXPECT_NEAR(r.probability("?{p(3,4)=true}"), 0.5, 1e-12);
  r.addStatements("pr(p(3, Y) = true) = 0.25.", "l1");
  EXPECT_NEAR(r.probability("?{p(3,4)=true}"), 0.25, 1e-12);
  EXPECT_TRUE(r.stats().ground_incremental);
  EXPECT_EQ(r.stats().ground_instances, 1u);
  // a body over r demands r(3): a fresh (still restricted) grounding
  r.removeStatementsWithTag("l1");
  r.addStatements("pr(p(3, Y) = true | r(3) = true) = 0.75.", "l2");
  EXPECT_NEAR(r.probability("?{p(3,4)=true}"), 0.2 * 0.75 + 0.8 * 0.5, 1e-12);
  EXPECT_EQ(r.stats().ground_instances, 2u);
  EXPECT_TRUE(r.stats().ground_restricted);
  r.removeStatementsWithTag("l2");
  EXPECT_NEAR(r.probability("?{p(3,4)=true}"), 0.5, 1e-12);
}

TEST(PlogRelevanceCone, AddedPrAtomsOverGroundInstancesPatch) {
  const std::string text = bigRelation(1000) +
                           "r : n -> boolean.\nrandom(r(X)).\npr(r(X) = true) = 0.2.\n"
                           "pr(p(X, Y) = true | r(X) = true, r(Y) = false) = 0.9.\n";
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(text, "kb.plog");
  // P(r3, not r4) = 0.16: 0.9; otherwise 0.5
  EXPECT_NEAR(r.probability("?{p(3,4)=true}"), 0.16 * 0.9 + 0.84 * 0.5, 1e-12);
  EXPECT_EQ(r.stats().ground_instances, 3u);
  // its body reads r(3) and r(4), ground already: patched in place
  r.addStatements("pr(p(3, Y) = true | r(3) = false, r(Y) = true) = 0.3.", "l");
  EXPECT_NEAR(r.probability("?{p(3,4)=true}"), 0.16 * 0.9 + 0.16 * 0.3 + 0.68 * 0.5, 1e-12);
  EXPECT_TRUE(r.stats().ground_incremental);
  EXPECT_EQ(r.stats().ground_instances, 3u);
  // this one reads r(9), not ground: a fresh grounding
  r.addStatements("pr(p(3, Y) = false | r(9) = true, r(3) = true, r(Y) = true) = 0.05.", "l");
  EXPECT_NEAR(r.probability("?{p(3,4)=true}"),
              0.16 * 0.9 + 0.16 * 0.3 + 0.008 * 0.95 + 0.672 * 0.5, 1e-12);
  EXPECT_FALSE(r.stats().ground_incremental);
  EXPECT_EQ(r.stats().ground_instances, 4u);
}

TEST(PlogRelevanceCone, SmallConesAreNotRestrictedByDefault) {
  const std::string text = bigRelation(3);
  Reasoner r;
  r.setBackend(Backend::Native);
  r.loadString(text, "small.plog");
  EXPECT_NEAR(r.probability("?{p(1,2)=true}"), 0.5, 1e-12);
  EXPECT_FALSE(r.stats().ground_restricted);
  EXPECT_EQ(r.stats().ground_instances, 9u);
  // the threshold applies from the next query on
  GroundingLimits lim;
  lim.cone_restrict_min_instances = 0;
  r.setLimits(lim);
  EXPECT_NEAR(r.probability("?{p(1,2)=true}"), 0.5, 1e-12);
  EXPECT_TRUE(r.stats().ground_restricted);
  EXPECT_EQ(r.stats().ground_instances, 1u);
  Program p = parseProgram(text, "small.plog");
  EXPECT_FALSE(instanceConePays(p, {"p"}, 10000));
  EXPECT_TRUE(instanceConePays(p, {"p"}, 9));
  EXPECT_TRUE(instanceConePays(parseProgram(bigRelation(2300), "b"), {"p"}, 10000));
}

// ---------------------------------------------------------------------------------------------
// Differential: random small programs, restricted grounding against the full one
// ---------------------------------------------------------------------------------------------

namespace {

/// A random program over s = {1..3}: random attributes with pr-atoms (some with dynamic
/// bodies, some about one instance), derived attributes in chains, and sometimes a dynamic
/// range, a constraint, a derived attribute with a variable head value, program-level
/// evidence, a default (`not`) rule, arithmetic in a body and in a head.
struct ProgramGen {
  std::mt19937 rng;
  explicit ProgramGen(unsigned seed) : rng(seed) {}
  int pick(int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); }
  bool coin(double p = 0.5) { return std::uniform_real_distribution<double>(0, 1)(rng) < p; }
  std::string c() { return std::to_string(1 + pick(3)); }
  std::string v() { return std::string(1, "abc"[pick(3)]); }

  std::string program() {
    std::string s = "s = {1..3}.\nv = {a, b, c}.\n";
    s += "r0 : s -> boolean.\nr1 : s, s -> v.\nr2 : s -> s.\nd0 : s -> boolean.\n"
         "d1 : s -> boolean.\nd2 : s -> s.\nok : s -> boolean.\nr3 : s -> s.\n";
    s += "random(r0(X)).\nrandom(r1(X, Y)).\n";
    s += coin() ? "random(r2(X)) :- r0(X) = true.\n" : "random(r2(X)).\n";
    const std::vector<std::string> prs = {
        "pr(r0(X) = true) = 0.3.\n",
        "pr(r0(" + c() + ") = true) = 0.8.\n",
        "pr(r1(X, Y) = a | r0(X) = true) = 0.6.\n",
        "pr(r1(X, X) = b) = 0.5.\n",
        "pr(r2(X) = " + c() + " | r1(X, " + c() + ") = c) = 0.7.\n",
        "pr(r1(" + c() + ", Y) = " + v() + " | r0(Y) = false) = 0.1.\n"};
    for (const auto& p : prs)
      if (coin(0.4)) s += p;
    const std::vector<std::string> rules = {
        "d0(X) = true :- r1(X, Y) = a, r0(Y) = true.\n",
        "d0(" + c() + ") = true :- r2(" + c() + ") = " + c() + ".\n",
        "d1(X) = true :- d0(X) = true, r2(X) = " + c() + ".\n",
        "d1(X) = true :- r1(" + c() + ", X) = " + v() + ".\n"};
    for (const auto& r : rules)
      if (coin(0.5)) s += r;
    if (coin(0.2)) s += "d1(X) = false :- not d1(X) = true.\n";
    // arithmetic: a head variable bound by a comparison, an arithmetic head argument
    if (coin(0.3)) s += "d0(X) = true :- r0(Y) = true, X = Y + 1.\n";
    if (coin(0.3)) s += "d1(X + 1) = true :- r2(X) = " + c() + ".\n";
    if (coin(0.15)) s += "d2(X) = Y :- r2(X) = Y.\n";
    if (coin(0.15)) s += ":- r0(" + c() + ") = true, r2(" + c() + ") = " + c() + ".\n";
    if (coin(0.15)) s += "ok(X) = true :- r0(X) = false.\nrandom(r3(X) : {Y : ok(Y) = true}).\n";
    if (coin(0.1)) s += "obs(r0(" + c() + ") = " + (coin() ? "true" : "false") + ").\n";
    if (coin(0.1)) s += "do(r1(" + c() + ", " + c() + ") = " + v() + ").\n";
    return s;
  }

  std::string atom() {
    switch (pick(5)) {
      case 0: return "r0(" + c() + ") = " + (coin() ? "true" : "false");
      case 1: return "r1(" + c() + "," + c() + ") = " + v();
      case 2: return "r2(" + c() + ") = " + c();
      case 3: return "d0(" + c() + ") = true";
      default: return "d1(" + c() + ") = " + (coin() ? "true" : "false");
    }
  }

  std::string query() {
    std::string q = "?{" + atom() + (coin(0.3) ? ", " + atom() : "") + "}";
    const int ev = pick(3);
    for (int i = 0; i < ev; ++i) {
      q += i == 0 ? " | " : ", ";
      if (coin(0.7)) q += "obs(" + atom() + ")";
      else if (coin(0.8)) q += pick(2) ? "do(r0(" + c() + ") = true)" : "do(r1(" + c() + "," + c() + ") = b)";
      else q += "do(d0(" + c() + ") = true)";
    }
    return q;
  }
};

/// The answer, or the kind of error ("error: ..." for any krr::Error).
std::string answer(Reasoner& r, const std::string& query) {
  try {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.12f", r.probability(query));
    return buf;
  } catch (const OutsideFragmentError&) {
    return "outside the fragment";
  } catch (const IncoherentError&) {
    return "incoherent";
  } catch (const Error& e) {
    return std::string("error ") + std::string(e.what()).substr(0, 60);
  }
}

}  // namespace

TEST(PlogRelevanceCone, RestrictedGroundingAnswersLikeTheFullOne) {
  int answered = 0, restricted_smaller = 0;
  std::map<std::string, int> hist;
  for (unsigned seed = 1; seed <= 200; ++seed) {
    ProgramGen gen(seed);
    const std::string text = gen.program();
    std::unique_ptr<Reasoner> cone_r = makeReasoner(text, true), full_r = makeReasoner(text, false);
    Reasoner& cone = *cone_r;
    Reasoner& full = *full_r;
    for (int k = 0; k < 6; ++k) {
      const std::string q = gen.query();
      const std::string a = answer(cone, q), b = answer(full, q);
      EXPECT_EQ(a, b) << "seed " << seed << "\n" << text << q;
      if (a == b && a[0] == '0') ++answered;
      else if (a == b) ++hist[a.substr(0, a.find(' '))];
      if (a == b && a[0] == '0' && cone.stats().ground_instances < full.stats().ground_instances)
        ++restricted_smaller;
    }
    // distributions too (a target attribute term with evidence)
    const std::string target = "r2(" + gen.c() + ")", ev = "obs(" + gen.atom() + ")";
    std::vector<ValueProb> da, db;
    std::string ea, eb;
    try { da = cone.distribution(target, ev); } catch (const Error&) { ea = "error"; }
    try { db = full.distribution(target, ev); } catch (const Error&) { eb = "error"; }
    EXPECT_EQ(ea, eb) << "seed " << seed << "\n" << text << target << " | " << ev;
    ASSERT_EQ(da.size(), db.size()) << "seed " << seed << "\n" << text << target << " | " << ev;
    for (size_t i = 0; i < da.size(); ++i) {
      EXPECT_EQ(da[i].value, db[i].value);
      EXPECT_NEAR(da[i].probability, db[i].probability, 1e-9) << "seed " << seed;
    }
  }
  // the comparison is not vacuous: most queries are answered, many on fewer instances
  EXPECT_GT(answered, 600);
  EXPECT_GT(restricted_smaller, 300);
  std::printf("answered %d of 1200 queries, %d on fewer instances; the others:\n", answered,
              restricted_smaller);
  for (const auto& x : hist) std::printf("  %s: %d\n", x.first.c_str(), x.second);
}
