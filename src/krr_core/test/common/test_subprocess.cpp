#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/subprocess.h"

namespace {

using krr::Subprocess;
using krr::SubprocessError;
using krr::SubprocessResult;

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

TEST(Subprocess, EchoWritesItsArgumentsOnStdout) {
  Subprocess p({"/bin/echo", "hello", "world"});
  p.setStdout(Subprocess::Stream::pipe());
  p.start();
  EXPECT_GT(p.pid(), 0);
  const SubprocessResult r = p.wait(10.0);
  EXPECT_EQ(r.end, SubprocessResult::End::kExited);
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out, "hello world\n");
  EXPECT_EQ(r.err, "");  // stderr: /dev/null unless set
}

TEST(Subprocess, ShellReadsItsStdinAndWritesBothStreams) {
  Subprocess p({"/bin/sh", "-c", "tr a-z A-Z; echo done >&2"});
  p.setStdin(Subprocess::Stream::pipe("some input\nsecond line\n"))
      .setStdout(Subprocess::Stream::pipe())
      .setStderr(Subprocess::Stream::pipe());
  p.start();
  const SubprocessResult r = p.wait(10.0);
  EXPECT_EQ(r.end, SubprocessResult::End::kExited);
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out, "SOME INPUT\nSECOND LINE\n");
  EXPECT_EQ(r.err, "done\n");
}

TEST(Subprocess, LargeStdinAndStdoutDoNotDeadlock) {
  // More than a pipe buffer both ways: stdin is written while stdout is read.
  const std::string input(1 << 20, 'x');
  Subprocess p({"/bin/cat"});
  p.setStdin(Subprocess::Stream::pipe(input)).setStdout(Subprocess::Stream::pipe());
  p.start();
  const SubprocessResult r = p.wait(30.0);
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out.size(), input.size());
  EXPECT_EQ(r.out, input);
}

TEST(Subprocess, AChildThatIgnoresItsStdinDoesNotKillTheParent) {
  // The child exits without reading: writing the rest of stdin meets a closed pipe (EPIPE,
  // no SIGPIPE for this process).
  Subprocess p({"/bin/sh", "-c", "exec 0<&-; exit 3"});
  p.setStdin(Subprocess::Stream::pipe(std::string(1 << 20, 'y')));
  p.start();
  const SubprocessResult r = p.wait(10.0);
  EXPECT_EQ(r.end, SubprocessResult::End::kExited);
  EXPECT_EQ(r.exit_code, 3);
}

TEST(Subprocess, FilesAsStreams) {
  char tmpl[] = "/tmp/krr_subprocess_XXXXXX";
  ASSERT_NE(::mkdtemp(tmpl), nullptr);
  const std::string dir = tmpl;
  krr::writeFileAtomic(dir + "/in.txt", "from a file\n");
  Subprocess p({"/bin/sh", "-c", "cat; echo oops >&2"});
  p.setStdin(Subprocess::Stream::file(dir + "/in.txt"))
      .setStdout(Subprocess::Stream::file(dir + "/out.txt"))
      .setStderr(Subprocess::Stream::file(dir + "/err.txt"));
  p.start();
  EXPECT_EQ(p.wait(10.0).exit_code, 0);
  EXPECT_EQ(krr::readFile(dir + "/out.txt"), "from a file\n");
  EXPECT_EQ(krr::readFile(dir + "/err.txt"), "oops\n");
  std::system(("rm -rf " + dir).c_str());
}

TEST(Subprocess, NonZeroExitAndSignalAreReported) {
  Subprocess fails({"/bin/sh", "-c", "echo bad >&2; exit 42"});
  fails.setStderr(Subprocess::Stream::pipe());
  fails.start();
  const SubprocessResult r = fails.wait(10.0);
  EXPECT_EQ(r.end, SubprocessResult::End::kExited);
  EXPECT_EQ(r.exit_code, 42);
  EXPECT_EQ(r.signal, 0);
  EXPECT_EQ(r.err, "bad\n");

  Subprocess killed({"/bin/sh", "-c", "kill -TERM $$"});
  killed.start();
  const SubprocessResult k = killed.wait(10.0);
  EXPECT_EQ(k.end, SubprocessResult::End::kSignalled);
  EXPECT_EQ(k.signal, SIGTERM);
  EXPECT_EQ(k.exit_code, -1);
}

