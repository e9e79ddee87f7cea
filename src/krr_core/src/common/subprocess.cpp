#include "krr_core/common/subprocess.h"

#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace krr {

namespace {

constexpr std::size_t kReadChunk = 65536;

void closeFd(int* fd) {
  if (*fd >= 0) close(*fd);
  *fd = -1;
}

/// @brief write() that turns a closed reading end into EPIPE without raising SIGPIPE in this
/// process (the signal is blocked for the call and a SIGPIPE it raised is consumed).
ssize_t writeNoSigpipe(int fd, const char* data, std::size_t n) {
  sigset_t pipeSet, old, pending;
  sigemptyset(&pipeSet);
  sigaddset(&pipeSet, SIGPIPE);
  sigemptyset(&pending);
  pthread_sigmask(SIG_BLOCK, &pipeSet, &old);
  sigpending(&pending);
  const bool wasPending = sigismember(&pending, SIGPIPE) == 1;
  const ssize_t w = write(fd, data, n);
  const int e = errno;
  if (w < 0 && e == EPIPE && !wasPending) {
    const struct timespec zero = {0, 0};
    while (sigtimedwait(&pipeSet, nullptr, &zero) < 0 && errno == EINTR) {
    }
  }
  pthread_sigmask(SIG_SETMASK, &old, nullptr);
  errno = e;
  return w;
}

}  // namespace

Subprocess::Subprocess(std::vector<std::string> argv) : argv_(std::move(argv)) {}

Subprocess::~Subprocess() {
  if (pid_ >= 0 && !reaped_) killAndReap();
  closeStreams();
}

Subprocess& Subprocess::setStdin(Stream s) {
  streams_[0] = std::move(s);
  return *this;
}

Subprocess& Subprocess::setStdout(Stream s) {
  streams_[1] = std::move(s);
  return *this;
}

Subprocess& Subprocess::setStderr(Stream s) {
  streams_[2] = std::move(s);
  return *this;
}

Subprocess& Subprocess::killWithParent(bool on) {
  killWithParent_ = on;
  return *this;
}

void Subprocess::start() {
  if (pid_ >= 0) throw std::logic_error("Subprocess::start: already started");
  if (argv_.empty()) throw std::logic_error("Subprocess::start: no program");
  std::vector<char*> argv;
  for (auto& a : argv_) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const std::string& program = argv_[0];

  // The child's end of each piped stream, and the paths it opens (no allocation after fork).
  int child[3] = {-1, -1, -1};
  const char* paths[3] = {nullptr, nullptr, nullptr};
  int errpipe[2] = {-1, -1};
  auto closeAll = [&]() {
    closeFd(&errpipe[0]);
    closeFd(&errpipe[1]);
    for (int i = 0; i < 3; ++i) closeFd(&child[i]);
    closeStreams();
  };
  if (pipe2(errpipe, O_CLOEXEC) != 0) {
    const int e = errno;
    throw SubprocessError(SubprocessError::Step::kPipe, e,
                          "cannot create a pipe for '" + program + "': " + std::strerror(e));
  }
  for (int i = 0; i < 3; ++i) {
    const Stream& s = streams_[i];
    if (s.kind == Stream::Kind::kNull) paths[i] = "/dev/null";
    if (s.kind == Stream::Kind::kFile) paths[i] = s.path.c_str();
    if (s.kind != Stream::Kind::kPipe) continue;
    int p[2];
    if (pipe2(p, O_CLOEXEC) != 0) {
      const int e = errno;
      closeAll();
      throw SubprocessError(SubprocessError::Step::kPipe, e,
                            "cannot create a pipe for '" + program + "': " + std::strerror(e));
    }
    child[i] = i == 0 ? p[0] : p[1];
    pipes_[i].parent = i == 0 ? p[1] : p[0];
    pipes_[i].written = 0;
  }

  const pid_t parent = getpid();
  const bool pdeath = killWithParent_;
  const pid_t pid = fork();
  if (pid < 0) {
    const int e = errno;
    closeAll();
    throw SubprocessError(SubprocessError::Step::kFork, e,
                          "cannot start '" + program + "': " + std::strerror(e));
  }
  if (pid == 0) {
    // Child: async-signal-safe calls only until exec.
    if (pdeath) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != parent) _exit(127);  // the parent died before prctl took effect
    }
    int e = 0;
    for (int i = 0; i < 3 && e == 0; ++i) {
      int fd = child[i];
      if (paths[i] != nullptr)
        fd = open(paths[i],
                  i == 0 ? O_RDONLY | O_CLOEXEC : O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
      if (paths[i] == nullptr && child[i] < 0) continue;  // inherited
      if (fd < 0 || dup2(fd, i) < 0 || (fd == i && fcntl(fd, F_SETFD, 0) < 0)) e = errno;
    }
    if (e == 0) {
      execvp(argv[0], argv.data());
      e = errno;
    }
    ssize_t ignored = write(errpipe[1], &e, sizeof(e));
    (void)ignored;
    _exit(127);
  }
  pid_ = pid;
  closeFd(&errpipe[1]);
  for (int i = 0; i < 3; ++i) closeFd(&child[i]);
  int childErrno = 0;
  ssize_t got;
  while ((got = read(errpipe[0], &childErrno, sizeof(childErrno))) < 0 && errno == EINTR) {
  }
  closeFd(&errpipe[0]);
  if (got > 0) {
    int st = 0;
    while (waitpid(pid_, &st, 0) < 0 && errno == EINTR) {
    }
    reaped_ = true;
    closeStreams();
    throw SubprocessError(SubprocessError::Step::kStart, childErrno,
                          "cannot start '" + program + "': " + std::strerror(childErrno));
  }
  for (int i = 0; i < 3; ++i)
    if (pipes_[i].parent >= 0)
      fcntl(pipes_[i].parent, F_SETFL, fcntl(pipes_[i].parent, F_GETFL) | O_NONBLOCK);
  if (pipes_[0].parent >= 0 && streams_[0].text.empty()) closeFd(&pipes_[0].parent);
  start_ = std::chrono::steady_clock::now();
}

