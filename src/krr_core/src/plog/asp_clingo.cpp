/**
 * @file asp_clingo.cpp
 * @brief Running the clingo binary as a subprocess and reading its answer sets.
 *
 * clingo is started through krr::Subprocess (common/subprocess.h: fork + exec, killed by the
 * kernel if its parent dies) on a program written to a private temporary directory (mkdtemp);
 * its stdout and stderr go to files in that directory, and the parent waits for its end on a
 * pidfd with the remaining time as poll timeout, killing it when the time limit is exceeded.
 * The directory is always removed (unless AspOptions::keep_files).
 * Answer sets are read from clingo's plain text output (-V0: one answer set per line, then
 * the result word), mapped into memory, split into atoms by a small term scanner that
 * respects parentheses and quoted strings, and every atom is interned: a model is a vector of
 * integers into the table of distinct atoms (millions of answer sets share a few thousand
 * atoms), handed to a callback as it is read or kept.
 */
#include "krr_core/plog/asp_backend.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
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

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/subprocess.h"

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

namespace {

/// @brief Runs clingo (`args`) with its stdout and stderr in files, within options.timeout_s
/// and until options.cancel: its wait status. Every failure is an Error naming `subject`.
int runClingoProcess(const std::vector<std::string>& args, const AspOptions& options,
                     const std::string& out_path, const std::string& err_path,
                     const std::string& subject) {
  // The child is killed by the kernel when this process dies (Subprocess::killWithParent),
  // so a plog or node killed mid-query (Ctrl-C, `timeout`, kill -9) leaves no clingo running
  // past its time limit.
  Subprocess clingo(args);
  clingo.setStdin(Subprocess::Stream::null())
      .setStdout(Subprocess::Stream::file(out_path))
      .setStderr(Subprocess::Stream::file(err_path));
  try {
    clingo.start();
  } catch (const SubprocessError& e) {
    const std::string why = std::strerror(e.errnum());
    if (e.step() == SubprocessError::Step::kPipe)
      throw Error("AspBackend: cannot create a pipe for clingo: " + why);
    if (e.step() == SubprocessError::Step::kFork)
      throw Error("AspBackend: cannot start clingo '" + options.clingo_path + "' on " + subject +
                  ": " + why);
    throw Error("AspBackend: cannot start clingo '" + options.clingo_path + "' on " + subject +
                ": " + why + " (install clingo >= 5.4 or set AspOptions.clingo_path)");
  }
  SubprocessResult end;
  try {
    end = clingo.wait(options.timeout_s, options.cancel);
  } catch (const SubprocessError& e) {
    throw Error("AspBackend: waiting for clingo on " + subject + " failed: " +
                std::strerror(e.errnum()));
  }
  if (end.end == SubprocessResult::End::kTimedOut)
    throw Error("AspBackend: clingo on " + subject + " exceeded the time limit of " +
                std::to_string(options.timeout_s) + " s and was killed");
  if (end.end == SubprocessResult::End::kCancelled)
    throw CancelledError("AspBackend: clingo abandoned: another back end answered first");
  return end.status;
}

/// @brief Refuses an output above options.max_output_bytes, a clingo killed by a signal and a
/// failed run (clingo's exit code), with clingo's message placed in the P-log program.
void checkClingoEnd(int status, const std::string& program, const AspOptions& options,
                    const std::string& lp, const std::string& out_path,
                    const std::string& err_path, const std::string& subject) {
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
}

/// @brief The answer sets of clingo's -V0 output (one per line, then the result word).
ClingoResult readAnswerSets(std::string_view out, const std::string& subject,
                            const AspModelCallback& on_model) {
  // Every atom is looked up in a table of the distinct atoms seen so far: a model becomes a
  // vector of integers without a string per atom.
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

}  // namespace

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
  const int status = runClingoProcess(args, options, out_path, err_path, subject);
  checkClingoEnd(status, program, options, lp, out_path, err_path, subject);
  // The output is mapped, not copied.
  const MappedFile mapped(out_path);
  return readAnswerSets(mapped.view(), subject, on_model);
}

std::vector<std::string> ClingoResult::atomTexts(const AspModel& model) const {
  std::vector<std::string> out;
  out.reserve(model.size());
  for (std::uint32_t id : model) out.push_back(atoms.at(id));
  return out;
}

}  // namespace plog
}  // namespace krr
