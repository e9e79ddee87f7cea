// Benchmark: the point-based solver on the standard POMDP problems of issue 15 at fixed budgets.
//
// Usage: bench_pomdp_suite [--dir DIR] [--budgets 1,10] [--problems tiger,rocksample_4_4,...]
//                          [--dialog-turns 10]   (--help: the options)
// Problems: tiger (built in), rocksample_4_4, rocksample_5_5, rocksample_5_7, tag, rocksample_7_8 (from
// DIR/<name>.pomdp; generate them with tools/pomdp_bench/gen_pomdp.py, see --help), dialog (a
// 30-request dialog POMDP with the turn counter in the state, pomdp::withTurnCounter; not the
// knowledge-base models of bench_dialog_pomdp, which need the experiment data).
// Each run is a child process (this program with --in-process), so that its peak memory is
// its own; the budget covers
// reading, set-up and search, as pomdp_solve's --timeout does. Per problem and budget it prints
// lower and upper bound at b0, gap, wall time, peak RSS and how the run ended.
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/files.h"
#include "krr_core/common/format.h"
#include "krr_core/common/subprocess.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_core/examples/tiger.h"
#include "krr_core/pomdp/turn_counter_model.h"

using namespace krr;
using namespace krr::pomdp;
using krr::dialog::DialogPomdp, krr::dialog::DialogSpec, krr::dialog::deliveryMatrix;
using krr::dialog::ownOfficePrior;
using krr::examples::makeTiger;

