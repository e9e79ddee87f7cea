// Robustness: garbage, truncations and token shuffles never crash; only krr::Error is thrown.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/random.h"
#include "krr_core/common/resources.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr;
using namespace krr::plog;

namespace {

const char* kDice = R"(score = {1..6}.
dice = {d1, d2}.
person = {mike, john}.
roll : dice -> score.
owner : dice -> person.
even : dice -> boolean.
owner(d1) = mike.
owner(d2) = john.
even(D) :- roll(D) = Y, Y mod 2 == 0.
[r] random(roll(D)).
[r] pr(roll(D) = Y | owner(D) = john) = 1/6.
pr(roll(D) = 6 | owner(D) = mike) = 0.25.
obs(roll(d2) != 1).
?{even(d1)} | obs(roll(d1) != 1), do(roll(d2) = 4).
)";

// Parse (and, for small programs, answer the queries); true when a krr::Error was thrown.
// Any other exception type fails the test.
bool runOne(const std::string& text, bool answer) {
  try {
    Program p = parseProgram(text, "fuzz");
    if (answer) {
      Reasoner r;
      r.loadString(text, "fuzz");
      r.answerProgramQueries();
      r.exportProgram();
    }
    return false;
  } catch (const Error&) {
    return true;
  }
}

std::vector<std::string> tokensOf(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (std::isspace(static_cast<unsigned char>(c))) {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else if (std::isalnum(static_cast<unsigned char>(c)) || c == '_') {
      cur += c;
    } else {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
      out.push_back(std::string(1, c));
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

}  // namespace

TEST(PlogFuzz, RandomGarbage) {
  Rng rng = makeRng(20260601, "plog_fuzz_garbage");
  const std::string alphabet = "abcXYZ019_ (){}[],;.:-|=!<>+*/?#%\n\t\"'\\@~";
  Stopwatch sw;
  int errors = 0;
  for (int i = 0; i < 3000; ++i) {
    std::string s;
    size_t n = rng() % 80;
    for (size_t k = 0; k < n; ++k) {
      if (rng() % 10 == 0)
        s += static_cast<char>(rng() % 256);  // arbitrary bytes, including NUL and high bytes
      else
        s += alphabet[rng() % alphabet.size()];
    }
    errors += runOne(s, false);
  }
  EXPECT_GT(errors, 2500);  // almost all garbage is rejected
  EXPECT_LT(sw.seconds(), 2.0);
}

TEST(PlogFuzz, TruncationsOfValidPrograms) {
  std::string monty = readFile(std::string(KRR_TEST_DATA_DIR) + "/plog/monty_hall.plog");
  Stopwatch sw;
  for (const std::string& text : {monty, std::string(kDice)}) {
    for (size_t cut = 0; cut <= text.size(); ++cut) runOne(text.substr(0, cut), true);
  }
  // the untruncated programs are valid
  EXPECT_FALSE(runOne(monty, true));
  EXPECT_FALSE(runOne(kDice, true));
  EXPECT_LT(sw.seconds(), 5.0);
}

TEST(PlogFuzz, TokenShuffles) {
  Rng rng = makeRng(20260601, "plog_fuzz_shuffle");
  std::vector<std::string> toks = tokensOf(kDice);
  Stopwatch sw;
  for (int i = 0; i < 2000; ++i) {
    std::vector<std::string> t = toks;
    // a few random swaps, deletions and duplications
    int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      size_t a = rng() % t.size(), b = rng() % t.size();
      switch (rng() % 3) {
        case 0: std::swap(t[a], t[b]); break;
        case 1: t.erase(t.begin() + static_cast<long>(a)); break;
        default: t.insert(t.begin() + static_cast<long>(a), t[b]); break;
      }
      if (t.empty()) t.push_back(".");
    }
    std::string s;
    for (const auto& x : t) s += x + " ";
    runOne(s, i % 4 == 0);
  }
  EXPECT_LT(sw.seconds(), 5.0);
}

// ---------------------------------------------------------------------------------------------
// Hostile mutants (issue 12): seeded token mutations of the bundled programs, biased towards
// what broke before (extreme integers, division, ranges, recursion through arithmetic). The
// mutants run in forked children under RLIMIT_AS, so a signal, a hang or a memory blow-up fails
// this test (naming the mutant) instead of killing the test binary.
// ---------------------------------------------------------------------------------------------

namespace {

const char* kHostileTokens[] = {
    "9223372036854775807", "-9223372036854775807", "(0-9223372036854775807-1)", "0", "(0-1)",
    "-1", "mod", "/", "*", "+", "-", "..", "X + 1", "X * X", "(X - 1) / (0 - 1)", "{", "}",
    "X", "Y", "not", ":-", ".", ",", "random(", ")", "do(", "obs(", "{-5000000000000000000..5000000000000000000}",
    "{X : p(X)}", "p(X + 1) :- p(X).", "1..9223372036854775807", "3037000500 * 3037000500"};

// Programs of the bundle (test data) plus the dice program above.
std::vector<std::string> corpus() {
  std::vector<std::string> out{kDice};
  const std::string dir = std::string(KRR_TEST_DATA_DIR);
  for (const char* f : {"/plog/monty_hall.plog", "/plog/monty_hall_plog2.plog",
                        "/plog/asp/dice.plog", "/plog/asp/do_obs.plog",
                        "/plog/asp/dynamic_range.plog", "/plog/asp/light.plog",
                        "/plog/asp/even_loop.plog", "/kb/tiny_geometry.plog"}) {
    if (std::filesystem::exists(dir + f)) out.push_back(readFile(dir + f));
  }
  return out;
}

// Tokens as the P-log lexer sees them (multi-character operators and decimals kept whole,
// comments dropped), so that most single edits still parse and reach the engine.
std::vector<std::string> plogTokens(const std::string& s) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c == '%') {
      while (i < s.size() && s[i] != '\n') ++i;
    } else if (std::isspace(c)) {
      ++i;
    } else if (std::isalnum(c) || c == '_') {
      size_t j = i;
      while (j < s.size() && (std::isalnum(static_cast<unsigned char>(s[j])) || s[j] == '_')) ++j;
      if (std::isdigit(c) && j + 1 < s.size() && s[j] == '.' &&
          std::isdigit(static_cast<unsigned char>(s[j + 1]))) {
        ++j;
        while (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) ++j;
      }
      out.push_back(s.substr(i, j - i));
      i = j;
    } else {
      static const char* kTwo[] = {"..", ":-", "!=", "<>", "<=", ">=", "==", "->"};
      size_t n = 1;
      for (const char* t : kTwo)
        if (s.compare(i, 2, t) == 0) n = 2;
      out.push_back(s.substr(i, n));
      i += n;
    }
  }
  return out;
}

