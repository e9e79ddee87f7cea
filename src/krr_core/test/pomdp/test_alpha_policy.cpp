// Tests of AlphaVectorPolicy: selection, own text format, APPL XML.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/pomdp/alpha_policy.h"

namespace krr {
namespace pomdp {
namespace {

AlphaVectorPolicy sample() {
  AlphaVectorPolicy p(2);
  Eigen::VectorXd a(2), b(2), c(2);
  a << 10, -100;        // open-right-like
  b << 1.0 / 3, 0.1;    // non-round values test the 17-digit round trip
  c << -100, 10;
  p.add(a, 2);
  p.add(b, 0);
  p.add(c, 1);
  return p;
}

TEST(AlphaVectorPolicy, PicksTheBestVector) {
  AlphaVectorPolicy p = sample();
  Belief left(2), mid(2), right(2);
  left << 1, 0;
  mid << 0.5, 0.5;
  right << 0, 1;
  EXPECT_EQ(p.bestAction(left), 2u);
  EXPECT_EQ(p.bestAction(mid), 0u);  // (1/3 + 0.1)/2 beats -45
  EXPECT_EQ(p.bestAction(right), 1u);
  EXPECT_DOUBLE_EQ(p.value(left), 10.0);
  EXPECT_THROW(AlphaVectorPolicy(2).bestAction(left), ConfigError);
  EXPECT_THROW(p.add(Eigen::VectorXd::Zero(3), 0), ConfigError);
}

TEST(AlphaVectorPolicy, TextRoundTripIsExact) {
  AlphaVectorPolicy p = sample();
  AlphaVectorPolicy q = AlphaVectorPolicy::fromText(p.toText());
  ASSERT_EQ(q.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(q.action(i), p.action(i));
    EXPECT_EQ(q.alpha(i), p.alpha(i));
  }
  const std::string path = "/tmp/krr_pomdp_test_policy.txt";
  p.save(path);
  EXPECT_EQ(AlphaVectorPolicy::load(path).alpha(1), p.alpha(1));
  std::remove(path.c_str());
}

TEST(AlphaVectorPolicy, ApplXmlFormatAndRoundTrip) {
  AlphaVectorPolicy p = sample();
  std::string xml = p.toApplXml("tiger.pomdp");
  EXPECT_NE(xml.find("<Policy version=\"0.1\" type=\"value\" model=\"tiger.pomdp\""),
            std::string::npos);
  EXPECT_NE(xml.find("<AlphaVector vectorLength=\"2\" numObsValue=\"1\" numVectors=\"3\">"),
            std::string::npos);
  EXPECT_NE(xml.find("<Vector action=\"2\" obsValue=\"0\">10 -100 </Vector>"), std::string::npos);
  AlphaVectorPolicy q = AlphaVectorPolicy::fromApplXml(xml);
  ASSERT_EQ(q.size(), 3u);
  EXPECT_EQ(q.alpha(1), p.alpha(1));
  EXPECT_EQ(q.action(2), 1u);
}

TEST(AlphaVectorPolicy, ParseErrorsHavePositions) {
  try {
    AlphaVectorPolicy::fromText("krr-alpha-policy 1\nstates 2\nvectors 1\n0 1.0 x\n", "p.txt");
    FAIL() << "no error";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.location().str(), "p.txt:4:7");
  }
  try {
    AlphaVectorPolicy::fromApplXml(
        "<AlphaVector vectorLength=\"2\" numVectors=\"1\">\n<Vector action=\"0\" "
        "obsValue=\"0\">1 </Vector></AlphaVector>",
        "p.xml");
    FAIL() << "no error";
  } catch (const ParseError& e) {
    EXPECT_EQ(e.location().line, 2);
    EXPECT_NE(e.message().find("1 values, expected 2"), std::string::npos);
  }
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
