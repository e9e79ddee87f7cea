// pomdp_solve as a program (issue 24): a file whose rewards would make the bounds infinite is
// refused at the reward's file:line:col with exit status 1, and no run ever prints a bound that
// is not a finite number, let alone labels it "valid bounds".
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "krr_core/common/files.h"
#include "../support/run_command.h"

namespace {

using krr::test::CommandOutcome;

/// @brief pomdp_solve on `text` (written to a file named `name`) with `args`.
CommandOutcome solve(const std::string& name, const std::string& text,
                                const std::string& args) {
  const std::string file = ::testing::TempDir() + "/" + name;
  std::ofstream(file, std::ios::binary) << text;
  return krr::test::runCommand(std::string(KRR_POMDP_SOLVE) + " '" + file + "' " + args, file);
}

/// @brief Every number in the table rows of pomdp_solve's output (lines not starting with '#'
/// and not the header), as text: each must be a finite number.
std::vector<std::string> tableNumbers(const std::string& out) {
  std::vector<std::string> nums;
  std::istringstream lines(out);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.empty() || line[0] == '#' || line.find("time_s") != std::string::npos) continue;
    std::istringstream words(line);
    std::string w;
    while (words >> w) nums.push_back(w);
  }
  return nums;
}

const std::string kHead = "discount: 0.95\nvalues: reward\nstates: a b\nactions: x y\n"
                          "observations: o p\nstart: uniform\nT: * identity\nO: * uniform\n";

// The reported case: rewards of +-1e308 gave lower = upper = -inf, gap nan, exit 0 and
// "timeout: NOT converged, gap above precision (valid bounds)".
TEST(PomdpSolveApp, HugeRewardsAreRefusedAtTheirPosition) {
  const CommandOutcome r = solve("huge.pomdp", kHead + "R: x : a : * : * 1e308\nR: y : * : * : * -1e308\n",
                      "--timeout 2");
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("huge.pomdp:9:18: reward 1e308 is outside [-1e+12, 1e+12]"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.out.find("valid bounds"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("inf"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
}

// At the limit, with a discount close to 1, every printed bound is finite and the run says
// "valid bounds" only about finite numbers.
TEST(PomdpSolveApp, RewardsAtTheLimitGiveFiniteBounds) {
  const CommandOutcome r = solve("limit.pomdp",
                      "discount: 0.999999\n" + kHead.substr(kHead.find('\n') + 1) +
                          "R: x : a : * : * 1e12\nR: y : * : * : * -1e12\nR: x : b : * : * -1e12\n",
                      "--timeout 1");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const std::vector<std::string> nums = tableNumbers(r.out);
  ASSERT_GE(nums.size(), 5u) << r.out;
  for (const std::string& n : nums) {
    char* end = nullptr;
    const double v = std::strtod(n.c_str(), &end);
    EXPECT_TRUE(end && *end == '\0' && std::isfinite(v)) << "'" << n << "' in\n" << r.out;
  }
  EXPECT_TRUE(r.out.find("converged: gap <= precision") != std::string::npos ||
              r.out.find("(valid bounds)") != std::string::npos)
      << r.out;
}

TEST(PomdpSolveApp, NegativeCountAndNulByteAreRefusedWhereTheyAre) {
  const CommandOutcome neg = solve("neg.pomdp", "discount: 0.95\nstates: -2\nactions: x\nobservations: o\n",
                        "--timeout 2");
  EXPECT_EQ(neg.status, 1);
  EXPECT_NE(neg.err.find("neg.pomdp:2:9: number of states must be a positive integer, got '-2'"),
            std::string::npos)
      << neg.err;
  const CommandOutcome nul = solve("nul.pomdp", std::string("discount: 0.95\0 junk\n", 21) +
                                         kHead.substr(kHead.find('\n') + 1) +
                                         "R: x : * : * : * 1\n",
                        "--timeout 2");
  EXPECT_EQ(nul.status, 1);
  EXPECT_NE(nul.err.find("nul.pomdp:1:15: NUL byte"), std::string::npos) << nul.err;
}

}  // namespace
