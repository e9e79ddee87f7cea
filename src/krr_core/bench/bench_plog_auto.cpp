/**
 * @file bench_plog_auto.cpp
 * @brief Issue 24: Backend::Auto against the faster back end on two scaled families, load +
 * one query, wall seconds (clingo runs as a child process):
 *  - one attribute over n values, `?{a = 5}`, n = 10^2 .. 10^6;
 *  - a conjunction over k independent boolean attributes, `?{a1 = true, ..., ak = true}`,
 *    k = 10 .. 30.
 * Prints native / asp / auto seconds (median of --repeat runs), auto's choice and the ratio
 * auto / fastest. clingo is not run where its own estimate (aspCostSeconds) is over
 * --asp-limit seconds (default 2; one attribute over 10^4 values took clingo 60 s and 2.9 GB):
 * the row says so and the ratio is to the native time.
 *
 * Usage: bench_plog_auto [--repeat N] [--asp-limit S]
 */
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/plog/asp_backend.h"
#include "krr_core/plog/parser.h"
#include "krr_core/plog/reasoner.h"

using namespace krr::plog;

namespace {

struct Case {
  std::string family;
  int size;
  std::string program;
  std::string query;
  double expected;
};

Case oneAttribute(int n) {
  return {"one attribute, n values", n,
          "s = {1.." + std::to_string(n) + "}.\na : s.\n[r] random(a).\n", "?{a = 5}", 1.0 / n};
}

Case conjunction(int k) {
  Case c{"conjunction of k attributes", k, "", "?{", std::exp2(-k)};
  for (int i = 1; i <= k; ++i) {
    c.program += "a" + std::to_string(i) + " : boolean.\n[r" + std::to_string(i) + "] random(a" +
                 std::to_string(i) + ").\n";
    c.query += (i > 1 ? ", a" : "a") + std::to_string(i) + " = true";
  }
  c.query += "}";
  return c;
}

struct Run {
  double seconds = 0;
  AutoChoice choice = AutoChoice::Native;
  Backend answered = Backend::Native;
};

Run runOnce(const Case& c, Backend b) {
  const auto t0 = std::chrono::steady_clock::now();
  Reasoner r;
  r.setBackend(b);
  AspOptions o;
  o.timeout_s = 120;
  r.setAspOptions(o);
  r.loadString(c.program, "bench.plog");
  const double p = r.probability(c.query);
  Run run;
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.choice = r.stats().last_auto_choice;
  run.answered = r.stats().last_backend;
  if (std::fabs(p - c.expected) > 1e-9 * std::max(1.0, c.expected))
    std::fprintf(stderr, "%s %d %s: answer %.17g, expected %.17g\n", c.family.c_str(), c.size,
                 backendName(b), p, c.expected);
  return run;
}

Run median(const Case& c, Backend b, int repeat) {
  std::vector<Run> runs;
  for (int k = 0; k < repeat; ++k) runs.push_back(runOnce(c, b));
  std::sort(runs.begin(), runs.end(), [](const Run& x, const Run& y) { return x.seconds < y.seconds; });
  return runs[runs.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  double asp_limit = 2.0;
  krr::OptionParser cli("bench_plog_auto",
                        "Backend::Auto against the faster back end on two scaled families (one\n"
                        "attribute over 10^2..10^6 values, conjunctions over 10..30 attributes).");
  cli.add("--repeat", "N", "runs per case (the median is printed; at least 1)", &repeat);
  cli.add("--asp-limit", "S", "clingo is not run where its own cost estimate is above S seconds",
          &asp_limit);
  if (const auto status = cli.parse(argc, argv)) return *status;
  repeat = std::max(1, repeat);
  std::vector<Case> cases;
  for (int n : {100, 1000, 10000, 100000, 1000000}) cases.push_back(oneAttribute(n));
  for (int k : {10, 15, 20, 25, 30}) cases.push_back(conjunction(k));
  std::printf("| family | size | native s | asp s | auto s | auto's choice (answered by) | "
              "auto / fastest |\n| --- | ---: | ---: | ---: | ---: | --- | ---: |\n");
  double worst = 0;
  for (const Case& c : cases) {
    const Run native = median(c, Backend::Native, repeat);
    const double asp_estimate = aspCostSeconds(parseProgram(c.program, "bench.plog"));
    char asp_text[96];
    double fastest = native.seconds;
    if (asp_estimate <= asp_limit) {
      const Run asp = median(c, Backend::Asp, repeat);
      std::snprintf(asp_text, sizeof asp_text, "%.4f", asp.seconds);
      fastest = std::min(fastest, asp.seconds);
    } else {
      std::snprintf(asp_text, sizeof asp_text, "not run (estimate %.3g s)", asp_estimate);
    }
    const Run automatic = median(c, Backend::Auto, repeat);
    const double ratio = automatic.seconds / fastest;
    worst = std::max(worst, ratio);
    std::printf("| %s | %d | %.4f | %s | %.4f | %s (%s) | %.2f |\n", c.family.c_str(), c.size,
                native.seconds, asp_text, automatic.seconds, autoChoiceName(automatic.choice),
                backendName(automatic.answered), ratio);
    std::fflush(stdout);
  }
  std::printf("\nworst auto / fastest: %.2f (target <= 2: %s)\n", worst, worst <= 2 ? "met" : "NOT met");
  return 0;
}