TEST(Subprocess, ATimedOutChildIsKilled) {
  Subprocess p({"sleep", "10"});  // found in PATH
  p.start();
  const pid_t pid = p.pid();
  const auto t0 = std::chrono::steady_clock::now();
  const SubprocessResult r = p.wait(0.2);
  EXPECT_EQ(r.end, SubprocessResult::End::kTimedOut);
  EXPECT_LT(secondsSince(t0), 5.0);
  EXPECT_GE(secondsSince(t0), 0.15);
  // Killed and reaped: the pid is gone.
  EXPECT_EQ(::kill(pid, 0), -1);
  EXPECT_EQ(errno, ESRCH);
  EXPECT_THROW(p.wait(1.0), std::logic_error);  // waited for once
}

TEST(Subprocess, ACancelledChildIsKilled) {
  std::atomic<bool> cancel{false};
  Subprocess p({"sleep", "10"});
  p.start();
  std::thread raiser([&]() {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    cancel = true;
  });
  const auto t0 = std::chrono::steady_clock::now();
  const SubprocessResult r = p.wait(30.0, &cancel);
  raiser.join();
  EXPECT_EQ(r.end, SubprocessResult::End::kCancelled);
  EXPECT_LT(secondsSince(t0), 5.0);
}

TEST(Subprocess, AMissingProgramFailsToStart) {
  Subprocess p({"/nonexistent/krr_no_such_program", "x"});
  try {
    p.start();
    FAIL() << "started a missing program";
  } catch (const SubprocessError& e) {
    EXPECT_EQ(e.step(), SubprocessError::Step::kStart);
    EXPECT_EQ(e.errnum(), ENOENT);
    EXPECT_EQ(std::string(e.what()),
              "cannot start '/nonexistent/krr_no_such_program': No such file or directory");
  }
  Subprocess notInPath({"krr_no_such_program_in_path"});
  EXPECT_THROW(notInPath.start(), SubprocessError);
  // A stream file that cannot be opened is a failure to start too.
  Subprocess badFile({"/bin/echo"});
  badFile.setStdin(Subprocess::Stream::file("/nonexistent/input.txt"));
  EXPECT_THROW(badFile.start(), SubprocessError);
}

TEST(Subprocess, MisuseIsRefused) {
  Subprocess p({"/bin/echo"});
  EXPECT_THROW(p.wait(1.0), std::logic_error);  // not started
  p.start();
  EXPECT_THROW(p.start(), std::logic_error);
  EXPECT_THROW(p.wait(0.0), krr::ConfigError);
  EXPECT_THROW(p.wait(-1.0), krr::ConfigError);
  EXPECT_EQ(p.wait(10.0).exit_code, 0);
  Subprocess empty({});
  EXPECT_THROW(empty.start(), std::logic_error);
}

TEST(Subprocess, NoTimeLimitWithInfinity) {
  Subprocess p({"/bin/sh", "-c", "exit 0"});
  p.start();
  EXPECT_EQ(p.wait(std::numeric_limits<double>::infinity()).exit_code, 0);
}

TEST(Subprocess, DestroyingARunningChildKillsIt) {
  pid_t pid = -1;
  {
    Subprocess p({"sleep", "10"});
    p.start();
    pid = p.pid();
    EXPECT_EQ(::kill(pid, 0), 0);
  }
  EXPECT_EQ(::kill(pid, 0), -1);
  EXPECT_EQ(errno, ESRCH);
}

}  // namespace
