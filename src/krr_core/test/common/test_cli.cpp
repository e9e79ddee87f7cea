// The shared option parser: declared options reach their targets; --help prints the usage on
// stdout and exits 0 before anything else; every error is "program: message" and the usage on
// stderr with exit status 2. And the resource locator that the programs' default paths use.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resource_locator.h"

namespace {

struct Options {
  std::size_t trials = 10;
  double br = 0.3;
  std::string out;
  bool json = false;
  std::vector<std::string> utterances, rest;
  int level = -1;
  std::uint32_t known = 5;
};

krr::OptionParser declare(Options& o) {
  krr::OptionParser p("prog", "Does things.");
  p.add("--trials", "N", "trials to run", &o.trials).required().alias("--samples");
  p.add("--br", "B", "blocking rate", &o.br);
  p.add("--out", "FILE", "CSV output", &o.out).defaultText("stdout");
  p.flag("--json", "print JSON", &o.json);
  p.add("--utterance", "TEXT", "what is said", &o.utterances);
  p.add("--level", "L", "an integer", &o.level);
  p.add("--known", "M", "a threshold", &o.known);
  p.positional("ARG", "more arguments", [&o](const std::string& v) { o.rest.push_back(v); }, true);
  return p;
}

/// Parse `args` (argv[0] = "prog"), capturing stdout and stderr.
struct Outcome {
  std::optional<int> status;
  std::string out, err;
};
Outcome run(Options& o, const std::vector<std::string>& args,
        const std::function<void()>& check = {}) {
  std::vector<const char*> argv{"prog"};
  for (const auto& a : args) argv.push_back(a.c_str());
  krr::OptionParser p = declare(o);
  Outcome r;
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  r.status = p.parse(static_cast<int>(argv.size()), argv.data(), check);
  r.out = testing::internal::GetCapturedStdout();
  r.err = testing::internal::GetCapturedStderr();
  return r;
}

bool startsWith(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

TEST(OptionParser, ValuesReachTheirTargets) {
  Options o;
  const Outcome r = run(o, {"--samples", "7", "--br=0.5", "--json", "--utterance", "a coke",
                        "--utterance", "yes", "x", "--level", "-3", "--", "--y"});
  EXPECT_FALSE(r.status);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(o.trials, 7u);
  EXPECT_DOUBLE_EQ(o.br, 0.5);
  EXPECT_TRUE(o.json);
  EXPECT_EQ(o.utterances, (std::vector<std::string>{"a coke", "yes"}));
  EXPECT_EQ(o.level, -3);
  EXPECT_EQ(o.rest, (std::vector<std::string>{"x", "--y"}));
}

TEST(OptionParser, HelpPrintsTheUsageOnStdoutExitsZeroAndSetsNothing) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--help"}, {"-h"}, {"--trials", "3", "--bogus", "-h"},
        {"--out", "x", "--help", "--br", "nan"}}) {
    Options o;
    bool checked = false;
    const Outcome r = run(o, args, [&] { checked = true; });
    ASSERT_TRUE(r.status);
    EXPECT_EQ(*r.status, 0);
    EXPECT_EQ(r.err, "");
    EXPECT_TRUE(startsWith(r.out, "usage: prog --trials N [options] [ARG...]\nDoes things.\n")) << r.out;
    EXPECT_NE(r.out.find("--trials, --samples N"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("blocking rate (default 0.3)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("CSV output (default stdout)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("-h, --help"), std::string::npos) << r.out;
    EXPECT_FALSE(checked);
    EXPECT_EQ(o.trials, 10u);
    EXPECT_EQ(o.out, "");
  }
}

TEST(OptionParser, ErrorsAreProgramMessageAndUsageOnStderrWithStatusTwo) {
  const std::pair<std::vector<std::string>, std::string> cases[] = {
      {{"--trials", "1", "--bogus"}, "prog: unknown option --bogus\n"},
      {{"--trials"}, "prog: option --trials needs a value\n"},
      {{"--trials", "x"}, "prog: option --trials: 'x' is not a number\n"},
      {{"--trials", "-1"}, "prog: option --trials: '-1' is not a non-negative integer\n"},
      {{"--trials", "1.5"}, "prog: option --trials: '1.5' is not a non-negative integer\n"},
      {{"--trials", "1", "--br", "inf"}, "prog: option --br: 'inf' is not a number\n"},
      {{"--trials", "1", "--level", "2.5"}, "prog: option --level: '2.5' is not an integer\n"},
      {{"--trials", "1", "--known", "5000000000"}, "prog: option --known: '5000000000' is too large\n"},
      {{"--trials", "1", "--json=yes"}, "prog: option --json takes no value\n"},
      {{"--br", "0.1"}, "prog: option --trials is required\n"},
  };
  for (const auto& [args, message] : cases) {
    Options o;
    const Outcome r = run(o, args);
    ASSERT_TRUE(r.status) << message;
    EXPECT_EQ(*r.status, 2) << message;
    EXPECT_EQ(r.out, "") << message;
    EXPECT_TRUE(startsWith(r.err, message + "usage: prog ")) << r.err;
  }
}

TEST(OptionParser, CheckErrorsAndUnexpectedArgumentsAreUsageErrors) {
  Options o;
  Outcome r = run(o, {"--trials", "0"}, [&] {
    if (o.trials == 0) throw krr::ConfigError("--trials must be at least 1");
  });
  ASSERT_TRUE(r.status);
  EXPECT_EQ(*r.status, 2);
  EXPECT_TRUE(startsWith(r.err, "prog: --trials must be at least 1\nusage: prog")) << r.err;

  krr::OptionParser p("bench");
  std::size_t n = 0;
  p.positional("N", "a count", [&](const std::string& v) { n = krr::parseCountOption("N", v); });
  const char* argv[] = {"bench", "4", "5"};
  testing::internal::CaptureStderr();
  const auto status = p.parse(3, argv);
  const std::string err = testing::internal::GetCapturedStderr();
  ASSERT_TRUE(status);
  EXPECT_EQ(*status, 2);
  EXPECT_EQ(n, 4u);
  EXPECT_TRUE(startsWith(err, "bench: unexpected argument '5'\nusage: bench [options] [N]\n")) << err;
}

TEST(OptionParser, GivenReportsWhatWasOnTheCommandLine) {
  Options o;
  krr::OptionParser p = declare(o);
  const char* argv[] = {"prog", "--samples", "2", "--json"};
  EXPECT_FALSE(p.parse(4, argv));
  EXPECT_TRUE(p.given("--trials"));
  EXPECT_TRUE(p.given("--samples"));
  EXPECT_TRUE(p.given("--json"));
  EXPECT_FALSE(p.given("--br"));
}

TEST(OptionParser, ADeprecatedNameStillWorksWarnsOnceAndIsNotListed) {
  std::string root;
  krr::OptionParser p("prog");
  p.add("--root", "DIR", "repository root", &root).deprecatedAlias("--repo");
  const char* argv[] = {"prog", "--repo", "/tmp/x"};
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_FALSE(p.parse(3, argv));
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
  EXPECT_EQ(testing::internal::GetCapturedStderr(),
            "prog: option --repo is deprecated: use --root\n");
  EXPECT_EQ(root, "/tmp/x");
  EXPECT_TRUE(p.given("--root"));
  // --repo=DIR too, and the new name says nothing.
  const char* eq[] = {"prog", "--repo=/tmp/y"};
  testing::internal::CaptureStderr();
  EXPECT_FALSE(p.parse(2, eq));
  EXPECT_EQ(testing::internal::GetCapturedStderr(),
            "prog: option --repo is deprecated: use --root\n");
  EXPECT_EQ(root, "/tmp/y");
  const char* now[] = {"prog", "--root", "/tmp/z"};
  testing::internal::CaptureStderr();
  EXPECT_FALSE(p.parse(3, now));
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(p.usage().find("--repo"), std::string::npos) << p.usage();
  EXPECT_THROW(p.add("--repo", "DIR", "again", &root), std::logic_error);
}

TEST(OptionParser, ListsAndDeclarationMistakes) {
  EXPECT_EQ(krr::parseNumberListOption("--reach", "0.5,1,2e-1"), (std::vector<double>{0.5, 1, 0.2}));
  EXPECT_EQ(krr::parseCountListOption("--sizes", "30,50"), (std::vector<std::size_t>{30, 50}));
  EXPECT_THROW(krr::parseNumberListOption("--reach", "0.5,,1"), krr::ConfigError);
  EXPECT_EQ(krr::splitOption("a:b::c", ':'), (std::vector<std::string>{"a", "b", "", "c"}));
  krr::OptionParser p("prog");
  bool f = false;
  p.flag("--x", "x", &f);
  EXPECT_THROW(p.flag("--x", "again", &f), std::logic_error);
  EXPECT_THROW(p.flag("--help", "reserved", &f), std::logic_error);
}

// The locator: $KRR_ROOT first; without it, the checkout of the krr_core package named by
// $ROS_PACKAGE_PATH (here a fake one) before the working directory's.
TEST(ResourceLocator, FindsTheRootFromEnvironmentPackagePathAndWorkingDirectory) {
  char tmpl[] = "/tmp/krr_locator_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  ASSERT_EQ(std::system(("mkdir -p " + dir + "/repo/config " + dir + "/repo/src/krr_core " +
                         dir + "/cwd/config " + dir + "/cwd/a").c_str()), 0);
  krr::writeFileAtomic(dir + "/repo/config/locator_marker.yaml", "x: 1\n");
  krr::writeFileAtomic(dir + "/cwd/config/locator_marker.yaml", "x: 1\n");
  krr::writeFileAtomic(dir + "/repo/src/krr_core/package.xml",
                       "<package><name>krr_core</name></package>\n");
  const auto save = [](const char* name) {
    const char* v = std::getenv(name);
    return std::make_pair(v != nullptr, std::string(v ? v : ""));
  };
  const auto krrRoot = save("KRR_ROOT"), rosPath = save("ROS_PACKAGE_PATH"),
             prefix = save("CMAKE_PREFIX_PATH");
  char cwd[4096];
  ASSERT_NE(::getcwd(cwd, sizeof cwd), nullptr);
  ::unsetenv("KRR_ROOT");
  ::unsetenv("CMAKE_PREFIX_PATH");
  ASSERT_EQ(::chdir((dir + "/cwd/a").c_str()), 0);
  const std::string marker = "config/locator_marker.yaml";

  ::setenv("ROS_PACKAGE_PATH", ("/nonexistent:" + dir + "/repo/src").c_str(), 1);
  EXPECT_EQ(krr::findRepositoryRoot("", marker), dir + "/repo");
  EXPECT_EQ(krr::resourcePath("", "config/x.yaml", "/given"), "/given/config/x.yaml");
  EXPECT_EQ(krr::resourcePath("mine.yaml", "config/x.yaml"), "mine.yaml");
  ::setenv("ROS_PACKAGE_PATH", "/nonexistent", 1);
  EXPECT_EQ(krr::findRepositoryRoot("", marker), dir + "/cwd");
  // The source space a devel prefix names in its .catkin file.
  krr::writeFileAtomic(dir + "/.catkin", dir + "/repo/src");
  ::setenv("CMAKE_PREFIX_PATH", dir.c_str(), 1);
  EXPECT_EQ(krr::findRepositoryRoot("", marker), dir + "/repo");
  ::setenv("KRR_ROOT", "/from/env", 1);
  EXPECT_EQ(krr::findRepositoryRoot("", marker), "/from/env");
  EXPECT_EQ(krr::findRepositoryRoot("/hint", marker), "/hint");
  ::unsetenv("KRR_ROOT");
  EXPECT_THROW(krr::findRepositoryRoot("", "config/no_such_marker_anywhere.yaml"), krr::ConfigError);

  ASSERT_EQ(::chdir(cwd), 0);
  for (const auto& [name, v] : {std::make_pair("KRR_ROOT", krrRoot),
                                std::make_pair("ROS_PACKAGE_PATH", rosPath),
                                std::make_pair("CMAKE_PREFIX_PATH", prefix)}) {
    if (v.first) ::setenv(name, v.second.c_str(), 1);
    else ::unsetenv(name);
  }
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace
