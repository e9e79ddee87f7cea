// pomdp_solve: solve a Cassandra .pomdp or PomdpX .pomdpx file with the anytime point-based solver.
//
//   pomdp_solve FILE.pomdp|FILE.pomdpx [--precision e] [--timeout s] [--policy out.policy] [--seed n]
//               [--memory-budget MiB] [--max-trials n]
//               [--trial-gap-factor f] [--trial-weight-cutoff c] [--verbose]
//
// Prints one line per checkpoint (geometric in solver time, and the final state):
//   time_s lower upper gap alphas
// for the bounds at the file's start belief, and writes the policy in APPL/SARSOP XML
// format if --policy is given. Input errors are reported as FILE:line:col: message on stderr
// with exit status 1; bad arguments exit with status 2; --help prints the usage on stdout.
//
// Budgets: --timeout counts from the start of the program. Reading the file stops with an error
// once it is spent (there is no model to bound yet). The solver's set-up gets at most half of
// what is left and each of its phases stops at that deadline, keeping valid bounds (at worst the blind-policy
// lower bound and Rmax / (1 - gamma)); the search gets the rest; the last line then says
// "timeout" and which set-up phase was cut short. The model is stored sparsely (dense only when
// small or dense).
//
// --memory-budget caps what the run holds: the model plus the solver's bounds (alpha vectors,
// plans, belief points and the lower-bound cache). The file is checked against it as it is read
// (declared sizes, then the T and O entries: a model too large is a FILE:line:col error naming
// the declaration or statement); a model larger than the budget is an error; otherwise the
// search stops when its next vector or point would exceed it, keeping valid bounds, and the
// last line says so. Without it the model gets $KRR_MEMORY_BUDGET_MIB or 1 GiB and the bounds
// are not capped. --max-trials is a deterministic work budget: the search
// is deterministic (there is no random choice; --seed is recorded only), so two runs with the
// same --max-trials that the timeout does not cut give identical bounds, and more trials never
// give a lower lower bound. --verbose adds where the search time went (backups, sampling,
// pruning) and the bounds' memory.
//
// Probability rows of the file that sum to 1 within 1e-4 (six-decimal benchmark files) are
// renormalised; the header reports how many and the largest deviation.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/format.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/pomdpx_io.h"
#include "krr_core/pomdp/point_based_solver.h"