void Subprocess::killAndReap() {
  kill(pid_, SIGKILL);
  int st = 0;
  while (waitpid(pid_, &st, 0) < 0 && errno == EINTR) {
  }
  reaped_ = true;
}

void Subprocess::closeStreams() {
  for (auto& p : pipes_) closeFd(&p.parent);
}

/// @brief Writes what stdin can take and reads what stdout and stderr hold, for the poll
/// events of each (0: that stream is not looked at).
void Subprocess::serveStreams(short stdinEvents, short outEvents, short errEvents,
                              SubprocessResult* r) {
  Pipe& in = pipes_[0];
  if (in.parent >= 0 && stdinEvents != 0) {
    const std::string& text = streams_[0].text;
    const ssize_t w = writeNoSigpipe(in.parent, text.data() + in.written, text.size() - in.written);
    if (w > 0) in.written += static_cast<std::size_t>(w);
    if (in.written >= text.size() || (w < 0 && errno != EAGAIN && errno != EINTR))
      closeFd(&in.parent);  // all written, or the child closed its stdin (EPIPE)
  }
  const short events[3] = {0, outEvents, errEvents};
  std::string* sinks[3] = {nullptr, &r->out, &r->err};
  for (int i = 1; i < 3; ++i) {
    if (pipes_[i].parent < 0 || events[i] == 0) continue;
    char buf[kReadChunk];
    const ssize_t n = read(pipes_[i].parent, buf, sizeof(buf));
    if (n > 0) sinks[i]->append(buf, static_cast<std::size_t>(n));
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) closeFd(&pipes_[i].parent);
  }
}

/// @brief Reads what the child left in its output pipes, without waiting for writers that
/// outlive it (a background grandchild holding the pipe open).
void Subprocess::drainOutput(SubprocessResult* r) {
  std::string* sinks[3] = {nullptr, &r->out, &r->err};
  for (int i = 1; i < 3; ++i) {
    char buf[kReadChunk];
    while (pipes_[i].parent >= 0) {
      const ssize_t n = read(pipes_[i].parent, buf, sizeof(buf));
      if (n > 0) {
        sinks[i]->append(buf, static_cast<std::size_t>(n));
      } else if (!(n < 0 && errno == EINTR)) {
        closeFd(&pipes_[i].parent);  // end of file, nothing more now (EAGAIN), or an error
      }
    }
  }
  closeStreams();
}

