#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <stdexcept>
#include <utility>
#include <thread>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/json.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/random.h"
#include "krr_core/common/resource_locator.h"

namespace {

std::string tempDir() {
  char tmpl[] = "/tmp/krr_files_XXXXXX";
  char* d = ::mkdtemp(tmpl);
  EXPECT_NE(d, nullptr);
  return d;
}

TEST(Files, AtomicWriteReplacesContentAndLeavesNoTemporaries) {
  std::string dir = tempDir();
  std::string path = dir + "/kb.plog";
  krr::writeFileAtomic(path, "first\n");
  EXPECT_EQ(krr::readFile(path), "first\n");
  krr::writeFileAtomic(path, "second\n");
  EXPECT_EQ(krr::readFile(path), "second\n");
  EXPECT_EQ(std::system(("test $(ls -A " + dir + " | wc -l) -eq 1").c_str()), 0);
  std::system(("rm -rf " + dir).c_str());
}

TEST(Files, IsRegularFileIsTrueOnlyForWhatAReaderCanOpen) {
  const std::string dir = tempDir();
  krr::writeFileAtomic(dir + "/kb.plog", "a.\n");
  EXPECT_TRUE(krr::isRegularFile(dir + "/kb.plog"));
  EXPECT_EQ(::symlink((dir + "/kb.plog").c_str(), (dir + "/link.plog").c_str()), 0);
  EXPECT_TRUE(krr::isRegularFile(dir + "/link.plog"));  // a symlink to a file is followed
  EXPECT_FALSE(krr::isRegularFile(dir));                 // a directory
  EXPECT_FALSE(krr::isRegularFile("/dev/null"));         // a device
  EXPECT_FALSE(krr::isRegularFile(dir + "/missing"));
  EXPECT_FALSE(krr::isRegularFile(""));
  std::system(("rm -rf " + dir).c_str());
}

TEST(Files, FailedWriteKeepsOldContentAndNamesTheFile) {
  std::string dir = tempDir();
  std::string path = dir + "/sub/none.txt";  // directory does not exist
  try {
    krr::writeFileAtomic(path, "x");
    FAIL() << "expected IoError";
  } catch (const krr::IoError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
  }
  EXPECT_THROW(krr::readFile(dir + "/missing"), krr::IoError);
  std::system(("rm -rf " + dir).c_str());
}

TEST(Files, MakeDirectoriesCreatesParentsAndRefusesFilesInThePath) {
  const std::string dir = tempDir();
  const std::string nested = dir + "/a/b/c";
  krr::makeDirectories(nested);
  krr::makeDirectories(nested);  // existing directories are fine
  krr::writeFileAtomic(nested + "/file", "x");
  EXPECT_EQ(krr::readFile(nested + "/file"), "x");
  EXPECT_NO_THROW(krr::makeDirectories(""));
  // A file where a directory should be: IoError naming it.
  try {
    krr::makeDirectories(nested + "/file/sub");
    ADD_FAILURE() << "expected IoError";
  } catch (const krr::IoError& e) {
    EXPECT_NE(std::string(e.what()).find(nested + "/file"), std::string::npos) << e.what();
  }
  std::system(("rm -rf " + dir).c_str());
}

TEST(Files, FileLockExcludesOtherHoldersUntilReleased) {
  const std::string lock = tempDir() + "/entry.lock";
  std::atomic<bool> got{false};
  std::thread other;
  {
    krr::FileLock held(lock);
    other = std::thread([&] {
      krr::FileLock second(lock);  // another open file description: waits for `held`
      got = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_FALSE(got) << "a second holder got the lock while the first held it";
  }
  other.join();
  EXPECT_TRUE(got);
  EXPECT_THROW(krr::FileLock("/nonexistent_dir_krr/x.lock"), krr::IoError);
}

TEST(Files, StableHashIsFnv1a) {
  EXPECT_EQ(krr::stableHash("policy text"), krr::stableHash(std::string("policy ") + "text"));
  EXPECT_NE(krr::stableHash("policy text"), krr::stableHash("policy texT"));
  // FNV-1a 64 test vectors: the offset basis for "", and "a".
  EXPECT_EQ(krr::stableHash(""), 14695981039346656037ULL);
  EXPECT_EQ(krr::stableHash("a"), 0xaf63dc4c8601ec8cULL);
}

TEST(Json, EscapesControlCharactersAndQuotes) {
  EXPECT_EQ(krr::jsonString("a\"b\\c\n\x01"), "\"a\\\"b\\\\c\\n\\u0001\"");
  EXPECT_EQ(krr::jsonNumber(0.5), "0.5");
  EXPECT_EQ(krr::jsonNumber(1.0 / 0.0), "null");
}

TEST(Random, DerivedStreamsAreReproducibleAndDistinct) {
  EXPECT_EQ(krr::deriveSeed(42, "trial", 3), krr::deriveSeed(42, "trial", 3));
  EXPECT_NE(krr::deriveSeed(42, "trial", 3), krr::deriveSeed(42, "trial", 4));
  EXPECT_NE(krr::deriveSeed(42, "trial", 3), krr::deriveSeed(43, "trial", 3));
  EXPECT_NE(krr::deriveSeed(42, "trial", 3), krr::deriveSeed(42, "user", 3));
  krr::Rng a = krr::makeRng(7, "x"), b = krr::makeRng(7, "x");
  for (int i = 0; i < 10; ++i) EXPECT_EQ(a(), b());
  double u = krr::uniform01(a);
  EXPECT_GE(u, 0.0);
  EXPECT_LT(u, 1.0);
}

TEST(Files, FindsTheRepositoryRootFromHintEnvironmentAndWorkingDirectory) {
  char tmpl[] = "/tmp/krr_root_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  ASSERT_EQ(std::system(("mkdir -p " + dir + "/config " + dir + "/a/b").c_str()), 0);
  krr::writeFileAtomic(dir + "/config/marker_for_test.yaml", "x: 1\n");
  const char* saved_env = std::getenv("KRR_ROOT");
  const std::string saved = saved_env ? saved_env : "";
  ::unsetenv("KRR_ROOT");
  char cwd[4096];
  ASSERT_NE(::getcwd(cwd, sizeof cwd), nullptr);
  EXPECT_EQ(krr::findRepositoryRoot("/given", "config/marker_for_test.yaml"), "/given");
  ASSERT_EQ(::chdir((dir + "/a/b").c_str()), 0);
  EXPECT_EQ(krr::findRepositoryRoot("", "config/marker_for_test.yaml"), dir);
  EXPECT_THROW(krr::findRepositoryRoot("", "config/no_such_marker_anywhere.yaml"), krr::ConfigError);
  ::setenv("KRR_ROOT", "/from/env", 1);
  EXPECT_EQ(krr::findRepositoryRoot("", "config/marker_for_test.yaml"), "/from/env");
  ASSERT_EQ(::chdir(cwd), 0);
  if (saved_env) ::setenv("KRR_ROOT", saved.c_str(), 1); else ::unsetenv("KRR_ROOT");
  std::system(("rm -rf " + dir).c_str());
}

TEST(Errors, ParseErrorCarriesLocation) {
  krr::ParseError e({"kb.plog", 3, 14}, "expected '.'");
  EXPECT_STREQ(e.what(), "kb.plog:3:14: expected '.'");
  EXPECT_EQ(e.location().line, 3);
}

}  // namespace

namespace {

// Special files have no end (/dev/zero) or block (a FIFO without writer): loaders refuse them.
TEST(Files, ReadFileRefusesSpecialFiles) {
  const std::string dir = tempDir();
  const std::string fifo = dir + "/fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::pair<std::string, std::string> cases[] = {
      {"/dev/zero", "character device"}, {dir, "directory"}, {fifo, "pipe"}};
  for (const auto& c : cases) {
    try {
      krr::readFile(c.first);
      ADD_FAILURE() << "no error for " << c.first;
    } catch (const krr::IoError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.find(c.first + ": is "), 0u) << msg;
      EXPECT_NE(msg.find(c.second), std::string::npos) << msg;
      EXPECT_NE(msg.find("expected a regular file"), std::string::npos) << msg;
    }
  }
  ::unlink(fifo.c_str());
}

TEST(Files, ReadFileHonoursTheMemoryBudget) {
  const std::string dir = tempDir();
  const std::string path = dir + "/big";
  krr::writeFileAtomic(path, std::string(3 << 20, 'x'));
  ::setenv("KRR_MEMORY_BUDGET_MIB", "2", 1);
  try {
    krr::readFile(path);
    ADD_FAILURE() << "no error";
  } catch (const krr::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("3 MiB exceeds the memory budget of 2 MiB"),
              std::string::npos) << e.what();
  }
  ::setenv("KRR_MEMORY_BUDGET_MIB", "two", 1);
  EXPECT_THROW(krr::memoryBudget(), krr::ConfigError);  // a typo never disables the limit
  ::unsetenv("KRR_MEMORY_BUDGET_MIB");
  EXPECT_EQ(krr::memoryBudget(), krr::defaultMemoryBudget());
  EXPECT_EQ(krr::readFile(path).size(), std::size_t(3) << 20);
}