std::string mutate(const std::vector<std::string>& toks, Rng& rng) {
  std::vector<std::string> t = toks;
  const size_t nh = sizeof(kHostileTokens) / sizeof(kHostileTokens[0]);
  int edits = rng() % 2 ? 1 : 1 + static_cast<int>(rng() % 3);
  static const char* kInts[] = {"9223372036854775807", "(0-9223372036854775807-1)", "(0-1)",
                                "0", "(3037000500*3037000500)", "(7 mod 0)", "(1/0)", "20000"};
  static const char* kVarForms[] = {"%V + 1", "(%V - 1) / (0 - 1)", "%V * 9223372036854775807",
                                    "%V mod (0 - 1)", "-%V", "%V + 9223372036854775807"};
  for (int e = 0; e < edits && !t.empty(); ++e) {
    size_t a = rng() % t.size(), b = rng() % t.size();
    // most edits keep the program well formed, so that the grounder and engine see them
    if (rng() % 3 != 0) {
      std::vector<size_t> ints, vars;
      for (size_t k = 0; k < t.size(); ++k) {
        if (std::isdigit(static_cast<unsigned char>(t[k][0]))) ints.push_back(k);
        if (std::isupper(static_cast<unsigned char>(t[k][0]))) vars.push_back(k);
      }
      if (!vars.empty() && (ints.empty() || rng() % 2)) {
        size_t k = vars[rng() % vars.size()];
        std::string f = kVarForms[rng() % (sizeof(kVarForms) / sizeof(kVarForms[0]))];
        std::string out;
        for (char c : f) out += c == '%' ? t[k] : std::string(1, c);
        t[k] = "(" + out + ")";
        continue;
      }
      if (!ints.empty()) {
        t[ints[rng() % ints.size()]] = kInts[rng() % (sizeof(kInts) / sizeof(kInts[0]))];
        continue;
      }
    }
    switch (rng() % 5) {
      case 0: t[a] = kHostileTokens[rng() % nh]; break;
      case 1: t.insert(t.begin() + static_cast<long>(a), kHostileTokens[rng() % nh]); break;
      case 2: std::swap(t[a], t[b]); break;
      case 3: t.erase(t.begin() + static_cast<long>(a)); break;
      default: t.insert(t.begin() + static_cast<long>(a), t[b]); break;
    }
  }
  std::string s;
  for (const auto& x : t) s += x + (x == "." ? "\n" : " ");
  return s;
}

