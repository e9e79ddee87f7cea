// Tests of the PomdpX (SARSOP XML) reader and writer.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_core/pomdp/pomdpx_io.h"

#include "../support/pomdp_expect.h"

namespace krr {
namespace pomdp {
namespace {

const std::string kData = std::string(KRR_TEST_DATA_DIR) + "/pomdp/";

using test::expectSameModel;

/// A factored problem written for these tests. pos is fully observable, door is not (and its
/// transition depends on the next pos); two reward functions depend on the next state and on
/// the observation, so R(s, a) is an expectation. Every TBL form appears: value names,
/// indices, '*', '-', 'identity', 'uniform', later entries overriding earlier ones, NumValues.
const char* kDoor = R"(<?xml version="1.0" encoding="UTF-8"?>
<pomdpx version="1.0" id="door">
  <Description>factored test problem</Description>
  <Discount>0.9</Discount>
  <Variable>
    <StateVar vnamePrev="door_0" vnameCurr="door_1"><NumValues>2</NumValues></StateVar>
    <StateVar vnamePrev="pos_0" vnameCurr="pos_1" fullyObs="true"><ValueEnum>left right</ValueEnum></StateVar>
    <ObsVar vname="sound"><ValueEnum>beep quiet</ValueEnum></ObsVar>
    <ActionVar vname="act"><ValueEnum>stay move</ValueEnum></ActionVar>
    <RewardVar vname="cost"/>
    <RewardVar vname="bonus"/>
    <RewardVar vname="noise"/>
  </Variable>
  <InitialStateBelief>
    <CondProb><Var>pos_0</Var><Parent>null</Parent>
      <Parameter><Entry><Instance>-</Instance><ProbTable>1 0</ProbTable></Entry></Parameter>
    </CondProb>
    <CondProb><Var>door_0</Var><Parent>pos_0</Parent>
      <Parameter type="TBL"><Entry><Instance>- -</Instance><ProbTable>0.4 0.6 0.5 0.5</ProbTable></Entry></Parameter>
    </CondProb>
  </InitialStateBelief>
  <StateTransitionFunction>
    <CondProb><Var>pos_1</Var><Parent>act pos_0</Parent>
      <Parameter type="TBL">
        <Entry><Instance>stay - -</Instance><ProbTable>identity</ProbTable></Entry>
        <Entry><Instance>move - -</Instance><ProbTable>0.2 0.8 0.8 0.2</ProbTable></Entry>
      </Parameter>
    </CondProb>
    <CondProb><Var>door_1</Var><Parent>pos_1 door_0</Parent>
      <Parameter type="TBL">
        <Entry><Instance>left - -</Instance><ProbTable>0.9 0.1 0.3 0.7</ProbTable></Entry>
        <Entry><Instance>right * -</Instance><ProbTable>uniform</ProbTable></Entry>
        <Entry><Instance>right 1 -</Instance><ProbTable>0.25 0.75</ProbTable></Entry>
      </Parameter>
    </CondProb>
  </StateTransitionFunction>
  <ObsFunction>
    <CondProb><Var>sound</Var><Parent>act door_1</Parent>
      <Parameter type="TBL">
        <Entry><Instance>* - -</Instance><ProbTable>0.7 0.3 0.4 0.6</ProbTable></Entry>
        <Entry><Instance>stay s1 beep</Instance><ProbTable>0.5</ProbTable></Entry>
        <Entry><Instance>stay s1 quiet</Instance><ProbTable>0.5</ProbTable></Entry>
      </Parameter>
    </CondProb>
  </ObsFunction>
  <RewardFunction>
    <Func><Var>cost</Var><Parent>act pos_0</Parent>
      <Parameter type="TBL">
        <Entry><Instance>move *</Instance><ValueTable>-1</ValueTable></Entry>
        <Entry><Instance>stay right</Instance><ValueTable>2</ValueTable></Entry>
      </Parameter>
    </Func>
    <Func><Var>bonus</Var><Parent>door_1</Parent>
      <Parameter><Entry><Instance>-</Instance><ValueTable>0 10</ValueTable></Entry></Parameter>
    </Func>
    <Func><Var>noise</Var><Parent>sound</Parent>
      <Parameter><Entry><Instance>beep</Instance><ValueTable>3</ValueTable></Entry></Parameter>
    </Func>
  </RewardFunction>
</pomdpx>
)";

/// kDoor with the first occurrence of `from` replaced by `to`.
std::string doorWith(const std::string& from, const std::string& to) {
  std::string t = kDoor;
  const std::size_t p = t.find(from);
  if (p == std::string::npos) ADD_FAILURE() << "no '" << from << "' in kDoor";
  else t.replace(p, from.size(), to);
  return t;
}

/// "line:col" of the first occurrence of s in text (1-based).
std::string positionOf(const std::string& text, const std::string& s) {
  const std::size_t p = text.find(s);
  const std::size_t nl = text.rfind('\n', p);
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + p, '\n'));
  const std::size_t col = nl == std::string::npos ? p + 1 : p - nl;
  return std::to_string(line) + ":" + std::to_string(col);
}

