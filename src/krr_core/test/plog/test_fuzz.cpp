// Robustness: garbage, truncations and token shuffles never crash; only krr::Error is thrown.
#include <gtest/gtest.h>

#include <string>
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
