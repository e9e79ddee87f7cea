// Seeded, bounded fuzzing of the .pomdp reader (issue 12): a few thousand mutants of the test
// files must each end in a model or a typed krr::Error, with no signal, no hang past the time
// budget and no allocation beyond the memory cap (RLIMIT_AS in a forked child).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "../common/fuzz_support.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_core/examples/tiger.h"

namespace krr {
namespace pomdp {
using examples::makeTiger;
namespace {

const std::string kData = std::string(KRR_TEST_DATA_DIR) + "/pomdp/";
constexpr std::size_t kMutants = 5000;
constexpr std::uint64_t kSeed = 20261202;

std::vector<std::string> seeds() {
  return {readFile(kData + "tiger.95.pomdp"), readFile(kData + "forms.pomdp"),
          writeCassandra(makeTiger())};
}

std::vector<std::string> mutants() {
  const std::vector<std::string> base = seeds();
  const std::vector<std::string> dict = {
      "states:", "actions:", "observations:", "T:", "O:", "R:", " * ", " : ", "identity",
      "uniform", "start:", "include", "exclude", "\n", "reward", "cost", "discount:", "#",
      // issue 24: numbers that overflow the bounds, counts that are not counts, NUL bytes
      " 1e308 ", " -1e308 ", " 1e12 ", " -2 ", "states: -2\n", std::string(1, '\0'),
      "discount: 0.9999999\n"};
  std::mt19937_64 rng(kSeed);
  std::vector<std::string> out;
  for (std::size_t i = 0; i < kMutants; ++i)
    out.push_back(fuzz::mutate(base[i % base.size()], rng, dict));
  return out;
}

/// @brief Parse one input under the budgets the fuzz test imposes; typed errors are fine. A
/// model that is read must keep its bounds finite (issue 24): no NUL byte in its text, every
/// reward within Model::kMaxAbsReward, and a short deterministic solve gives finite, ordered
/// bounds. A violation is a std::logic_error, which the harness reports as an escape.
void parseQuietly(const std::string& text) {
  CassandraLimits limits;
  limits.memory_budget = 64u << 20;
  limits.timeout = 2.0;
  try {
    Model m = readCassandra(text, "mutant.pomdp", limits);
    writeCassandra(m);
    if (text.find('\0') != std::string::npos)
      throw std::logic_error("a text with a NUL byte was read as a model");
    for (std::size_t s = 0; s < m.getS(); ++s)
      for (std::size_t a = 0; a < m.getA(); ++a)
        if (!(std::abs(m.getExpectedReward(s, a)) <= Model::kMaxAbsReward))
          throw std::logic_error("reward beyond the limit was read");
    if (m.getDiscount() < 1.0 && m.getS() <= 64) {
      SolverOptions opt;
      opt.maxTrials = 3;
      opt.timeout = 1.0;
      opt.setupTimeLimit = 0.5;
      PointBasedSolver solver(m, m.initialBelief(), opt);
      solver.solve();
      if (!solver.report().valid())
        throw std::logic_error("the solver's bounds are not finite: " +
                               std::to_string(solver.report().lower) + ", " +
                               std::to_string(solver.report().upper));
    }
  } catch (const Error&) {
  }
}

TEST(CassandraFuzz, MutantsGiveModelsOrTypedErrors) {
  const std::vector<std::string> inputs = mutants();
  const auto t0 = std::chrono::steady_clock::now();
  const fuzz::Report r = fuzz::runIsolated(
      inputs.size(), [&](std::size_t i) { parseQuietly(inputs[i]); }, std::size_t(512) << 20, 10.0);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[ fuzz     ] %zu .pomdp mutants in %.2f s (seed %llu)\n", r.mutants, secs,
              static_cast<unsigned long long>(kSeed));
  if (r.failed_index >= 0) {
    const std::string path = ::testing::TempDir() + "/cassandra_fuzz_failure.pomdp";
    std::ofstream(path, std::ios::binary) << inputs[static_cast<std::size_t>(r.failed_index)];
    FAIL() << "mutant " << r.failed_index << ": " << r.failure << "; input saved to " << path;
  }
  EXPECT_EQ(r.mutants, inputs.size());
  EXPECT_LT(secs, 60.0);
}

// The harness itself must notice a crash and a hang, or the test above proves nothing.
TEST(CassandraFuzz, HarnessDetectsSignalsHangsAndRunawayAllocation) {
  fuzz::Report crash = fuzz::runIsolated(
      5, [](std::size_t i) { if (i == 3) ::raise(SIGSEGV); }, std::size_t(256) << 20, 5.0);
  EXPECT_EQ(crash.failed_index, 3);
  EXPECT_NE(crash.failure.find("signal"), std::string::npos) << crash.failure;
  fuzz::Report hang = fuzz::runIsolated(
      3, [](std::size_t i) { if (i == 1) ::pause(); }, std::size_t(256) << 20, 0.5);
  EXPECT_EQ(hang.failed_index, 1);
  EXPECT_NE(hang.failure.find("hang"), std::string::npos) << hang.failure;
  fuzz::Report hog = fuzz::runIsolated(
      2, [](std::size_t i) {
        if (i == 1) {
          std::vector<char> v(std::size_t(2) << 30, 1);
          std::printf("%d\n", v[12345]);
        }
      },
      std::size_t(256) << 20, 5.0);
  EXPECT_EQ(hog.failed_index, 1);
  EXPECT_NE(hog.failure.find("exception escaped"), std::string::npos) << hog.failure;
}

}  // namespace
}  // namespace pomdp
}  // namespace krr