std::string errorOf(const std::string& text, const CassandraLimits& limits = CassandraLimits()) {
  try {
    readPomdpx(text, "door.pomdpx", limits);
  } catch (const ParseError& e) {
    return e.what();
  }
  return "no error";
}

TEST(PomdpxIo, FactoredModelIsFlattenedAsComputedByHand) {
  CassandraStats stats;
  Model m = readPomdpx(kDoor, "door.pomdpx", CassandraLimits(), &stats);
  EXPECT_EQ(stats.renormalised_rows, 0u);
  // States: the fully observable pos first, then door (SARSOP's order), the last fastest.
  ASSERT_EQ(m.getS(), 4u);
  ASSERT_EQ(m.getA(), 2u);
  ASSERT_EQ(m.getO(), 4u);
  EXPECT_EQ(m.stateNames(), (std::vector<std::string>{"left_s0", "left_s1", "right_s0", "right_s1"}));
  EXPECT_EQ(m.actionNames(), (std::vector<std::string>{"stay", "move"}));
  // Observations: the next pos (fully observable) and the sound.
  EXPECT_EQ(m.observationNames(),
            (std::vector<std::string>{"left_beep", "left_quiet", "right_beep", "right_quiet"}));
  EXPECT_DOUBLE_EQ(m.getDiscount(), 0.9);
  // b0: pos = left surely, door | left = (0.4, 0.6).
  Eigen::Vector4d b0(0.4, 0.6, 0.0, 0.0);
  EXPECT_LE((m.initialBelief() - b0).cwiseAbs().maxCoeff(), 1e-15);

  // The tables as written, by hand.
  auto pPos = [](int a, int pos, int pos1) {  // stay: identity; move: flips with 0.8
    if (a == 0) return pos == pos1 ? 1.0 : 0.0;
    return pos == pos1 ? 0.2 : 0.8;
  };
  auto pDoor = [](int pos1, int door, int door1) {
    static const double left[2][2] = {{0.9, 0.1}, {0.3, 0.7}};
    static const double right[2][2] = {{0.5, 0.5}, {0.25, 0.75}};
    return pos1 == 0 ? left[door][door1] : right[door][door1];
  };
  auto pBeep = [](int a, int door1) {
    if (a == 0 && door1 == 1) return 0.5;
    return door1 == 0 ? 0.7 : 0.4;
  };
  for (int a = 0; a < 2; ++a) {
    const Eigen::MatrixXd T = m.denseTransition(static_cast<std::size_t>(a));
    const Eigen::MatrixXd Z = m.denseObservation(static_cast<std::size_t>(a));
    for (int s = 0; s < 4; ++s) {
      const int pos = s / 2, door = s % 2;
      double expectedR = a == 1 ? -1.0 : (pos == 1 ? 2.0 : 0.0);
      for (int s1 = 0; s1 < 4; ++s1) {
        const int pos1 = s1 / 2, door1 = s1 % 2;
        const double p = pPos(a, pos, pos1) * pDoor(pos1, door, door1);
        EXPECT_NEAR(T(s, s1), p, 1e-15) << "a " << a << " s " << s << " s1 " << s1;
        expectedR += p * (10.0 * door1 + 3.0 * pBeep(a, door1));
      }
      EXPECT_NEAR(m.getExpectedReward(static_cast<std::size_t>(s), static_cast<std::size_t>(a)),
                  expectedR, 1e-12)
          << "a " << a << " s " << s;
    }
    for (int s1 = 0; s1 < 4; ++s1) {
      const int pos1 = s1 / 2, door1 = s1 % 2;
      for (int o = 0; o < 4; ++o) {
        const int seenPos = o / 2, sound = o % 2;
        const double beep = pBeep(a, door1);
        const double p = seenPos != pos1 ? 0.0 : (sound == 0 ? beep : 1.0 - beep);
        EXPECT_NEAR(Z(s1, o), p, 1e-15) << "a " << a << " s1 " << s1 << " o " << o;
      }
    }
  }
}

