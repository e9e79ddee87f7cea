// Every program of the package (apps/ and bench/, the list comes from CMake) answers --help
// with its usage on stdout and status 0, from any directory, without running or writing
// anything; bad options give status 2 and the usage on stderr.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "../support/run_command.h"

namespace {

using krr::test::CommandOutcome;

/// @brief `program args` run in the empty directory `cwd`, its output captured outside it.
CommandOutcome run(const std::string& program, const std::string& args,
                              const std::string& cwd) {
  return krr::test::runCommand("cd '" + cwd + "' && '" + std::string(KRR_PROGRAM_DIR) + "/" +
                                   program + "' " + args + " </dev/null",
                               ::testing::TempDir() + "/program_help_" + program);
}

/// @brief A fresh empty directory (the programs must not depend on the working directory).
std::string emptyDir(const std::string& name) {
  const std::filesystem::path p = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

TEST(ProgramHelp, EveryProgramPrintsItsUsageOnStdoutAndExits0) {
  const std::vector<std::string> programs = krr::splitOption(KRR_PROGRAMS);
  ASSERT_GE(programs.size(), 10u);
  // The site check is a program a new user runs first: its help must work like the others'.
  EXPECT_NE(std::find(programs.begin(), programs.end(), "check_site"), programs.end());
  const std::string cwd = emptyDir("program_help_cwd");
  for (const std::string& p : programs) {
    for (const char* flag : {"--help", "-h"}) {
      const CommandOutcome r = run(p, flag, cwd);
      EXPECT_EQ(r.status, 0) << p << " " << flag << ": " << r.err;
      EXPECT_EQ(r.out.rfind("usage: " + p, 0), 0u) << p << " " << flag << ": " << r.out;
      EXPECT_EQ(r.err, "") << p << " " << flag;
    }
    EXPECT_TRUE(std::filesystem::is_empty(cwd)) << p << " --help wrote into the directory";
  }
}

// The programs that used to parse argv by hand: unknown options are usage errors.
TEST(ProgramHelp, UsageErrorsExit2WithTheUsageOnStderr) {
  const std::string cwd = emptyDir("program_usage_cwd");
  for (const std::string p : {"plog", "pomdp_solve", "bench_pomdp_suite"}) {
    const CommandOutcome r = run(p, "--frobnicate", cwd);
    EXPECT_EQ(r.status, 2) << p;
    EXPECT_EQ(r.out, "") << p;
    EXPECT_EQ(r.err.rfind(p + ": ", 0), 0u) << p << ": " << r.err;
    EXPECT_NE(r.err.find("usage: " + p), std::string::npos) << p << ": " << r.err;
  }
  // pomdp_solve has one memory option, --memory-budget.
  const CommandOutcome old = run("pomdp_solve", "x.pomdp --memory-limit 10", cwd);
  EXPECT_EQ(old.status, 2) << old.err;
  const CommandOutcome help = run("pomdp_solve", "--help", cwd);
  EXPECT_NE(help.out.find("--memory-budget"), std::string::npos) << help.out;
  EXPECT_EQ(help.out.find("--memory-limit"), std::string::npos) << help.out;
  // A missing input file is a usage error too.
  EXPECT_EQ(run("plog", "", cwd).status, 2);
  EXPECT_EQ(run("pomdp_solve", "", cwd).status, 2);
}

}  // namespace