namespace {

/// @brief A setter that reads a number and refuses it outside the rule `ok` (exit status 2).
krr::OptionParser::Setter bounded(const std::string& name, double* target, bool (*ok)(double),
                                  const std::string& rule) {
  return [=](const std::string& v) {
    const double x = krr::parseNumberOption(name, v);
    if (!ok(x)) throw krr::ConfigError("option " + name + ": '" + v + "' must be " + rule);
    *target = x;
  };
}

/// @brief The command line.
struct Args {
  std::string file, policyOut;
  double precision = 1e-3, timeout = 10.0, seed = 0.0, budgetMiB = 0.0, maxTrials = 0.0;
  bool verbose = false;
  double gapFactor = krr::pomdp::SolverOptions().trialGapFactor;
  double weightCutoff = krr::pomdp::SolverOptions().trialWeightCutoff;
};

/// @brief Reads the command line into `a`; an exit status when the program ends there
/// (--help, a bad argument).
std::optional<int> parseArgs(int argc, char** argv, Args* a) {
  krr::OptionParser cli("pomdp_solve",
                        "Solve a POMDP file with the anytime point-based solver; print the bounds\n"
                        "at the start belief at each checkpoint (time_s lower upper gap alphas).");
  cli.positional("FILE",
                 "Cassandra .pomdp or SARSOP PomdpX .pomdpx (flattened: fully observable state "
                 "variables become part of the observation)",
                 [a](const std::string& v) {
                   if (!a->file.empty()) throw krr::ConfigError("more than one input file: " + v);
                   a->file = v;
                 });
  cli.add("--precision", "E", "target gap between the bounds", &a->precision);
  cli.add("--timeout", "S", "wall-clock budget in seconds, reading and set-up included",
          &a->timeout);
  cli.add("--policy", "FILE", "write the policy (APPL XML) here", &a->policyOut);
  cli.add("--seed", "N", "recorded only (the search is deterministic)", &a->seed);
  cli.add("--memory-budget", "MiB", "cap on the model plus the solver's bounds",
          bounded("--memory-budget", &a->budgetMiB, [](double x) { return x > 0.0 && x <= 1e9; },
                  "a positive number of MiB"),
          "$KRR_MEMORY_BUDGET_MIB or 1024 for the model, bounds not capped");
  cli.add("--max-trials", "N", "deterministic work budget (search trials)",
          bounded("--max-trials", &a->maxTrials, [](double x) { return x >= 1.0 && x <= 1e15; },
                  "a positive count"),
          "no limit");
  cli.add("--trial-gap-factor", "F", "trial precision as a share of the root gap, in (0, 1]",
          bounded("--trial-gap-factor", &a->gapFactor,
                  [](double x) { return x > 0.0 && x <= 1.0; }, "in (0, 1]"),
          krr::formatNumber(a->gapFactor));
  cli.add("--trial-weight-cutoff", "C", "weight below which a trial stops, in [0, 1]",
          bounded("--trial-weight-cutoff", &a->weightCutoff,
                  [](double x) { return x >= 0.0 && x <= 1.0; }, "in [0, 1]"),
          krr::formatNumber(a->weightCutoff));
  cli.flag("--verbose", "print where the search time went and the bounds' memory", &a->verbose);
  return cli.parse(argc, argv, [a]() {
    if (a->file.empty()) throw krr::ConfigError("no input file");
    if (!(a->timeout > 0.0) || !(a->precision > 0.0))
      throw krr::ConfigError("--timeout and --precision must be positive");
  });
}

/// @brief The solver's options: the model is held already, so the bounds get the rest of
/// --memory-budget; the set-up gets at most half of the time left after reading, less the
/// `reserve` kept for the last report.
krr::pomdp::SolverOptions solverOptions(const Args& a, const krr::pomdp::Model& model,
                                        double readSeconds, double reserve) {
  krr::pomdp::SolverOptions opt;
  opt.precision = a.precision;
  opt.timeout = a.timeout;
  opt.maxTrials = static_cast<std::size_t>(a.maxTrials);
  opt.trialGapFactor = a.gapFactor;
  opt.trialWeightCutoff = a.weightCutoff;
  if (a.budgetMiB > 0.0) {
    // The model is held already; the bounds get the rest of the budget.
    const double limitBytes = a.budgetMiB * 1048576.0;
    const double modelBytes = static_cast<double>(model.storageBytes());
    if (modelBytes >= limitBytes)
      throw krr::ConfigError(a.file + ": the model alone takes " +
                             std::to_string(modelBytes / 1048576.0) +
                             " MiB, more than --memory-budget " + std::to_string(a.budgetMiB) +
                             " MiB");
    opt.memoryLimit = static_cast<std::size_t>(limitBytes - modelBytes);
  }
  // Half of what is left for the set-up at most, the rest for the search.
  opt.setupTimeLimit = std::max(1e-6, 0.5 * (a.timeout - reserve - readSeconds));
  return opt;
}

/// @brief The header: the model, renormalised rows, and where the set-up time went.
void printHeader(const Args& a, const krr::pomdp::Model& model,
                 const krr::pomdp::CassandraStats& stats,
                 const krr::pomdp::PointBasedSolver& solver, double readSeconds) {
  std::printf("# %s: %zu states, %zu actions, %zu observations, discount %g, seed %.0f\n",
              a.file.c_str(), model.getS(), model.getA(), model.getO(), model.getDiscount(),
              a.seed);
  if (stats.renormalised_rows > 0)
    std::printf("# renormalised %zu distribution(s); largest |sum - 1| = %.3g (%s)\n",
                stats.renormalised_rows, stats.max_sum_deviation,
                stats.max_deviation_where.c_str());
  const krr::pomdp::SetupReport& su = solver.setupReport();
  std::printf("# time: read+build %.3f s; set-up %.3f s (lower %.3f s: %s; MDP %.3f s: %s; "
              "FIB %.3f s: %zu iteration(s)%s)%s\n",
              readSeconds, su.seconds(), su.lowerSeconds,
              su.lowerExact ? "exact" : "cut short, blind-policy iterate",
              su.mdpSeconds, su.mdpExact ? "exact" : "cut short", su.fibSeconds,
              su.fibIterations, su.fibConverged ? ", converged" : "",
              su.timedOut ? " -- set-up stopped at the time budget" : "");
  std::printf("%10s %14s %14s %12s %8s\n", "time_s", "lower", "upper", "gap", "alphas");
}

/// @brief Runs the search until solveEnd (solver time), printing the bounds at each
/// checkpoint (geometric in solver time) and at the end, then why it stopped.
void search(const Args& a, krr::pomdp::PointBasedSolver& solver,
            const krr::pomdp::SolverOptions& opt, double solveEnd) {
  // Bounds that are not finite (or not ordered) are never printed as bounds: the run stops
  // with an error. The model's reward limit (Model::kMaxAbsReward) rules this out; the check
  // makes sure that no path ever labels such numbers "valid bounds".
  auto print = [&]() {
    auto r = solver.report();
    if (!r.valid())
      throw krr::IncoherentError(a.file + ": the solver's bounds at the start belief are not "
                                 "finite, ordered numbers (lower " + std::to_string(r.lower) +
                                 ", upper " + std::to_string(r.upper) + "): no valid bounds");
    std::printf("%10.4f %14.6f %14.6f %12.6f %8zu\n", r.time, r.lower, r.upper, r.gap(),
                r.alphas);
    std::fflush(stdout);
  };
  print();
  double ck = 0.01;
  bool done = solver.converged();
  while (!done) {
    if (ck < solveEnd && ck <= solver.report().time) {  // checkpoint already passed (init)
      ck *= 2.0;
      continue;
    }
    const double until = ck < solveEnd ? ck : solveEnd;
    done = solver.runUntil(until, solveEnd) || until >= solveEnd || solver.memoryLimited() ||
           (opt.maxTrials > 0 && solver.report().trials >= opt.maxTrials);
    print();
    ck *= 2.0;
  }
  std::printf("# %s\n", solver.converged() ? "converged: gap <= precision"
                         : solver.memoryLimited()
                             ? "memory budget: NOT converged, search stopped at --memory-budget "
                               "(valid bounds)"
                         : opt.maxTrials > 0 && solver.report().trials >= opt.maxTrials
                             ? "trial budget: NOT converged, --max-trials reached (valid bounds)"
                             : "timeout: NOT converged, gap above precision (valid bounds)");
}

/// @brief --verbose: where the search time went and the bounds' memory.
void printProfile(const krr::pomdp::PointBasedSolver& solver) {
  const krr::pomdp::SearchProfile& pr = solver.profile();
  const krr::pomdp::BoundsReport rep = solver.report();
  std::printf("# search profile: %zu trials (mean depth %.1f, max %zu); upper backups %zu "
              "(%.3f s); lower backups %zu (%.3f s); sampling %.3f s; prunes %zu (%.3f s); "
              "vectors added %zu, kept %zu; points added %zu, pruned %zu in %zu prunes "
              "(%.3f s), kept %zu; bounds %.1f MiB\n",
              rep.trials, rep.trials ? static_cast<double>(pr.depthSum) / rep.trials : 0.0,
              pr.maxDepth, pr.upperBackups, pr.upperBackupSeconds, pr.lowerBackups,
              pr.lowerBackupSeconds, pr.sampleSeconds, pr.prunes, pr.pruneSeconds,
              pr.alphasAdded, rep.alphas, pr.pointsAdded, pr.pointsPruned, pr.pointPrunes,
              pr.pointPruneSeconds, rep.points, rep.bytes / 1048576.0);
}

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  const krr::Stopwatch wall;  // --timeout covers reading and set-up too
  Args a;
  if (const auto status = parseArgs(argc, argv, &a)) return *status;
  // The solver is deterministic; the seed is accepted for interface compatibility with
  // sampling solvers and recorded in the output.
  krr::pomdp::CassandraLimits limits;
  limits.memory_budget =
      a.budgetMiB > 0.0 ? static_cast<std::size_t>(a.budgetMiB * 1048576.0) : krr::memoryBudget();
  limits.timeout = a.timeout;
  // No S x S work matrices to reserve: the set-up factorises dense matrices only up to
  // PointBasedSolver::kDenseSetupStates (500) states, 4 MB at most; above, it sweeps the
  // sparse successor lists.
  krr::pomdp::CassandraStats stats;
  krr::pomdp::Model model = krr::pomdp::loadPomdpFile(a.file, limits, &stats);
  const double readSeconds = wall.seconds();
  // A little time is kept for the last report and writing the policy.
  const double reserve = std::min(0.05 * a.timeout, 0.5);
  const krr::pomdp::SolverOptions opt = solverOptions(a, model, readSeconds, reserve);
  krr::pomdp::PointBasedSolver solver(model, model.initialBelief(), opt);
  // Solver time starts with its set-up; it gets what is left of the wall-clock budget.
  const double solveEnd =
      solver.report().time + std::max(0.0, a.timeout - reserve - wall.seconds());
  printHeader(a, model, stats, solver, readSeconds);
  search(a, solver, opt, solveEnd);
  std::printf("# time: search %.3f s, total %.3f s of %g s\n",
              solver.report().time - solver.setupReport().seconds(), wall.seconds(), a.timeout);
  if (a.verbose) printProfile(solver);
  if (!a.policyOut.empty()) {
    solver.policy().writeApplXml(a.policyOut, a.file);
    std::printf("# policy (APPL XML) written to %s\n", a.policyOut.c_str());
  }
  // Freeing a large dense model took 0.1-0.2 s after the budget's last report (3000 states,
  // 0.57 GB): the process ends here and leaves that to the OS.
  std::fflush(stdout);
  std::fflush(stderr);
  std::_Exit(0);
}

int main(int argc, char** argv) {
  return krr::guardedMain("pomdp_solve", mainBody, argc, argv);
}