// State shared with the forked child (MAP_SHARED): which mutant it is running and since when.
struct Shared {
  volatile int current;
  volatile long long started_ns;
  volatile int failed;  // 1: an exception other than krr::Error escaped
  volatile int loaded;  // mutants that parsed and loaded (so that the engine was exercised)
  volatile int answered;  // queries answered without error
  char what[512];
};

long long nowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Parse, answer the program's queries, export and parse again, with small budgets.
void runMutant(const std::string& text, Shared* sh) {
  try {
    Reasoner r;
    GroundingLimits lim;
    lim.max_ground_atoms = 200000;
    lim.max_ground_statements = 200000;
    lim.max_ground_seconds = 1.0;
    lim.max_inference_seconds = 1.0;
    lim.memory_budget = 256u << 20;  // well inside the child's RLIMIT_AS: a budget error, never bad_alloc
    r.setLimits(lim);
    r.loadString(text, "mutant");
    sh->loaded = sh->loaded + 1;
    for (const auto& q : r.program().queries) {
      try {
        r.probability(q);
        sh->answered = sh->answered + 1;
      } catch (const Error&) {
      }
    }
    // distributions of a few random attributes without arguments (exercise the engine also
    // for programs without queries)
    int asked = 0;
    for (const auto& rr : r.program().random_rules) {
      if (!rr.attr.args.empty() || asked++ >= 3) continue;
      try {
        r.distribution(rr.attr.name);
        sh->answered = sh->answered + 1;
      } catch (const Error&) {
      }
    }
    parseProgram(r.exportProgram(), "export");
  } catch (const Error&) {
  }
}

}  // namespace