/// A flat model with awkward numbers (1/3, 1e-17), a sparse and an identity action and a
/// non-uniform start, so that the writer's row forms and its 17 digits are all exercised.
Model awkwardModel() {
  const int S = 5, A = 3, O = 3;
  std::vector<Eigen::MatrixXd> T(A, Eigen::MatrixXd::Zero(S, S)), Z(A, Eigen::MatrixXd::Zero(S, O));
  for (int s = 0; s < S; ++s) {
    T[0](s, s) = 1.0;  // identity
    T[1](s, (s + 1) % S) = 1.0 / 3.0;
    T[1](s, (s + 3) % S) = 2.0 / 3.0;
    for (int s1 = 0; s1 < S; ++s1) T[2](s, s1) = 1.0 / S;
    if (s == 0) {  // a tiny entry next to a large one
      T[2](s, 0) = 2.0 / S;
      T[2](s, 4) = 1e-17;
    }
    for (int a = 0; a < A; ++a) {
      Z[a](s, s % O) = 0.7;
      Z[a](s, (s + a + 1) % O) += 0.3;
    }
  }
  Eigen::MatrixXd R(S, A);
  R << 1, -2.5, 0, 0, 1.0 / 7.0, 3, 4, 0, -1e-300, 2, 2, 2, 0, 0, 0;
  Model m(T, Z, R, 0.875);
  m.setNames({"a", "b&c", "x<y", "1", "s-4"}, {"stay", "jump", "mix"}, {"o0", "o1", "o2"});
  Eigen::VectorXd b0(S);
  b0 << 0.1, 0.2, 0.3, 0.4, 0.0;
  m.setInitialBelief(b0);
  return m;
}

TEST(PomdpxIo, FlatModelsRoundTripExactly) {
  const Model tiger = loadCassandra(kData + "tiger.95.pomdp");
  const std::string x = writePomdpx(tiger);  // listen is an identity: the 'identity' keyword
  EXPECT_NE(x.find("<ProbTable>identity</ProbTable>"), std::string::npos);
  expectSameModel(readPomdpx(x, "tiger.pomdpx"), tiger);
  const Model awkward = awkwardModel();
  expectSameModel(readPomdpx(writePomdpx(awkward)), awkward);
  // The factored model, flattened, written flat and read again.
  Model door = readPomdpx(kDoor);
  expectSameModel(readPomdpx(writePomdpx(door)), door);
}

TEST(PomdpxIo, CassandraFilesThroughPomdpxAgreeWithin1e12) {
  for (const char* f : {"tiger.95.pomdp", "forms.pomdp", "RockSample_4_4.pomdp"}) {
    SCOPED_TRACE(f);
    Model original = loadCassandra(kData + f);
    Model viaX = readPomdpx(writePomdpx(original), std::string(f) + "x");
    expectSameModel(viaX, original, 1e-12);
    // and back to .pomdp
    expectSameModel(readCassandra(writeCassandra(viaX)), original, 1e-12);
  }
}

