/**
 * @file subprocess.h
 * @brief Running a program as a child process with a time budget.
 *
 * fork + exec rather than posix_spawn: the child can ask the kernel to kill it when the thread
 * that started it dies (PR_SET_PDEATHSIG), so a program killed mid-run (Ctrl-C, `timeout`,
 * kill -9) leaves no child running past its time limit. A close-on-exec pipe carries the errno
 * of a failed exec (or of a failed redirection) back, so a missing program is an exception of
 * start(), not an exit code. Each standard stream of the child is /dev/null, a file, a pipe
 * to this process (stdin: a text written to it; stdout, stderr: captured into strings) or
 * inherited. wait() waits for the end without polling latency on a pidfd (polling waitpid
 * where pidfds are unavailable), serving the pipes meanwhile, and kills the child (SIGKILL)
 * when the time budget is spent or a cancel flag is raised.
 */
#pragma once

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"

namespace krr {

/// @brief A Subprocess could not be started or waited for: which step failed and its errno.
class SubprocessError : public Error {
 public:
  enum class Step {
    kPipe,   ///< creating a pipe (the exec-error pipe or a stream's)
    kFork,   ///< fork()
    kStart,  ///< in the child: redirecting a stream or exec (program missing, not executable)
    kWait,   ///< poll() or waitpid() while waiting for the end
  };
  SubprocessError(Step step, int errnum, const std::string& what)
      : Error(what), step_(step), errnum_(errnum) {}
  Step step() const { return step_; }
  int errnum() const { return errnum_; }  ///< the errno of the failed call

 private:
  Step step_;
  int errnum_;
};

/// @brief How a child process ended (Subprocess::wait).
struct SubprocessResult {
  enum class End {
    kExited,     ///< it exited: exit_code
    kSignalled,  ///< a signal killed it: signal
    kTimedOut,   ///< the time budget was spent: killed with SIGKILL and reaped
    kCancelled,  ///< the cancel flag was raised: killed with SIGKILL and reaped
  };
  End end = End::kExited;
  int status = 0;      ///< the raw waitpid status (kExited, kSignalled)
  int exit_code = -1;  ///< kExited: its exit code, else -1
  int signal = 0;      ///< kSignalled: the signal that killed it, else 0
  std::string out;     ///< what it wrote on stdout, with Stream::pipe()
  std::string err;     ///< what it wrote on stderr, with Stream::pipe()
};

/**
 * @brief One child process: configure its streams, start() it, wait() for its end.
 *
 * A Subprocess still running when destroyed (an exception between start and wait) is killed
 * with SIGKILL and reaped, and every pipe is closed. Not copyable.
 */
class Subprocess {
 public:
  /// @brief Where one standard stream of the child goes.
  struct Stream {
    enum class Kind { kNull, kFile, kPipe, kInherit };
    Kind kind = Kind::kNull;
    std::string path;  ///< kFile: the file (stdin: read; stdout, stderr: created, truncated)
    std::string text;  ///< kPipe on stdin: what is written to it (then it is closed)
    static Stream null() { return {}; }                        ///< /dev/null
    static Stream file(const std::string& p) { return {Kind::kFile, p, ""}; }
    static Stream pipe(const std::string& input = "") { return {Kind::kPipe, "", input}; }
    static Stream inherit() { return {Kind::kInherit, "", ""}; }  ///< this process's own
  };

  /// @brief The program (argv[0], looked up in PATH like execvp) and its arguments.
  /// Every stream is /dev/null until set.
  explicit Subprocess(std::vector<std::string> argv);
  ~Subprocess();
  Subprocess(const Subprocess&) = delete;
  Subprocess& operator=(const Subprocess&) = delete;

  Subprocess& setStdin(Stream s);
  Subprocess& setStdout(Stream s);
  Subprocess& setStderr(Stream s);
  /// @brief Whether the child is killed (SIGKILL) when the thread that started it dies
  /// (default: true).
  Subprocess& killWithParent(bool on);

  /// @brief Start the child. Returns once it runs the program (exec succeeded); the time
  /// budget of wait() counts from then.
  /// @throws SubprocessError: kPipe, kFork, or kStart with the child's errno (ENOENT: no such
  /// program). std::logic_error when already started or argv is empty.
  void start();
  /// @brief Wait for the end of the child, at most `timeout_s` seconds after start() returned
  /// (infinity: no limit), writing stdin's text and reading captured output meanwhile. When
  /// `cancel` is set, it is looked at every 10 ms. A timed out or cancelled child is killed
  /// with SIGKILL and reaped (output captured so far is kept).
  /// @throws ConfigError when timeout_s is not positive (or NaN); SubprocessError (kWait) when
  /// poll or waitpid fail; std::logic_error when not started or already waited for.
  SubprocessResult wait(double timeout_s, const std::atomic<bool>* cancel = nullptr);

  pid_t pid() const { return pid_; }  ///< the child's pid once started, else -1

 private:
  struct Pipe {
    int parent = -1;    ///< this process's end (-1: none or closed)
    std::size_t written = 0;  ///< stdin: bytes of the text written so far
  };
  void killAndReap();
  void serveStreams(short stdinEvents, short outEvents, short errEvents, SubprocessResult* r);
  void drainOutput(SubprocessResult* r);
  void closeStreams();
  SubprocessResult finish(int status, SubprocessResult r);

  std::vector<std::string> argv_;
  Stream streams_[3];
  bool killWithParent_ = true;
  pid_t pid_ = -1;
  bool reaped_ = false;
  Pipe pipes_[3];
  std::chrono::steady_clock::time_point start_;
};

}  // namespace krr
