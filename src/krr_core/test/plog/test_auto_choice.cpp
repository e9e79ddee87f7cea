// Issue 24: Backend::Auto's choice between the native engine and clingo, from the estimates of
// both (decideAuto, a pure function) and the estimates themselves (aspWorkAtoms, the native
// plan). No timing: the decisions and estimates are checked, not who answers first.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "krr_core/plog/engine.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr::plog;

namespace {

const double kInf = std::numeric_limits<double>::infinity();

AutoEstimate est(double native, double asp, bool refuses = false) {
  AutoEstimate e;
  e.native_seconds = native;
  e.asp_seconds = asp;
  e.native_refuses = refuses;
  return e;
}

std::string oneAttribute(int values) {
  return "s = {1.." + std::to_string(values) + "}.\na : s.\n[r] random(a).\n";
}

std::string conjunction(int attributes, std::string* query) {
  std::string s;
  *query = "?{";
  for (int i = 1; i <= attributes; ++i) {
    s += "a" + std::to_string(i) + " : boolean.\n[r" + std::to_string(i) + "] random(a" +
         std::to_string(i) + ").\n";
    *query += (i > 1 ? ", a" : "a") + std::to_string(i) + " = true";
  }
  *query += "}";
  return s;
}

}  // namespace

TEST(PlogAutoChoice, ClingoAloneOnlyWhenTheNativeEngineRefuses) {
  // whatever the estimates, a plan inside the fragment never gives clingo alone
  for (double native : {0.0, 1e-6, 1.0, 1e6})
    for (double asp : {0.0, 1e-6, 1.0, 1e6, kInf})
      EXPECT_NE(decideAuto(est(native, asp), 0.25).choice, AutoChoice::Asp) << native << " " << asp;
  const AutoDecision d = decideAuto(est(1.0, 1e-3, true), 0.25);
  EXPECT_EQ(d.choice, AutoChoice::Asp);
  EXPECT_EQ(d.asp_join_seconds, 0.0);
}

TEST(PlogAutoChoice, CloseEstimatesRace) {
  EXPECT_EQ(decideAuto(est(1.0, 1.0), 0.25).choice, AutoChoice::Race);
  EXPECT_EQ(decideAuto(est(1.0, 0.01), 0.25).choice, AutoChoice::Race);  // clingo far cheaper
  EXPECT_EQ(decideAuto(est(1.0, 3.99), 0.25).choice, AutoChoice::Race);
  EXPECT_EQ(decideAuto(est(1.0, std::nan("")), 0.25).choice, AutoChoice::Race);
  EXPECT_EQ(decideAuto(est(1.0, 4.0), 0.25).choice, AutoChoice::Native);  // kSureRatio
}

TEST(PlogAutoChoice, NativeAloneWithClingoJoiningOnOverrun) {
  // clingo 10x the native estimate: native, clingo joins once the native engine has overrun
  // its estimate kOverrun times or spent half clingo's estimate, at most after the race delay
  AutoDecision d = decideAuto(est(0.01, 0.1), 0.25);
  EXPECT_EQ(d.choice, AutoChoice::Native);
  EXPECT_DOUBLE_EQ(d.asp_join_seconds, 0.05);
  d = decideAuto(est(0.01, 0.1), 0.02);
  EXPECT_DOUBLE_EQ(d.asp_join_seconds, 0.02);
  d = decideAuto(est(0.02, 0.1), 0.25);
  EXPECT_DOUBLE_EQ(d.asp_join_seconds, 0.08);  // kOverrun x 0.02
  EXPECT_DOUBLE_EQ(decideAuto(est(0.01, 0.1), 0.0).asp_join_seconds, 0.0);  // race delay 0
  // clingo hopeless (kHopelessRatio): it never joins
  d = decideAuto(est(0.001, 1.0), 0.25);
  EXPECT_EQ(d.choice, AutoChoice::Native);
  EXPECT_EQ(d.asp_join_seconds, kInf);
  EXPECT_EQ(decideAuto(est(0.001, kInf), 0.0).asp_join_seconds, kInf);
}