/// The Tiger problem written by hand as a PomdpX file, in the compact forms the writer does not
/// use ('-' rows, '*', 'uniform', NumValues-free names).
const char* kTigerX = R"(<?xml version="1.0"?>
<pomdpx version="1.0" id="tiger">
  <Discount>0.95</Discount>
  <Variable>
    <StateVar vnamePrev="tiger_0" vnameCurr="tiger_1"><ValueEnum>tiger-left tiger-right</ValueEnum></StateVar>
    <ObsVar vname="hear"><ValueEnum>tiger-left tiger-right</ValueEnum></ObsVar>
    <ActionVar vname="act"><ValueEnum>listen open-left open-right</ValueEnum></ActionVar>
    <RewardVar vname="r"/>
  </Variable>
  <InitialStateBelief>
    <CondProb><Var>tiger_0</Var><Parent>null</Parent>
      <Parameter><Entry><Instance>-</Instance><ProbTable>uniform</ProbTable></Entry></Parameter></CondProb>
  </InitialStateBelief>
  <StateTransitionFunction>
    <CondProb><Var>tiger_1</Var><Parent>act tiger_0</Parent>
      <Parameter>
        <Entry><Instance>listen - -</Instance><ProbTable>identity</ProbTable></Entry>
        <Entry><Instance>open-left * -</Instance><ProbTable>0.5 0.5</ProbTable></Entry>
        <Entry><Instance>open-right * -</Instance><ProbTable>uniform</ProbTable></Entry>
      </Parameter></CondProb>
  </StateTransitionFunction>
  <ObsFunction>
    <CondProb><Var>hear</Var><Parent>act tiger_1</Parent>
      <Parameter>
        <Entry><Instance>listen - -</Instance><ProbTable>0.85 0.15 0.15 0.85</ProbTable></Entry>
        <Entry><Instance>open-left * *</Instance><ProbTable>0.5</ProbTable></Entry>
        <Entry><Instance>open-right * -</Instance><ProbTable>0.5 0.5</ProbTable></Entry>
      </Parameter></CondProb>
  </ObsFunction>
  <RewardFunction>
    <Func><Var>r</Var><Parent>act tiger_0</Parent>
      <Parameter>
        <Entry><Instance>listen *</Instance><ValueTable>-1</ValueTable></Entry>
        <Entry><Instance>open-left -</Instance><ValueTable>-100 10</ValueTable></Entry>
        <Entry><Instance>open-right -</Instance><ValueTable>10 -100</ValueTable></Entry>
      </Parameter></Func>
  </RewardFunction>
</pomdpx>
)";

TEST(PomdpxIo, TigerInBothFormatsIsTheSameModelAndSolvesToTheSameValue) {
  Model fromPomdp = loadCassandra(kData + "tiger.95.pomdp");
  Model fromPomdpx = readPomdpx(kTigerX, "tiger.pomdpx");
  expectSameModel(fromPomdpx, fromPomdp, 1e-15);
  SolverOptions opt;
  opt.precision = 1e-6;
  opt.timeout = 30.0;
  PointBasedSolver a(fromPomdp, fromPomdp.initialBelief(), opt);
  PointBasedSolver b(fromPomdpx, fromPomdpx.initialBelief(), opt);
  ASSERT_TRUE(a.solve());
  ASSERT_TRUE(b.solve());
  EXPECT_NEAR(a.report().lower, b.report().lower, 1e-6);
  EXPECT_NEAR(a.report().upper, b.report().upper, 1e-6);
  // Tiger's optimal value at the uniform belief (discount 0.95) is about 19.37.
  EXPECT_NEAR(b.report().lower, 19.37, 0.01);
}