SubprocessResult Subprocess::finish(int status, SubprocessResult r) {
  r.status = status;
  if (WIFEXITED(status)) {
    r.end = SubprocessResult::End::kExited;
    r.exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    r.end = SubprocessResult::End::kSignalled;
    r.signal = WTERMSIG(status);
  }
  return r;
}

SubprocessResult Subprocess::wait(double timeout_s, const std::atomic<bool>* cancel) {
  if (!(timeout_s > 0.0))
    throw ConfigError("Subprocess::wait: the time budget must be a positive number of seconds, "
                      "got " + std::to_string(timeout_s));
  if (pid_ < 0) throw std::logic_error("Subprocess::wait: not started");
  if (reaped_) throw std::logic_error("Subprocess::wait: already waited for");
  SubprocessResult r;
  const bool bounded = std::isfinite(timeout_s);
  const auto limit = std::chrono::duration<double>(bounded ? timeout_s : 0.0);
  auto cancelled = [&]() { return cancel != nullptr && cancel->load(); };
  auto stop = [&](SubprocessResult::End end) {
    killAndReap();
    drainOutput(&r);
    r.end = end;
    return r;
  };
  auto waitFailed = [&](int e) {
    return SubprocessError(SubprocessError::Step::kWait, e, "waiting for '" + argv_[0] +
                           "' failed: " + std::strerror(e));
  };
  int status = 0;
  // Wait for the end without polling latency: a pidfd becomes readable when the process
  // exits. Where pidfds are unavailable, fall back to polling waitpid.
  // (Direct system call: glibc 2.36's <sys/pidfd.h> lacks C linkage for C++.)
#ifdef SYS_pidfd_open
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, pid_, 0));
#else
  const int pidfd = -1;
#endif
  if (pidfd >= 0) {
    for (;;) {
      long ms = 1000000L;
      if (bounded) {
        const auto left = limit - (std::chrono::steady_clock::now() - start_);
        const double leftMs = std::ceil(std::chrono::duration<double, std::milli>(left).count());
        ms = leftMs > 1e9 ? 1000000000L : static_cast<long>(leftMs);
      }
      if (ms <= 0) {
        close(pidfd);
        return stop(SubprocessResult::End::kTimedOut);
      }
      if (cancelled()) {
        close(pidfd);
        return stop(SubprocessResult::End::kCancelled);
      }
      struct pollfd pfd[4] = {{pidfd, POLLIN, 0}, {-1, 0, 0}, {-1, 0, 0}, {-1, 0, 0}};
      for (int i = 0; i < 3; ++i)
        if (pipes_[i].parent >= 0)
          pfd[i + 1] = {pipes_[i].parent, static_cast<short>(i == 0 ? POLLOUT : POLLIN), 0};
      // With a cancel flag, look at it every 10 ms.
      const long slice = cancel != nullptr ? std::min<long>(ms, 10L) : std::min<long>(ms, 1000000L);
      const int n = poll(pfd, 4, static_cast<int>(slice));
      if (n < 0 && errno != EINTR) {
        const int e = errno;
        close(pidfd);
        throw waitFailed(e);
      }
      if (n <= 0) continue;
      serveStreams(pfd[1].revents, pfd[2].revents, pfd[3].revents, &r);
      if (pfd[0].revents != 0) break;
    }
    close(pidfd);
    while (waitpid(pid_, &status, 0) < 0) {
      if (errno != EINTR) {
        reaped_ = true;  // it cannot be reaped: never kill a pid that may be reused
        throw waitFailed(errno);
      }
    }
  } else {
    auto pause = std::chrono::microseconds(50);
    for (;;) {
      const pid_t w = waitpid(pid_, &status, WNOHANG);
      if (w == pid_) break;
      if (w < 0 && errno != EINTR) {
        reaped_ = true;  // it cannot be reaped: never kill a pid that may be reused
        throw waitFailed(errno);
      }
      if (bounded && std::chrono::steady_clock::now() - start_ > limit)
        return stop(SubprocessResult::End::kTimedOut);
      if (cancelled()) return stop(SubprocessResult::End::kCancelled);
      serveStreams(POLLOUT, POLLIN, POLLIN, &r);  // non-blocking: EAGAIN when nothing is there
      std::this_thread::sleep_for(pause);
      if (pause < std::chrono::milliseconds(2)) pause *= 2;
    }
  }
  reaped_ = true;
  drainOutput(&r);
  return finish(status, std::move(r));
}

}  // namespace krr
