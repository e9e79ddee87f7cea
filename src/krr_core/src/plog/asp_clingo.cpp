/**
 * @file asp_clingo.cpp
 * @brief Running the clingo binary as a subprocess and reading its answer sets.
 *
 * clingo is started (fork + exec, and killed by the kernel if its parent dies) on a program
 * written to a private temporary directory (mkdtemp), its stdout and stderr go to files in that directory, and the parent waits for its
 * end on a pidfd with the remaining time as poll timeout, killing it when the time limit is
 * exceeded. The directory is always removed (unless AspOptions::keep_files).
 * Answer sets are read from clingo's plain text output (-V0: one answer set per line, then
 * the result word), mapped into memory, split into atoms by a small term scanner that
 * respects parentheses and quoted strings, and every atom is interned: a model is a vector of
 * integers into the table of distinct atoms (millions of answer sets share a few thousand
 * atoms), handed to a callback as it is read or kept.
 */
#include "krr_core/plog/asp_backend.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <deque>
#include <string_view>
#include <unordered_map>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"

extern char** environ;

namespace krr {
namespace plog {

namespace {

/// Removes a directory tree when it goes out of scope, whatever happens in between.
class TempDir {
 public:
  TempDir() {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base != nullptr && *base != '\0' ? base : "/tmp") +
                          "/krr_asp_XXXXXX";
    std::vector<char> buf(pattern.begin(), pattern.end());
    buf.push_back('\0');
    if (mkdtemp(buf.data()) == nullptr) {
      throw IoError("AspBackend: cannot create a temporary directory from '" + pattern +
                    "': " + std::strerror(errno));
    }
    path_ = buf.data();
  }
  ~TempDir() {
    if (keep_) return;
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  void keep() { keep_ = true; }

 private:
  std::string path_;
  bool keep_ = false;
};

std::string readWhole(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string trimmed(const std::string& s, std::size_t max_len = 4000) {
  std::size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  std::size_t e = s.find_last_not_of(" \t\r\n");
  std::string out = s.substr(b, e - b + 1);
  if (out.size() > max_len) out = out.substr(0, max_len) + " [...]";
  return out;
}

/// A file mapped read-only into memory (an empty or unreadable file is an empty view).
class MappedFile {
 public:
  explicit MappedFile(const std::string& path) {
    const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return;
    struct stat st;
    if (fstat(fd, &st) == 0 && st.st_size > 0) {
      void* p = mmap(nullptr, static_cast<std::size_t>(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
      if (p != MAP_FAILED) {
        data_ = static_cast<const char*>(p);
        size_ = static_cast<std::size_t>(st.st_size);
        madvise(p, size_, MADV_SEQUENTIAL);
      }
    }
    close(fd);
  }
  ~MappedFile() {
    if (data_ != nullptr) munmap(const_cast<char*>(data_), size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  std::string_view view() const { return {data_ == nullptr ? "" : data_, size_}; }

 private:
  const char* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace

/// @brief Calls piece(begin, end) for each non-empty piece of `text` between top-level
/// separators (not inside parentheses or strings); a ' ' separator also cuts at tabs and CRs.
/// One scanner for splitAspTerms and the answer-set lines, which are cut by index (they hold
/// millions of atoms on large programs) rather than copied character by character.
template <typename Piece>
void forEachAspTerm(std::string_view text, char separator, Piece&& piece) {
  std::size_t begin = 0;  // start of the current piece
  int depth = 0;
  bool in_string = false;
  auto flush = [&](std::size_t end) {
    if (end > begin) piece(begin, end);
    begin = end + 1;
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\' && i + 1 < text.size()) {
        ++i;
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '(') {
      ++depth;
    } else if (c == ')') {
      --depth;
    } else if (depth == 0 && (c == separator || (separator == ' ' && (c == '\t' || c == '\r')))) {
      flush(i);
    }
  }
  flush(text.size());
}

std::vector<std::string> splitAspTerms(const std::string& text, char separator) {
  std::vector<std::string> out;
  out.reserve(separator == ' ' ? 64 : 4);
  forEachAspTerm(text, separator, [&](std::size_t begin, std::size_t end) {
    out.emplace_back(text, begin, end - begin);
  });
  return out;
}

AspAtom parseAspAtom(const std::string& text) {
  AspAtom atom;
  std::size_t open = text.find('(');
  if (open == std::string::npos || text.empty() || text.back() != ')' || text[0] == '"') {
    atom.name = text;
    return atom;
  }
  atom.name = text.substr(0, open);
  atom.args = splitAspTerms(text.substr(open + 1, text.size() - open - 2), ',');
  return atom;
}

std::string pLogLocations(const std::string& message, const std::string& lp_path,
                          const std::string& asp_program) {
  // The P-log statement of every line of the translation: the last marker above it.
  std::vector<std::string> source{""};
  {
    std::istringstream lines(asp_program);
    std::string line, current = "<translation>";
    const std::string marker = kAspSourceMarker;
    while (std::getline(lines, line)) {
      if (line.compare(0, marker.size(), marker) == 0) current = line.substr(marker.size());
      source.push_back(current);
    }
  }
  std::string out;
  const std::string prefix = lp_path + ":";
  std::size_t pos = 0;
  for (;;) {
    const std::size_t at = message.find(prefix, pos);
    if (at == std::string::npos) {
      out += message.substr(pos);
      return out;
    }
    out += message.substr(pos, at - pos);
    // lp:LINE:COL[-COL|-LINE:COL]: -> the P-log location and the ASP line
    std::size_t k = at + prefix.size();
    std::size_t line = 0;
    const std::size_t digits = k;
    while (k < message.size() && std::isdigit(static_cast<unsigned char>(message[k])) &&
           line < 100000000)
      line = line * 10 + static_cast<std::size_t>(message[k++] - '0');
    if (k == digits) {
      out += "the ASP translation:";
      pos = at + prefix.size();
      continue;
    }
    while (k < message.size() && (std::isdigit(static_cast<unsigned char>(message[k])) ||
                                  message[k] == ':' || message[k] == '-') &&
           !(message[k] == ':' && k + 1 < message.size() && message[k + 1] == ' '))
      ++k;
    const std::string statement = line < source.size() ? source[line] : "<translation>";
    out += statement + ": (line " + std::to_string(line) + " of its ASP translation)";
    pos = k;
  }
}

ClingoResult runClingo(const std::string& program, const AspOptions& options,
                       const std::vector<std::string>& extra_args,
                       const AspModelCallback& on_model) {
  if (!(options.timeout_s > 0.0) || !std::isfinite(options.timeout_s)) {
    throw ConfigError("AspOptions.timeout_s must be a positive number of seconds, got " +
                      std::to_string(options.timeout_s));
  }
  TempDir dir;
  if (options.keep_files) dir.keep();
  const std::string lp = dir.path() + "/program.lp";
  const std::string out_path = dir.path() + "/stdout.txt";
  const std::string err_path = dir.path() + "/stderr.txt";
  // Messages name the P-log program, not a temporary file that is gone after the call.
  const std::string subject = options.keep_files
                                  ? "the ASP translation (kept in " + lp + ")"
                                  : "the ASP translation of the program";
  {
    std::ofstream f(lp, std::ios::binary);
    f << program;
    if (!f) throw IoError("AspBackend: cannot write the ASP program to '" + lp + "'");
  }

  std::vector<std::string> args = {options.clingo_path, "--models=0", "-V0", "--warn=none"};
  for (const auto& a : options.extra_args) args.push_back(a);
  for (const auto& a : extra_args) args.push_back(a);
  args.push_back(lp);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);

  // fork + exec rather than posix_spawn: the child asks the kernel to kill it when this
  // process dies (PR_SET_PDEATHSIG), so a plog or node killed mid-query (Ctrl-C, `timeout`,
  // kill -9) leaves no clingo running past its time limit. A close-on-exec pipe carries the
  // errno of a failed exec back.
  int errpipe[2];
  if (pipe2(errpipe, O_CLOEXEC) != 0)
    throw Error(std::string("AspBackend: cannot create a pipe for clingo: ") + std::strerror(errno));
  const pid_t parent = getpid();
  pid_t pid = fork();
  if (pid < 0) {
    const int e = errno;
    close(errpipe[0]);
    close(errpipe[1]);
    throw Error("AspBackend: cannot start clingo '" + options.clingo_path + "' on " + subject +
                ": " + std::strerror(e));
  }
  if (pid == 0) {
    // Child: async-signal-safe calls only until exec.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);  // the parent died before prctl took effect
    int e = 0;
    const int in = open("/dev/null", O_RDONLY);
    const int out = open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    const int err = open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (in < 0 || out < 0 || err < 0 || dup2(in, STDIN_FILENO) < 0 ||
        dup2(out, STDOUT_FILENO) < 0 || dup2(err, STDERR_FILENO) < 0) {
      e = errno;
    } else {
      execvp(argv[0], argv.data());
      e = errno;
    }
    ssize_t ignored = write(errpipe[1], &e, sizeof(e));
    (void)ignored;
    _exit(127);
  }
  close(errpipe[1]);
  int child_errno = 0;
  ssize_t got;
  while ((got = read(errpipe[0], &child_errno, sizeof(child_errno))) < 0 && errno == EINTR) {
  }
  close(errpipe[0]);
  if (got > 0) {
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
    throw Error("AspBackend: cannot start clingo '" + options.clingo_path + "' on " + subject +
                ": " + std::strerror(child_errno) +
                " (install clingo >= 5.4 or set AspOptions.clingo_path)");
  }

  const auto start = std::chrono::steady_clock::now();
  const auto limit = std::chrono::duration<double>(options.timeout_s);
  auto timedOut = [&]() {
    kill(pid, SIGKILL);
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
    throw Error("AspBackend: clingo on " + subject + " exceeded the time limit of " +
                std::to_string(options.timeout_s) + " s and was killed");
  };
  auto cancelled = [&]() { return options.cancel && options.cancel->load(); };
  auto abandon = [&]() {
    kill(pid, SIGKILL);
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
    throw CancelledError("AspBackend: clingo abandoned: another back end answered first");
  };
  int status = 0;
  // Wait for the end of clingo without polling latency: a pidfd becomes readable when the
  // process exits. Where pidfds are unavailable, fall back to polling waitpid.
  // (Direct system call: glibc 2.36's <sys/pidfd.h> lacks C linkage for C++.)
#ifdef SYS_pidfd_open
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, pid, 0));
#else
  const int pidfd = -1;
#endif
  if (pidfd >= 0) {
    for (;;) {
      const auto left = limit - (std::chrono::steady_clock::now() - start);
      const long ms = static_cast<long>(
          std::ceil(std::chrono::duration<double, std::milli>(left).count()));
      if (ms <= 0) {
        close(pidfd);
        timedOut();
      }
      if (cancelled()) {
        close(pidfd);
        abandon();
      }
      struct pollfd pfd = {pidfd, POLLIN, 0};
      // With a cancel flag, look at it every 10 ms.
      const long slice = options.cancel ? std::min<long>(ms, 10L) : std::min<long>(ms, 1000000L);
      const int r = poll(&pfd, 1, static_cast<int>(slice));
      if (r > 0) break;
      if (r < 0 && errno != EINTR) {
        close(pidfd);
        throw Error("AspBackend: waiting for clingo on " + subject + " failed: " +
                    std::strerror(errno));
      }
    }
    close(pidfd);
    while (waitpid(pid, &status, 0) < 0) {
      if (errno != EINTR) {
        throw Error("AspBackend: waiting for clingo on " + subject + " failed: " +
                    std::strerror(errno));
      }
    }
  } else {
    auto pause = std::chrono::microseconds(50);
    for (;;) {
      pid_t w = waitpid(pid, &status, WNOHANG);
      if (w == pid) break;
      if (w < 0 && errno != EINTR) {
        throw Error("AspBackend: waiting for clingo on " + subject + " failed: " +
                    std::strerror(errno));
      }
      if (std::chrono::steady_clock::now() - start > limit) timedOut();
      if (cancelled()) abandon();
      std::this_thread::sleep_for(pause);
      if (pause < std::chrono::milliseconds(2)) pause *= 2;
    }
  }

  std::error_code size_error;
  const auto out_size = std::filesystem::file_size(out_path, size_error);
  if (!size_error && out_size > options.max_output_bytes) {
    throw Error("AspBackend: clingo's output on " + subject + " has " + std::to_string(out_size) +
                " bytes, more than AspOptions.max_output_bytes = " +
                std::to_string(options.max_output_bytes) +
                " (too many possible worlds to enumerate; use the native engine)");
  }
  const std::string err = readWhole(err_path);
  if (WIFSIGNALED(status)) {
    throw Error("AspBackend: clingo on " + subject + " was killed by signal " +
                std::to_string(WTERMSIG(status)) + ": " + trimmed(err));
  }
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  // clingo's exit code is a bit set: 1 interrupted, 10 satisfiable, 20 search space exhausted,
  // 33 out of memory, 65 error, 128 no run; 127 is a child that could not run clingo.
  if (code == 127 || code >= 33 || (code & 1) != 0 || (code & 20) != 20) {
    std::string why = pLogLocations(trimmed(err), lp, program);
    if (why.empty()) why = trimmed(readWhole(out_path));
    if (why.find("unsafe variables") != std::string::npos)
      why = "a variable of the statement is bound by no sorted argument or positive literal, "
            "so clingo cannot ground it (declare the sorts of the attribute's arguments); "
            "clingo says: " + why;
    throw Error("AspBackend: clingo '" + options.clingo_path + "' rejected " + subject +
                " (exit code " + std::to_string(code) + "): " +
                (why.empty() ? std::string("no message") : why));
  }

  // The output is mapped, not copied, and every atom is looked up in a table of the distinct
  // atoms seen so far: a model becomes a vector of integers without a string per atom.
  const MappedFile mapped(out_path);
  const std::string_view out = mapped.view();
  ClingoResult result;
  std::deque<std::string> storage;  // stable addresses for the views in index
  std::unordered_map<std::string_view, std::uint32_t> index;
  AspModel model;
  auto intern = [&](std::string_view atom) {
    auto it = index.find(atom);
    if (it != index.end()) return it->second;
    storage.emplace_back(atom);
    const auto id = static_cast<std::uint32_t>(result.atoms.size());
    result.atoms.push_back(storage.back());
    index.emplace(std::string_view(storage.back()), id);
    return id;
  };
  bool status_seen = false;
  std::size_t pos = 0;
  while (pos < out.size()) {
    std::size_t eol = out.find('\n', pos);
    if (eol == std::string_view::npos) eol = out.size();
    std::string_view line = out.substr(pos, eol - pos);
    pos = eol + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line == "SATISFIABLE" || line == "UNSATISFIABLE" || line == "OPTIMUM FOUND") {
      result.satisfiable = (line != "UNSATISFIABLE");
      status_seen = true;
      break;
    }
    if (line == "UNKNOWN") {
      throw Error("AspBackend: clingo did not finish the search on " + subject);
    }
    static const std::string_view kOpt = "Optimization:";
    if (line.substr(0, kOpt.size()) == kOpt) {
      if (result.model_count == 0) {
        throw Error("AspBackend: optimisation value before any answer set in clingo's output on " +
                    subject);
      }
      std::istringstream values(std::string(line.substr(kOpt.size())));
      std::vector<long long> cost;
      long long v = 0;
      while (values >> v) cost.push_back(v);
      result.costs.resize(result.model_count);
      result.costs.back() = cost;
      continue;
    }
    model.clear();
    forEachAspTerm(line, ' ', [&](std::size_t begin, std::size_t end) {
      model.push_back(intern(line.substr(begin, end - begin)));
    });
    ++result.model_count;
    if (on_model) {
      on_model(result.atoms, model);
    } else {
      result.models.push_back(model);
    }
  }
  if (!status_seen) {
    throw Error("AspBackend: unexpected clingo output on " + subject + " (no result line): " +
                trimmed(std::string(out.substr(0, 8000))));
  }
  // No model lines precede an UNSATISFIABLE; with a multi-shot script the result line is that
  // of the last solve only, and earlier solves' answer sets are kept.
  return result;
}

std::vector<std::string> ClingoResult::atomTexts(const AspModel& model) const {
  std::vector<std::string> out;
  out.reserve(model.size());
  for (std::uint32_t id : model) out.push_back(atoms.at(id));
  return out;
}

}  // namespace plog
}  // namespace krr