TEST(PomdpxIo, MalformedInputIsRefusedAtItsPosition) {
  const std::string sumBad = doorWith("0.9 0.1 0.3 0.7", "0.9 0.2 0.3 0.7");
  const std::string negative = doorWith("0.2 0.8 0.8 0.2", "0.2 0.8 -0.1 0.2");
  const std::string unknownVar = doorWith("<Parent>act pos_0</Parent>", "<Parent>act pos_9</Parent>");
  const std::string unknownValue = doorWith("stay - -", "sit - -");
  const std::string shortTable = doorWith("0.2 0.8 0.8 0.2", "0.2 0.8 0.8");
  const std::string arity = doorWith("<Instance>move *</Instance>", "<Instance>move * *</Instance>");
  const std::string dd = doorWith("<Parameter type=\"TBL\">\n        <Entry><Instance>stay",
                                  "<Parameter type=\"DD\">\n        <Entry><Instance>stay");
  const std::string noDoorT = doorWith("<Var>door_1</Var>", "<Var>pos_1</Var>");
  const std::string wrongKind = doorWith("<Var>sound</Var>", "<Var>door_1</Var>");
  const std::string identity = doorWith("stay - -", "stay * -");
  const std::string unspecified = doorWith(
      "<Entry><Instance>stay - -</Instance><ProbTable>identity</ProbTable></Entry>", "");
  const std::string prevInObs = doorWith("<Parent>act door_1</Parent>", "<Parent>act door_0</Parent>");
  auto expectAt = [](const std::string& text, const std::string& at, const std::string& what) {
    const std::string e = errorOf(text);
    EXPECT_EQ(e.rfind("door.pomdpx:" + at + ": ", 0), 0u) << e << "\nexpected at " << at;
    EXPECT_NE(e.find(what), std::string::npos) << e << "\nexpected: " << what;
  };
  expectAt(sumBad, positionOf(sumBad, "<Entry><Instance>left - -"),
           "probabilities given pos_1=left, door_0=s0 sum to 1.1");
  expectAt(negative, positionOf(negative, "-0.1"), "probability -0.1 is not in [0, 1]");
  expectAt(unknownVar, positionOf(unknownVar, "pos_9"), "unknown variable 'pos_9'");
  expectAt(unknownValue, positionOf(unknownValue, "sit - -"), "'sit' is not a value of 'act'");
  expectAt(shortTable, positionOf(shortTable, "<ProbTable>0.2 0.8 0.8<"),
           "has 3 number(s), <Instance> needs 4");
  expectAt(arity, positionOf(arity, "<Instance>move * *"), "<Instance> has 3 item(s)");
  expectAt(dd, positionOf(dd, "<Parameter type=\"DD\""), "type=\"DD\") are not supported");
  expectAt(noDoorT, positionOf(noDoorT, "pos_1 door_0</Parent>"), "'pos_1' appears twice");
  const std::string door = std::string(kDoor);
  const std::size_t from = door.find("    <CondProb><Var>door_1</Var>");
  const std::string missing =
      door.substr(0, from) + door.substr(door.find("</CondProb>", from) + 12);
  expectAt(missing, positionOf(missing, "<StateTransitionFunction>"),
           "<StateTransitionFunction> has no <CondProb> for 'door_1'");
  expectAt(wrongKind, positionOf(wrongKind, "door_1</Var><Parent>act door_1"),
           "<Var> of ObsFunction must be an observation variable, got 'door_1'");
  expectAt(identity, positionOf(identity, "<ProbTable>identity"), "'identity' needs exactly two '-'");
  expectAt(unspecified, positionOf(unspecified, "<CondProb><Var>pos_1</Var>"),
           "no <Entry> gives the distribution for act=stay, pos_0=left");
  expectAt(prevInObs, positionOf(prevInObs, "door_0</Parent>\n      <Parameter type=\"TBL\">\n        <Entry><Instance>* - -"),
           "'door_0' cannot be a parent in ObsFunction");
  // Not XML at all, broken XML, another XML document.
  EXPECT_EQ(errorOf("states: 2\n").rfind("door.pomdpx:1:1: not well-formed XML", 0), 0u)
      << errorOf("states: 2\n");
  const std::string truncated = std::string(kDoor).substr(0, std::string(kDoor).find("<ObsFunction>"));
  EXPECT_NE(errorOf(truncated).find("not well-formed XML"), std::string::npos) << errorOf(truncated);
  EXPECT_NE(errorOf("<?xml version=\"1.0\"?>\n<pomdp/>").find("door.pomdpx:2:1: the root element is <pomdp>"),
            std::string::npos);
}

// Issue 24: rewards must keep the bounds finite (|R| <= Model::kMaxAbsReward), each <Func>
// entry and their sum; a NUL byte would end tinyxml2's document early.
TEST(PomdpxIo, RewardsBeyondTheLimitAndNulBytesAreRefusedAtTheirPosition) {
  const std::string huge = doorWith("<ValueTable>0 10</ValueTable>", "<ValueTable>0 1e308</ValueTable>");
  std::string e = errorOf(huge);
  EXPECT_EQ(e.rfind("door.pomdpx:" + positionOf(huge, "1e308") + ": reward 1e308 is outside "
                    "[-1e+12, 1e+12]", 0), 0u) << e;
  const std::string negative = doorWith("<ValueTable>-1</ValueTable>", "<ValueTable>-1e13</ValueTable>");
  e = errorOf(negative);
  EXPECT_EQ(e.rfind("door.pomdpx:" + positionOf(negative, "-1e13") + ": reward -1e13", 0), 0u) << e;
  // each Func at the limit, their sum beyond it: refused at <RewardFunction>
  const std::string sum = doorWith("<ValueTable>2</ValueTable>", "<ValueTable>1e12</ValueTable>");
  e = errorOf(sum);
  EXPECT_EQ(e.rfind("door.pomdpx:" + positionOf(sum, "<RewardFunction>") +
                    ": the reward functions add up to", 0), 0u) << e;
  EXPECT_EQ(errorOf(doorWith("<ValueTable>2</ValueTable>", "<ValueTable>-1e12</ValueTable>")),
            "no error");
  std::string nul = kDoor;
  const std::size_t at = nul.find("<ObsFunction>");
  nul.insert(at, 1, '\0');
  e = errorOf(nul);
  EXPECT_EQ(e.rfind("door.pomdpx:" + positionOf(kDoor, "<ObsFunction>") + ": NUL byte", 0), 0u) << e;
}

TEST(PomdpxIo, RowsOffByRoundingAreRenormalisedLikeThePomdpReader) {
  CassandraStats stats;
  Model m = readPomdpx(doorWith("0.9 0.1 0.3 0.7", "0.90004 0.1 0.3 0.7"), "door.pomdpx",
                       CassandraLimits(), &stats);
  EXPECT_EQ(stats.renormalised_rows, 1u);
  EXPECT_NEAR(stats.max_sum_deviation, 4e-5, 1e-12);
  EXPECT_NE(stats.max_deviation_where.find("door_1' given pos_1=left, door_0=s0"),
            std::string::npos)
      << stats.max_deviation_where;
  EXPECT_NEAR(m.getTransitionProbability(0, 0, 0), 0.90004 / 1.00004, 1e-15);
  // The same tolerance as the .pomdp reader: 2e-4 off is an error.
  const std::string bad = doorWith("0.9 0.1 0.3 0.7", "0.9002 0.1 0.3 0.7");
  EXPECT_NE(errorOf(bad).find("sum to 1.0002"), std::string::npos) << errorOf(bad);
  CassandraLimits loose;
  loose.sum_tolerance = 1e-3;
  EXPECT_EQ(errorOf(bad, loose), "no error");
}

TEST(PomdpxIo, HugeDeclaredSizesAreRefusedBeforeAllocating) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string one = doorWith("<NumValues>2</NumValues>", "<NumValues>1000000000000</NumValues>");
  EXPECT_NE(errorOf(one).find("door.pomdpx:" + positionOf(one, "<NumValues>1000") + ": <NumValues>1000000000000</NumValues> needs about"),
            std::string::npos)
      << errorOf(one);
  // 40 binary variables: 2^40 states, each variable small.
  std::string vars;
  for (int i = 0; i < 40; ++i)
    vars += "<StateVar vnamePrev=\"v" + std::to_string(i) + "_0\" vnameCurr=\"v" +
            std::to_string(i) + "_1\"><NumValues>2</NumValues></StateVar>\n";
  const std::string many = doorWith("<RewardVar vname=\"cost\"/>", vars + "<RewardVar vname=\"cost\"/>");
  const std::string e = errorOf(many);
  EXPECT_NE(e.find("door.pomdpx:" + positionOf(many, "<Variable>") +
                   ": the declared variables: the model needs about"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("4398046511104 states"), std::string::npos) << e;
  // A table too large for the budget is refused before it is allocated.
  CassandraLimits small;
  small.memory_budget = 200000;
  const std::string wide = doorWith("<ValueEnum>left right</ValueEnum>",
                                    "<NumValues>400</NumValues>");
  EXPECT_NE(errorOf(wide, small).find("above the memory budget"), std::string::npos)
      << errorOf(wide, small);
  // Small declarations, dense transitions: 16 variables drawn uniformly make every T row
  // 65536 entries long; the rows are refused as soon as the next one would not fit.
  std::string dense = "<?xml version=\"1.0\"?>\n<pomdpx version=\"1.0\"><Discount>0.9</Discount>\n<Variable>\n";
  for (int i = 0; i < 16; ++i)
    dense += "<StateVar vnamePrev=\"v" + std::to_string(i) + "_0\" vnameCurr=\"v" +
             std::to_string(i) + "_1\"><NumValues>2</NumValues></StateVar>\n";
  dense += "<ActionVar vname=\"a\"><NumValues>1</NumValues></ActionVar>\n</Variable>\n"
           "<StateTransitionFunction>\n";
  for (int i = 0; i < 16; ++i)
    dense += "<CondProb><Var>v" + std::to_string(i) + "_1</Var><Parent>null</Parent><Parameter>"
             "<Entry><Instance>-</Instance><ProbTable>uniform</ProbTable></Entry></Parameter>"
             "</CondProb>\n";
  dense += "</StateTransitionFunction>\n</pomdpx>\n";
  CassandraLimits mib64;
  mib64.memory_budget = std::size_t(64) << 20;
  const std::string de = errorOf(dense, mib64);
  EXPECT_NE(de.find("door.pomdpx:" + positionOf(dense, "<StateTransitionFunction>") +
                    ": StateTransitionFunction: the model needs about"),
            std::string::npos)
      << de;
  EXPECT_NE(de.find("T and O entries"), std::string::npos) << de;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 1.0);
}