TEST(Limits, TheDefaultBudgetComesFromTheMachine) {
  ::unsetenv("KRR_MEMORY_BUDGET_MIB");
  const std::size_t physical = static_cast<std::size_t>(::sysconf(_SC_PHYS_PAGES)) *
                               static_cast<std::size_t>(::sysconf(_SC_PAGE_SIZE));
  struct rlimit rl;
  ASSERT_EQ(::getrlimit(RLIMIT_AS, &rl), 0);
  std::size_t expected = std::clamp(physical / 8, krr::kDefaultMemoryBudget,
                                    krr::kMaxDefaultMemoryBudget);
  if (rl.rlim_cur != RLIM_INFINITY) expected = std::min(expected, rl.rlim_cur / 2);
  EXPECT_EQ(krr::defaultMemoryBudget(), expected);
  EXPECT_EQ(krr::memoryBudget(), expected);
  // Under an address-space limit the budget is at most half of it (reached before an
  // allocation fails): checked in a child, whose limit does not reach this process.
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    struct rlimit low = rl;
    low.rlim_cur = std::size_t(512) << 20;
    if (::setrlimit(RLIMIT_AS, &low) != 0) ::_exit(2);
    ::_exit(krr::defaultMemoryBudget() == (std::size_t(256) << 20) ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "512 MiB address space: budget not 256 MiB";
}

TEST(Limits, SaturatingArithmeticAndFormatting) {
  EXPECT_EQ(krr::saturatingMul(SIZE_MAX / 2, 3), SIZE_MAX);
  EXPECT_EQ(krr::saturatingMul(6, 7), 42u);
  EXPECT_EQ(krr::saturatingAdd(SIZE_MAX, 1), SIZE_MAX);
  EXPECT_EQ(krr::formatBytes(512), "512 B");
  EXPECT_EQ(krr::formatBytes(std::size_t(3) << 30), "3 GiB");
  EXPECT_EQ(krr::formatBytes(SIZE_MAX), "more than 16 EiB");
}

TEST(Limits, PlainNames) {
  EXPECT_TRUE(krr::isPlainName("office_30x30"));
  EXPECT_TRUE(krr::isPlainName("A-b_9"));
  for (const char* bad : {"", "../../x", "a/b", "..", ".", "a b", "x\n"})
    EXPECT_FALSE(krr::isPlainName(bad)) << bad;
}

int throwsBadAlloc(int, char**) { throw std::bad_alloc(); }
int throwsLogicError(int, char**) { throw std::logic_error("boom"); }
int returnsSeven(int, char**) { return 7; }

// Every CLI runs under guardedMain: an escaping bad_alloc is a message and status 1, no abort.
TEST(MainGuard, TurnsEscapingExceptionsIntoStatusOne) {
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(krr::guardedMain("prog", throwsBadAlloc, 0, nullptr), 1);
  EXPECT_EQ(krr::guardedMain("prog", throwsLogicError, 0, nullptr), 1);
  EXPECT_EQ(krr::guardedMain("prog", returnsSeven, 0, nullptr), 7);
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("prog: out of memory"), std::string::npos) << err;
  EXPECT_NE(err.find("prog: internal error: boom"), std::string::npos) << err;
}

}  // namespace
