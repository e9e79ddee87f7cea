// Tests of the Cassandra .pomdp reader and writer.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/examples/tiger.h"

#include "../support/pomdp_expect.h"
#include "../support/office_dialog.h"

namespace krr {
namespace pomdp {
using examples::makeTiger;
using dialog::DialogPomdp, dialog::DialogSpec, dialog::deliveryMatrix, dialog::ownOfficePrior;
namespace {

const std::string kData = std::string(KRR_TEST_DATA_DIR) + "/pomdp/";

using test::expectSameModel;

std::string errorAt(const std::string& text) {
  try {
    readCassandra(text, "m.pomdp");
  } catch (const ParseError& e) {
    return e.location().str() + " " + e.message();
  }
  return "no error";
}

TEST(CassandraIo, ReadsTigerFileAsTheTigerFactory) {
  Model fromFile = loadCassandra(kData + "tiger.95.pomdp");
  // 1 - 0.85 in the factory is 0.15000000000000002, the file says 0.15: compare to 1e-15
  expectSameModel(fromFile, makeTiger(), 1e-15);
}

TEST(CassandraIo, RoundTripTiger) {
  Model tiger = makeTiger();
  Model back = readCassandra(writeCassandra(tiger));
  expectSameModel(back, tiger);
  // read -> write -> read of the file version too
  Model f = loadCassandra(kData + "tiger.95.pomdp");
  expectSameModel(readCassandra(writeCassandra(f)), f);
}

TEST(CassandraIo, RoundTripDialogModel) {
  DialogSpec spec = dialog::test::officeSpec();
  spec.prior = ownOfficePrior(3, 5, {0, 1}, 0.8);
  Eigen::VectorXd reach(5);
  reach << 0.95, 0.65, 0.75, 0.95, 0.5;
  spec.delivery = deliveryMatrix(3, reach, 2);
  DialogPomdp dialog(spec);
  Model back = readCassandra(dialog.exportCassandra(), "dialog.pomdp");
  expectSameModel(back, dialog.model());
  Model again = readCassandra(writeCassandra(back));
  expectSameModel(again, back);
}

TEST(CassandraIo, LessCommonFormsByHand) {
  Model m = loadCassandra(kData + "forms.pomdp");
  ASSERT_EQ(m.getS(), 3u);
  ASSERT_EQ(m.getA(), 2u);
  ASSERT_EQ(m.getO(), 2u);
  EXPECT_EQ(m.stateNames()[2], "s2");  // counts get default names
  EXPECT_DOUBLE_EQ(m.getDiscount(), 0.9);
  EXPECT_DOUBLE_EQ(m.initialBelief()(2), 0.5);
  const std::size_t go = m.actionIndex("go"), stay = m.actionIndex("stay");
  EXPECT_TRUE(m.isIdentityTransition(stay));
  // T: go : * row "0 1 0", then row 1 cleared and set to s2, row 2 set to {s0 .5, s2 .5}
  EXPECT_EQ(m.getTransitionProbability(0, go, 1), 1.0);
  EXPECT_EQ(m.getTransitionProbability(1, go, 1), 0.0);
  EXPECT_EQ(m.getTransitionProbability(1, go, 2), 1.0);
  EXPECT_EQ(m.getTransitionProbability(2, go, 0), 0.5);
  EXPECT_EQ(m.getTransitionProbability(2, go, 2), 0.5);
  // O: uniform by wildcards, then go in s2 always gives o0
  EXPECT_EQ(m.getObservationProbability(1, stay, 1), 0.5);
  EXPECT_EQ(m.getObservationProbability(2, go, 0), 1.0);
  // values: cost, so rewards are negated costs:
  // R(s0, stay) = -(0.5*1 + 0.5*2) = -1.5 (matrix form, s' = s0 under identity)
  EXPECT_DOUBLE_EQ(m.getExpectedReward(0, stay), -1.5);
  EXPECT_DOUBLE_EQ(m.getExpectedReward(1, stay), 0.0);
  // R(s1, go) = -(1.0 * 10) = -10; R(s2, go) = -(0.5 * 0 + 0.5 * 10) = -5;
  // R(s0, go) = 0: the "7 8" row is for s' = s2, which go never reaches from s0.
  EXPECT_DOUBLE_EQ(m.getExpectedReward(1, go), -10.0);
  EXPECT_DOUBLE_EQ(m.getExpectedReward(2, go), -5.0);
  EXPECT_DOUBLE_EQ(m.getExpectedReward(0, go), 0.0);
}

TEST(CassandraIo, StartForms) {
  const std::string head =
      "discount: 0.5\nstates: a b c\nactions: x\nobservations: o\nT: x identity\nO: x uniform\n";
  EXPECT_DOUBLE_EQ(readCassandra(head + "start: b\n").initialBelief()(1), 1.0);
  EXPECT_DOUBLE_EQ(readCassandra(head + "start: 2\n").initialBelief()(2), 1.0);
  Model inc = readCassandra(head + "start include: a c\n");
  EXPECT_DOUBLE_EQ(inc.initialBelief()(0), 0.5);
  EXPECT_DOUBLE_EQ(inc.initialBelief()(1), 0.0);
  Model exc = readCassandra(head + "start exclude: a\n");
  EXPECT_DOUBLE_EQ(exc.initialBelief()(0), 0.0);
  EXPECT_DOUBLE_EQ(exc.initialBelief()(2), 0.5);
  EXPECT_DOUBLE_EQ(readCassandra(head).initialBelief()(0), 1.0 / 3.0);  // default uniform
}

TEST(CassandraIo, ParseErrorPositions) {
  const std::string head = "discount: 0.9\nstates: a b\nactions: x\nobservations: o\n";
  // line 5, column 12: the unknown state name
  EXPECT_EQ(errorAt(head + "T: x : a : zz 1\n"), "m.pomdp:5:12 unknown state 'zz'");
  // line 5, column 14: a probability that is not a number / not in [0, 1]
  EXPECT_EQ(errorAt(head + "O: x : a : o half\n").substr(0, 12), "m.pomdp:5:14");
  EXPECT_EQ(errorAt(head + "T: x\nidentity\nO: x : a : o 1.5\n").substr(0, 12), "m.pomdp:7:14");
  // missing colon after the keyword
  EXPECT_EQ(errorAt("discount 0.9\n").substr(0, 11), "m.pomdp:1:1");
  // unknown keyword at line 5
  EXPECT_EQ(errorAt(head + "Q: x\n").substr(0, 11), "m.pomdp:5:1");
  // rows that do not sum to one point at the entry that last wrote them
  EXPECT_EQ(errorAt(head + "T: x : a : a 0.5\nT: x : b : b 1\nO: x uniform\n"),
            "m.pomdp:5:1 transition probabilities of action 'x' from state 'a' sum to 0.5 "
            "(expected 1 within 0.0001)");
  // the discount must be in (0, 1]
  EXPECT_EQ(errorAt("discount: 1.5\n").substr(0, 12), "m.pomdp:1:11");
  // T before states
  EXPECT_EQ(errorAt("discount: 0.9\nT: x identity\n").substr(0, 11), "m.pomdp:2:1");
  // truncated file: position of the end of input
  EXPECT_EQ(errorAt(head + "T: x : a :").substr(0, 12), "m.pomdp:5:11");
  // values must be reward or cost
  EXPECT_EQ(errorAt("discount: 0.9\nvalues: money\n").substr(0, 11), "m.pomdp:2:9");
}

// Issue 24: rewards of +-1e308 were read, and pomdp_solve printed bounds -inf / -inf, gap nan
// as "valid bounds". Every reward entry must be within Model::kMaxAbsReward, in every R form.
TEST(CassandraIo, RewardsThatWouldMakeBoundsInfiniteAreRefusedAtTheirToken) {
  const std::string head = "discount: 0.95\nstates: a b\nactions: x\nobservations: o p\n"
                           "T: x identity\nO: x uniform\n";
  EXPECT_EQ(errorAt(head + "R: x : a : * : * 1e308\n"),
            "m.pomdp:7:18 reward 1e308 is outside [-1e+12, 1e+12], the limit that keeps "
            "|R| / (1 - discount) and |R| * horizon finite");
  EXPECT_EQ(errorAt(head + "R: x : a : b : o -1e308\n").substr(0, 13), "m.pomdp:7:18 ");
  // row (over observations) and matrix (next states x observations) forms: at the entry
  EXPECT_EQ(errorAt(head + "R: x : a : b 1 -2e12\n").substr(0, 13), "m.pomdp:7:16 ");
  EXPECT_EQ(errorAt(head + "R: x : a\n1 2\n3 1.5e12\n").substr(0, 12), "m.pomdp:9:3 ");
  // costs are negated rewards: the same limit
  EXPECT_EQ(errorAt("values: cost\n" + head + "R: x : * : * : * 1e13\n").substr(0, 13),
            "m.pomdp:8:18 ");
  // non-finite numbers were refused already, as numbers
  EXPECT_EQ(errorAt(head + "R: x : a : * : * inf\n").substr(0, 13), "m.pomdp:7:18 ");
  // the limit itself is accepted, with a discount close to 1: the bounds stay finite
  const Model m = readCassandra("discount: 0.9999999\nstates: a b\nactions: x\n"
                                "observations: o p\nT: x identity\nO: x uniform\n"
                                "R: x : a : * : * 1e12\nR: x : b : * : * -1e12\n");
  EXPECT_EQ(m.getExpectedReward(0, 0), 1e12);
  EXPECT_EQ(m.getExpectedReward(1, 0), -1e12);
}

// "states: -2" was read as one state named -2 and the error surfaced 19 lines later; a NUL
// byte after the discount was accepted ("0.95\0" read as 0.95).
TEST(CassandraIo, NegativeCountsNumericNamesAndNulBytesAreRefusedWhereTheyAre) {
  const std::string rest = "actions: x\nobservations: o\nT: x identity\nO: x uniform\n";
  EXPECT_EQ(errorAt("discount: 0.95\nstates: -2\n" + rest),
            "m.pomdp:2:9 number of states must be a positive integer, got '-2'");
  EXPECT_EQ(errorAt("discount: 0.95\nstates: 2.5\n" + rest),
            "m.pomdp:2:9 number of states must be a positive integer, got '2.5'");
  EXPECT_EQ(errorAt("discount: 0.95\nstates: 0\n" + rest),
            "m.pomdp:2:9 number of states must be positive");
  EXPECT_EQ(errorAt("discount: 0.95\nstates: 3\nactions: -1\n").substr(0, 13),
            "m.pomdp:3:10 ");
  EXPECT_EQ(errorAt("discount: 0.95\nstates: a 7 b\n" + rest),
            "m.pomdp:2:11 '7' is a number, not a name: states are a positive count or a list "
            "of names");
  EXPECT_EQ(errorAt(std::string("discount: 0.95") + '\0' + "\nstates: 2\n" + rest),
            "m.pomdp:1:15 NUL byte (\\0) in the file: a .pomdp file is text");
  EXPECT_EQ(errorAt(std::string("discount: 0.95\nstates: 2\nactions: x") + '\0' + "y\n" + rest)
                .substr(0, 13),
            "m.pomdp:3:11 ");
  // a NUL byte in a comment is refused too: the file is not text
  EXPECT_EQ(errorAt(std::string("# a") + '\0' + "b\ndiscount: 0.95\n").substr(0, 12), "m.pomdp:1:4 ");
}

// The standard benchmark files are written with six decimals: TagAvoid.pomdp was refused with
// "transition probabilities of action 'North' from state 's837' sum to 1.000001" (issue 15).
TEST(CassandraIo, SixDecimalRowsAreRenormalisedAndTheLargestDeviationReported) {
  const std::string text =
      "discount: 0.95\nvalues: reward\nstates: a b c\nactions: x y\nobservations: o p\n"
      "start: 0.333333 0.333333 0.333333\n"
      "T: x\n0.333334 0.333334 0.333333\n0.5 0.5 0\n0 0 1\n"  // row a: 1.000001
      "T: y identity\n"
      "O: * : * : o 0.66667\nO: * : * : p 0.33333\n"          // every row: 1.0
      "O: y : c : o 0.166667\nO: y : c : p 0.833331\n"        // 0.999998
      "R: * : * : * : * 1\n";
  CassandraStats stats;
  const Model m = readCassandra(text, "six.pomdp", CassandraLimits(), &stats);
  EXPECT_NEAR(stats.max_sum_deviation, 2e-6, 1e-12);
  EXPECT_EQ(stats.max_deviation_where, "O row of action 'y' in state 'c'");
  EXPECT_EQ(stats.renormalised_rows, 3u);  // start, T(x, a), O(y, c)
  for (std::size_t a = 0; a < m.getA(); ++a)
    for (std::size_t s = 0; s < m.getS(); ++s) {
      EXPECT_NEAR(m.denseTransition(a).row(static_cast<Eigen::Index>(s)).sum(), 1.0, 1e-15);
      EXPECT_NEAR(m.denseObservation(a).row(static_cast<Eigen::Index>(s)).sum(), 1.0, 1e-15);
    }
  EXPECT_NEAR(m.getTransitionProbability(0, 0, 2), 0.333333 / 1.000001, 1e-15);
  EXPECT_NEAR(m.initialBelief().sum(), 1.0, 1e-15);
  // Exact files report nothing.
  CassandraStats exact;
  loadCassandra(kData + "tiger.95.pomdp", CassandraLimits(), &exact);
  EXPECT_LT(exact.max_sum_deviation, 1e-12);
  EXPECT_EQ(exact.renormalised_rows, 0u);
  // A tolerance of zero restores the strict reading.
  CassandraLimits strict;
  strict.sum_tolerance = 0.0;
  try {
    readCassandra(text, "six.pomdp", strict);
    ADD_FAILURE() << "accepted with sum_tolerance 0";
  } catch (const ParseError& e) {
    EXPECT_EQ(std::string(e.what()).substr(0, 13), "six.pomdp:6:8") << e.what();
  }
}

TEST(CassandraIo, RealProbabilityErrorsAreStillRefusedWithTheirPosition) {
  const std::string head = "discount: 0.9\nstates: a b\nactions: x\nobservations: o\nO: x uniform\n";
  // Off by 1e-3, beyond the 1e-4 tolerance: the entry that last wrote the row.
  EXPECT_EQ(errorAt(head + "T: x identity\nT: x : a\n0.5 0.501\n"),
            "m.pomdp:7:1 transition probabilities of action 'x' from state 'a' sum to 1.001 "
            "(expected 1 within 0.0001)");
  // Just inside and just outside the tolerance.
  EXPECT_EQ(errorAt(head + "T: x identity\nT: x : a : b 0.00009\n"), "no error");
  EXPECT_EQ(errorAt(head + "T: x identity\nT: x : a : b 0.00011\n").substr(0, 11),
            "m.pomdp:7:1");
  // Negative entries, even tiny ones, at their token (a renormalised row must stay >= 0).
  EXPECT_EQ(errorAt(head + "T: x identity\nT: x : a : b -0.000001\n").substr(0, 13),
            "m.pomdp:7:14 ");
  EXPECT_EQ(errorAt(head + "T: x identity\nT: x : a : b -0.000001\n").substr(13),
            "transition probability -0.000001 is not in [0, 1]");
  // An observation row off by more than the tolerance.
  EXPECT_EQ(errorAt("discount: 0.9\nstates: a b\nactions: x\nobservations: o p\n"
                    "T: x identity\nO: x : b\n0.6 0.3\nO: x : a\n0.5 0.5\n")
                .substr(0, 11),
            "m.pomdp:6:1");
  // The start vector too.
  EXPECT_EQ(errorAt(head + "T: x identity\nstart: 0.5 0.4\n").substr(0, 12), "m.pomdp:7:8 ");
}

TEST(CassandraIo, WriterRejectsNamesOtherToolsCannotRead) {
  Model m = makeTiger();
  m.setNames({"tiger left", "tiger-right"}, {"listen", "open-left", "open-right"},
             {"tiger-left", "tiger-right"});
  EXPECT_THROW(writeCassandra(m), ConfigError);
}

TEST(CassandraIo, MissingFileIsAnIoError) {
  EXPECT_THROW(loadCassandra(kData + "does-not-exist.pomdp"), IoError);
}

std::string budgetError(const std::string& text, std::size_t budget = 0) {
  CassandraLimits limits;
  limits.memory_budget = budget;
  try {
    readCassandra(text, "m.pomdp", limits);
  } catch (const ParseError& e) {
    return e.what();
  }
  return "no error";
}

// The 97-byte file of issue 12 asked for ~75 GiB and died in bad_alloc. The model is sparse now
// (about 232 bytes per state and action, plus the entries), so the declared sizes that are
// refused at their declaration are larger; entries are checked as they arrive.
TEST(CassandraIo, DeclaredSizesAboveTheMemoryBudgetAreRefused) {
  const std::string big =
      "discount: 0.95\nvalues: reward\nstates: 5000000\nactions: 1\nobservations: 1\n"
      "T: * identity\nO: * uniform\n";
  // 1 GiB, the smallest default (the default follows the machine: limits.h).
  const std::size_t gib = std::size_t(1) << 30;
  const std::string e = budgetError(big, gib);
  EXPECT_EQ(e.substr(0, 13), "m.pomdp:3:9: ") << e;
  EXPECT_NE(e.find("states: 5000000 needs about"), std::string::npos) << e;
  EXPECT_NE(e.find("GiB"), std::string::npos) << e;
  EXPECT_NE(e.find("memory budget of 1 GiB"), std::string::npos) << e;
  // The product is what counts: a later declaration can push it over the budget.
  const std::string e2 = budgetError("discount: 0.9\nstates: 20000\nactions: 500\n", gib);
  EXPECT_EQ(e2.substr(0, 12), "m.pomdp:3:10") << e2;
  EXPECT_NE(e2.find("actions: 500"), std::string::npos) << e2;
  // Counts whose products overflow 64 bits saturate instead of wrapping to a small size.
  EXPECT_NE(budgetError("discount: 0.9\nstates: 4294967296\nactions: 4294967296\n")
                .find("states: 4294967296"), std::string::npos);
  // A configurable budget: 100 states fit in 1 GiB but not in 20 kB.
  const std::string small = "discount: 0.9\nstates: 100\nactions: a\nobservations: o\n"
                            "T: a identity\nO: a uniform\n";
  EXPECT_EQ(budgetError(small), "no error");
  EXPECT_NE(budgetError(small, 20000).find("states: 100 needs about"), std::string::npos)
      << budgetError(small, 20000);
  // A long name list is refused as well (here at the end of the list, at its keyword).
  std::string names = "discount: 0.9\nstates:";
  for (int i = 0; i < 300; ++i) names += " s" + std::to_string(i);
  EXPECT_NE(budgetError(names + "\n", 50000).find("m.pomdp:2:1: states: (300 names)"),
            std::string::npos) << budgetError(names + "\n", 50000);
  // The token list itself is held to the budget.
  EXPECT_NE(budgetError(small, 500).find("tokens"), std::string::npos);
  // A caller's own per-state-pair needs count too.
  CassandraLimits solver;
  solver.memory_budget = 150000;
  solver.extra_bytes_per_state_pair = 16;
  EXPECT_NO_THROW(readCassandra(small, "m.pomdp", CassandraLimits{150000, 0.0, 0}));
  EXPECT_THROW(readCassandra(small, "m.pomdp", solver), ParseError);
}

// The number of non-zero entries is not declared: a statement that would store more than the
// budget allows is refused at its position, before it is stored.
TEST(CassandraIo, EntriesBeyondTheMemoryBudgetAreRefusedAsTheyArrive) {
  const std::string head = "discount: 0.9\nstates: 3000\nactions: a b\nobservations: o\n";
  EXPECT_EQ(budgetError(head + "T: * identity\nO: * uniform\n", 8u << 20), "no error");
  // "uniform" is 9e6 entries per action: 288 MB in the reader.
  const std::string e = budgetError(head + "T: a identity\nT: b uniform\nO: * uniform\n", 8u << 20);
  EXPECT_EQ(e.substr(0, 12), "m.pomdp:6:1:") << e;
  EXPECT_NE(e.find("non-zero T and O entries"), std::string::npos) << e;
}

TEST(CassandraIo, EstimateSaturatesInsteadOfWrapping) {
  EXPECT_EQ(estimateModelBytes(std::size_t(1) << 32, std::size_t(1) << 32, 1), SIZE_MAX);
  // Small models are also kept dense (T and its transpose)...
  EXPECT_GE(estimateModelBytes(64, 1, 1), 2u * 64 * 64 * sizeof(double));
  // ... large ones only sparse: RockSample[5,7] (3201 states, 12 actions, 2 observations).
  EXPECT_LT(estimateModelBytes(3201, 12, 2), std::size_t(16) << 20);
}

TEST(CassandraIo, TimeBudgetStopsReading) {
  // Each wildcard statement rewrites every row: many of them take long, and the reader stops.
  std::string text = "discount: 0.9\nstates: 300\nactions: a\nobservations: o\n";
  for (int i = 0; i < 20000; ++i) text += "T: * : * uniform\n";
  text += "O: a uniform\n";
  CassandraLimits limits;
  limits.timeout = 0.05;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    readCassandra(text, "slow.pomdp", limits);
    ADD_FAILURE() << "no timeout";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("time budget"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).substr(0, 10), "slow.pomdp");
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
}

TEST(CassandraIo, SpecialFilesAreRefused) {
  for (const char* path : {"/dev/zero", "/dev/null", "/tmp"}) {
    try {
      loadCassandra(path);
      ADD_FAILURE() << "no error for " << path;
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("expected a regular file"), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