TEST(PomdpxIo, TimeBudgetStopsReading) {
  CassandraLimits limits;
  limits.timeout = 1e-12;
  const std::string e = errorOf(kDoor, limits);
  EXPECT_NE(e.find("time budget of"), std::string::npos) << e;
}

TEST(PomdpxIo, MutatedFilesAreReadOrRefusedWithAParseError) {
  // Deterministic mutants of kDoor (characters deleted, duplicated or replaced, tokens swapped):
  // each is a model or a ParseError with a position in the file, never a crash or another
  // exception.
  const std::string base = kDoor;
  const char* pieces[] = {"-", "*", "0", "1", "0.5", "identity", "uniform", "null", "pos_1",
                          "door_0", "<", ">", "/", "\"\"", " ", "s1", "2", "-1e308", "</Entry>"};
  std::uint64_t x = 12345;
  auto next = [&x](std::size_t n) {
    x = x * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<std::size_t>((x >> 33) % n);
  };
  int models = 0, errors = 0;
  for (int i = 0; i < 3000; ++i) {
    std::string t = base;
    for (int k = 0, n = 1 + static_cast<int>(next(3)); k < n; ++k) {
      const std::size_t p = next(t.size());
      switch (next(3)) {
        case 0: t.erase(p, 1 + next(4)); break;
        case 1: t.insert(p, t.substr(p, 1 + next(8))); break;
        default: t.insert(p, pieces[next(sizeof(pieces) / sizeof(pieces[0]))]);
      }
    }
    try {
      readPomdpx(t, "m.pomdpx");
      ++models;
    } catch (const ParseError& e) {
      ++errors;
      EXPECT_EQ(std::string(e.what()).rfind("m.pomdpx:", 0), 0u) << e.what();
      EXPECT_GE(e.location().line, 1);
    }
  }
  EXPECT_GT(errors, 1000);
  EXPECT_GT(models, 10);
}

TEST(PomdpxIo, LoadPomdpFileDispatchesOnTheExtension) {
  const std::string dir = ::testing::TempDir();
  const Model tiger = loadCassandra(kData + "tiger.95.pomdp");
  savePomdpx(dir + "/t.pomdpx", tiger);
  saveCassandra(dir + "/t.pomdp", tiger);
  writeFileAtomic(dir + "/t_xml.txt", writePomdpx(tiger));
  writeFileAtomic(dir + "/t_cassandra.txt", writeCassandra(tiger));
  for (const char* f : {"/t.pomdpx", "/t.pomdp", "/t_xml.txt", "/t_cassandra.txt"})
    expectSameModel(loadPomdpFile(dir + f), tiger);
  // A .pomdpx that is really .pomdp text is read as PomdpX, and says so.
  writeFileAtomic(dir + "/wrong.pomdpx", writeCassandra(tiger));
  try {
    loadPomdpFile(dir + "/wrong.pomdpx");
    ADD_FAILURE() << "no error";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("wrong.pomdpx:1:1: not well-formed XML"), std::string::npos)
        << e.what();
  }
  for (const char* f : {"/t.pomdpx", "/t.pomdp", "/t_xml.txt", "/t_cassandra.txt", "/wrong.pomdpx"})
    std::remove((dir + f).c_str());
}

TEST(PomdpxIo, WriterRejectsNamesPomdpxCannotHold) {
  Model m = loadCassandra(kData + "tiger.95.pomdp");
  m.setNames({"tiger left", "tiger-right"}, m.actionNames(), m.observationNames());
  EXPECT_THROW(writePomdpx(m), ConfigError);
  m.setNames({"*", "tiger-right"}, m.actionNames(), m.observationNames());
  EXPECT_THROW(writePomdpx(m), ConfigError);
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