namespace {

/// @brief One run's figures (runOne), printed as a row (printRow).
struct RunResult {
  int ok = 0;  ///< 1: solved; 0: error (message in `error`)
  std::size_t states = 0, actions = 0, observations = 0, alphas = 0;
  double lower = 0.0, upper = 0.0, seconds = 0.0, readSeconds = 0.0, setupSeconds = 0.0;
  double peakMiB = 0.0;
  int converged = 0, setupCut = 0;
  std::string error;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string x;
  while (std::getline(ss, x, ','))
    if (!x.empty()) out.push_back(x);
  return out;
}

/// @brief Load (or build) and solve one problem within `budget` seconds, in this process.
RunResult runOne(const std::string& name, const std::string& dir, double budget, int turns) {
  RunResult r;
  const Stopwatch wall;
  try {
    Model model = makeTiger();
    if (name == "dialog") {
      // The default request space (3 items x 5 rooms x 2 persons) with uneven delivery success
      // and an own-office prior, so that asking pays (with every serve succeeding, the value is
      // trivially 80).
      DialogSpec spec = krr::dialog::placeholderNames(DialogSpec(), 3, 5, 2);
      spec.prior = ownOfficePrior(3, 5, {0, 3}, 0.8);
      Eigen::VectorXd reach(5);
      reach << 0.95, 0.6, 0.8, 0.9, 0.7;
      spec.delivery = deliveryMatrix(3, reach, 2);
      DialogPomdp d(spec);
      model = withTurnCounter(d.model(), d.model().initialBelief(), turns);
    } else if (name != "tiger") {
      CassandraLimits limits;
      limits.timeout = budget;
      model = loadCassandra(dir + "/" + name + ".pomdp", limits);
    }
    r.readSeconds = wall.seconds();
    SolverOptions opt;
    opt.timeout = budget;
    const double reserve = std::min(0.05 * budget, 0.5);
    opt.setupTimeLimit = std::max(1e-6, 0.5 * (budget - reserve - r.readSeconds));
    PointBasedSolver solver(model, model.initialBelief(), opt);
    r.setupSeconds = solver.setupReport().seconds();
    solver.runUntil(solver.report().time + std::max(0.0, budget - reserve - wall.seconds()));
    const BoundsReport rep = solver.report();
    if (!rep.valid()) throw IncoherentError("bounds at b0 are not finite, ordered numbers");
    r.ok = 1;
    r.states = model.getS();
    r.actions = model.getA();
    r.observations = model.getO();
    r.alphas = rep.alphas;
    r.lower = rep.lower;
    r.upper = rep.upper;
    r.converged = solver.converged() ? 1 : 0;
    r.setupCut = solver.setupReport().timedOut ? 1 : 0;
  } catch (const std::exception& e) {
    r.error = e.what();
  }
  r.seconds = wall.seconds();
  r.peakMiB = peakRssMiB();
  return r;
}

void printHeader() {
  std::printf("%-15s %6s %4s %4s %7s %11s %11s %9s %8s %8s %8s %7s  %s\n", "problem", "S", "A",
              "O", "budget", "lower", "upper", "gap", "time_s", "setup_s", "peak_MiB", "alphas",
              "end");
}

void printRow(const std::string& p, double budget, const RunResult& r) {
  if (!r.ok) {
    std::printf("%-15s %6s %4s %4s %7.1f  error: %s\n", p.c_str(), "-", "-", "-", budget,
                r.error.c_str());
  } else {
    std::printf("%-15s %6zu %4zu %4zu %7.1f %11.4f %11.4f %9.4f %8.3f %8.3f %8.1f %7zu  %s%s%s\n",
                p.c_str(), r.states, r.actions, r.observations, budget, r.lower, r.upper,
                r.upper - r.lower, r.seconds, r.setupSeconds, r.peakMiB, r.alphas,
                r.converged ? "converged" : "timeout", r.setupCut ? ", set-up cut" : "",
                r.seconds > 1.1 * budget ? ", OVER BUDGET" : "");
  }
  std::fflush(stdout);
}

/// @brief One problem at one budget in a child process (this program with --in-process), so
/// that its peak RSS is its own; it prints its own row. A child that dies or outlives its
/// budget by a minute gets an error row.
void runChild(const std::string& name, const std::string& dir, double budget, int turns) {
  std::fflush(stdout);
  Subprocess child({"/proc/self/exe", "--in-process", "--no-header", "--dir", dir, "--budgets",
                    formatNumber(budget, 17), "--problems", name, "--dialog-turns",
                    std::to_string(turns)});
  child.setStdout(Subprocess::Stream::inherit()).setStderr(Subprocess::Stream::inherit());
  child.start();
  const SubprocessResult r = child.wait(2.0 * budget + 60.0);
  if (r.end == SubprocessResult::End::kExited && r.exit_code == 0) return;
  RunResult failed;
  failed.error = r.end == SubprocessResult::End::kTimedOut
                     ? "the child outlived its budget by a minute: killed"
                 : r.end == SubprocessResult::End::kSignalled
                     ? "the child died of signal " + std::to_string(r.signal)
                     : "the child exited with " + std::to_string(r.exit_code);
  printRow(name, budget, failed);
}

/// @brief The benchmark; main() runs it under guardedMain so that no exception aborts it.
int mainBody(int argc, char** argv) {
  std::string dir = "/tmp/pomdp_bench";
  std::vector<double> budgets{1, 10};
  std::vector<std::string> problems{"tiger", "rocksample_4_4", "rocksample_5_5", "rocksample_5_7",
                                    "tag", "rocksample_7_8", "dialog"};
  int turns = 10;
  OptionParser cli("bench_pomdp_suite",
                   "The point-based solver on the standard POMDP problems at fixed budgets, each\n"
                   "run in a child process; per problem and budget: bounds at b0, gap, wall\n"
                   "time, peak RSS and how the run ended.");
  cli.add("--dir", "DIR", "where the problems' .pomdp files are", &dir);
  cli.add("--budgets", "S,S...", "budgets in seconds (reading, set-up and search)",
          [&](const std::string& v) { budgets = parseNumberListOption("--budgets", v); }, "1,10");
  cli.add("--problems", "A,B...", "problems to run",
          [&](const std::string& v) { problems = split(v); },
          "tiger,rocksample_4_4,rocksample_5_5,rocksample_5_7,tag,rocksample_7_8,dialog");
  cli.add("--dialog-turns", "N", "turn limit of the dialog problem", &turns);
  bool inProcess = false, noHeader = false;
  cli.flag("--in-process", "run in this process (what each child does; the peak RSS is then "
           "the largest run's so far)", &inProcess);
  cli.flag("--no-header", "print no header line", &noHeader);
  cli.epilog(
      "Generate DIR's files first, e.g. for DIR=/tmp/pomdp_bench:\n"
      "  tools/pomdp_bench/gen_pomdp.py rocksample 4 4 -o /tmp/pomdp_bench/rocksample_4_4.pomdp\n"
      "  (likewise 5 5, 5 7, 7 8) and tools/pomdp_bench/gen_pomdp.py tag -o "
      "/tmp/pomdp_bench/tag.pomdp\n");
  if (const auto status = cli.parse(argc, argv)) return *status;
  if (!noHeader) printHeader();
  for (const double budget : budgets)
    for (const std::string& p : problems) {
      if (inProcess) printRow(p, budget, runOne(p, dir, budget, turns));
      else runChild(p, dir, budget, turns);
    }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return krr::guardedMain("bench_pomdp_suite", mainBody, argc, argv);
}