namespace {

/// @brief Run inputs[0..n) in forked children (batches of `batch`, RLIMIT_AS 2 GB). Returns ""
/// or why it failed, naming the input: a signal, a non-krr exception, or an input running longer
/// than `per_input_seconds` (the child is then killed).
std::string runForked(const std::vector<std::string>& inputs, int batch, double per_input_seconds,
                      int* loaded, int* answered) {
  void* mem = mmap(nullptr, sizeof(Shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS,
                   -1, 0);
  if (mem == MAP_FAILED) return "mmap failed";
  Shared* sh = static_cast<Shared*>(mem);
  std::string failure;
  const int n = static_cast<int>(inputs.size());
  for (int start = 0; start < n && failure.empty(); start += batch) {
    const int end = std::min(n, start + batch);
    std::memset(sh, 0, sizeof(Shared));
    sh->current = -1;
    pid_t pid = fork();
    if (pid < 0) {
      failure = "fork failed";
      break;
    }
    if (pid == 0) {
      struct rlimit rl;
      rl.rlim_cur = rl.rlim_max = 2ull << 30;  // 2 GB of address space
      setrlimit(RLIMIT_AS, &rl);
      for (int i = start; i < end; ++i) {
        sh->started_ns = nowNs();  // before `current`: the parent reads them in this order
        __sync_synchronize();
        sh->current = i;
        try {
          runMutant(inputs[static_cast<size_t>(i)], sh);
        } catch (const std::exception& e) {  // bad_alloc, logic_error...: not a typed error
          std::strncpy(sh->what, e.what(), sizeof(sh->what) - 1);
          sh->failed = 1;
          _exit(3);
        }
      }
      _exit(0);
    }
    int status = 0;
    for (;;) {
      pid_t w = waitpid(pid, &status, WNOHANG);
      if (w == pid) break;
      const int cur = sh->current;
      __sync_synchronize();
      const long long started = sh->started_ns;
      if (cur >= 0 && started > 0 && (nowNs() - started) * 1e-9 > per_input_seconds) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
        munmap(mem, sizeof(Shared));
        return "input " + std::to_string(cur) + " ran longer than " +
               std::to_string(per_input_seconds) + " s:\n" + inputs[static_cast<size_t>(cur)];
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    const int cur = sh->current;
    const std::string text = cur >= 0 ? inputs[static_cast<size_t>(cur)] : std::string();
    if (WIFSIGNALED(status))
      failure = "input " + std::to_string(cur) + " killed the child with signal " +
                std::to_string(WTERMSIG(status)) + ":\n" + text;
    else if (WEXITSTATUS(status) != 0)
      failure = "input " + std::to_string(cur) + " threw a non-krr exception (" +
                std::string(sh->what) + "):\n" + text;
    *loaded += sh->loaded;
    *answered += sh->answered;
  }
  munmap(mem, sizeof(Shared));
  return failure;
}

}  // namespace

TEST(PlogFuzz, HostileMutantsInForkedChildren) {
  const int kMutants = 3000;
  Rng rng = makeRng(20261202, "plog_fuzz_hostile");
  std::vector<std::vector<std::string>> toks;
  for (const auto& p : corpus()) toks.push_back(plogTokens(p));
  std::vector<std::string> mutants;
  for (int i = 0; i < kMutants; ++i) mutants.push_back(mutate(toks[rng() % toks.size()], rng));
  Stopwatch sw;
  int loaded = 0, answered = 0;
  const std::string failure = runForked(mutants, 250, 5.0, &loaded, &answered);
  EXPECT_TRUE(failure.empty()) << failure;
  std::cout << "[ hostile fuzz ] " << kMutants << " mutants in " << sw.seconds() << " s, "
            << loaded << " loaded, " << answered << " queries answered\n";
  EXPECT_GT(loaded, kMutants / 5);  // the mutants reach the grounder and the engine
  EXPECT_LT(sw.seconds(), 30.0);
}

// Minimised inputs that crashed or hung before (test/data/plog/regress), run as they are.
TEST(PlogFuzz, RegressionInputs) {
  const std::string dir = std::string(KRR_TEST_DATA_DIR) + "/plog/regress";
  std::vector<std::string> inputs;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".plog") inputs.push_back(readFile(e.path().string()));
  ASSERT_GE(inputs.size(), 4u);
  int loaded = 0, answered = 0;
  const std::string failure = runForked(inputs, 1, 10.0, &loaded, &answered);
  EXPECT_TRUE(failure.empty()) << failure;
}

// Issue 24: inputs that grow without bound (a large random relation, many facts, wide record
// sorts, huge ranges, long sums) under RLIMIT_AS: each ends in an answer or a krr::Error (the
// memory budget), never std::bad_alloc (which fails the test as a non-krr exception).
TEST(PlogFuzz, SizeHostileInputsUnderAddressSpaceLimit) {
  std::vector<std::string> inputs;
  inputs.push_back("n = {1..2300}.\np : n, n -> boolean.\n[r] random(p(X,Y)).\n?{p(1,1)=true}.\n");
  // the same relation with a query whose relevance cone is all of it
  inputs.push_back("n = {1..2300}.\np : n, n -> boolean.\n[r] random(p(X,Y)).\nany : boolean.\n"
                   "any :- p(X, Y) = true.\n?{any}.\n");
  std::string f;
  for (int i = 0; i < 400000; ++i) f += "q" + std::to_string(i) + ".\n";
  inputs.push_back(f + "?{q1}.\n");
  inputs.push_back("a = {1..1000}.\nr = f(a, a).\nt = g(r, a).\nx : t.\n[r] random(x).\n?{x = g(f(1,1),1)}.\n");
  inputs.push_back("n = {1..1000000}.\nm = {1..1000000}.\np : n, m -> boolean.\np(X, Y) :- X = Y.\n?{p(1,1)}.\n");
  std::string sum = "s = {0..30000}.\na : s.\n[r] random(a).\n?{a = 1";
  for (int i = 0; i < 200000; ++i) sum += "+1";
  inputs.push_back(sum + "}.\n");
  int loaded = 0, answered = 0;
  const std::string failure = runForked(inputs, 1, 120.0, &loaded, &answered);
  EXPECT_TRUE(failure.empty()) << failure.substr(0, 400);
}