TEST(PlogAutoChoice, WhileGroundingClingoJoinsLate) {
  AutoEstimate e;  // no plan yet
  e.asp_seconds = 0.01;
  EXPECT_EQ(decideAuto(e, 0.25).choice, AutoChoice::Native);
  EXPECT_DOUBLE_EQ(decideAuto(e, 0.25).asp_join_seconds, 0.5);  // 2 race delays
  e.asp_seconds = 100;
  EXPECT_DOUBLE_EQ(decideAuto(e, 0.25).asp_join_seconds, 50);  // half its estimate
}

TEST(PlogAutoChoice, ClingoWorkIsWorldsTimesGroundSize) {
  // one attribute over n values: n worlds of n + 2 atoms (+ 1, + 1 rule-less statement count)
  for (int n : {100, 10000}) {
    const Program p = parseProgram(oneAttribute(n), "one.plog");
    EXPECT_DOUBLE_EQ(aspWorkAtoms(p), double(n) * (n + 2 + 1)) << n;
  }
  // k independent booleans: 2^k worlds of 4k + 1 atoms
  std::string q;
  const Program p = parseProgram(conjunction(20, &q), "conj.plog");
  EXPECT_DOUBLE_EQ(aspWorkAtoms(p), std::exp2(20) * (4 * 20 + 1));
}

TEST(PlogAutoChoice, TheScaledFamiliesGoNativeWithoutClingo) {
  // the cases: auto took clingo (60 s, 2.9 GB) for one attribute over 10^4 values and
  // a conjunction over 20 attributes (7.5 s); the native engine answers in milliseconds
  Reasoner one;
  one.loadString(oneAttribute(10000), "one.plog");
  EXPECT_NEAR(one.probability("?{a = 5}"), 1e-4, 1e-15);
  EXPECT_EQ(one.stats().last_backend, Backend::Native);
  EXPECT_EQ(one.stats().last_auto_choice, AutoChoice::Native);
  EXPECT_FALSE(one.stats().last_asp_joined);
  EXPECT_EQ(decideAuto(one.stats().last_estimate, one.autoRaceDelay()).asp_join_seconds, kInf);
  for (int k : {10, 20, 30}) {
    std::string q;
    Reasoner c;
    c.loadString(conjunction(k, &q), "conj.plog");
    EXPECT_NEAR(c.probability(q), std::exp2(-k), 1e-15) << k;
    EXPECT_EQ(c.stats().last_backend, Backend::Native) << k;
    EXPECT_EQ(c.stats().last_auto_choice, AutoChoice::Native) << k;
    // the plan: k tables of 2 rows (the selections) and k indicators of 2 rows
    EXPECT_DOUBLE_EQ(c.stats().last_estimate.native_seconds,
                     4.0 * k * AutoCostModel::kNativeSecondsPerRow) << k;
  }
}

TEST(PlogAutoChoice, APlanOverTheNativeLimitGoesToClingo) {
  // obs(big) with `big` derived from 26 coins: one indicator over 2^26 rows, beyond the native
  // engine's limit; clingo answers (the observation is a constraint: one world of 2^26)
  std::string s = "c = {1..26}.\n#domain c(C).\nf : c -> boolean.\n[f] random(f(C)).\n"
                  "big : boolean.\nbig :- ";
  for (int i = 1; i <= 26; ++i) s += (i > 1 ? ", f(" : "f(") + std::to_string(i) + ")";
  s += ".\n";
  Reasoner r;
  r.loadString(s, "big.plog");
  r.setAutoRaceDelay(1000);
  EXPECT_NEAR(r.probability("?{f(1)} | obs(big)"), 1.0, 1e-12);
  EXPECT_EQ(r.stats().last_auto_choice, AutoChoice::Asp);
  EXPECT_TRUE(r.stats().last_estimate.native_refuses);
  EXPECT_EQ(r.stats().last_backend, Backend::Asp);
}
