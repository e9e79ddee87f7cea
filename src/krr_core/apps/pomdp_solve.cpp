// pomdp_solve: solve a Cassandra .pomdp or PomdpX .pomdpx file with the anytime point-based solver.
//
//   pomdp_solve FILE.pomdp|FILE.pomdpx [--precision e] [--timeout s] [--policy out.policy] [--seed n]
//               [--memory-budget MiB] [--memory-limit MiB] [--max-trials n]
//               [--trial-gap-factor f] [--trial-weight-cutoff c] [--verbose]
//
// Prints one line per checkpoint (geometric in solver time, and the final state):
//   time_s lower upper gap alphas
// for the bounds at the file's start belief, and writes the policy in APPL/SARSOP XML
// format if --policy is given. Input errors are reported as FILE:line:col: message on stderr
// with exit status 1; bad arguments exit with status 2.
//
// Budgets: --timeout counts from the start of the program. Reading the file stops with an error
// once it is spent (there is no model to bound yet). The solver's set-up gets at most half of
// what is left and each of its phases stops at that deadline, keeping valid bounds (at worst the blind-policy
// lower bound and Rmax / (1 - gamma)); the search gets the rest; the last line then says
// "timeout" and which set-up phase was cut short. The model is stored sparsely (dense only when
// small or dense): the memory budget (--memory-budget, default $KRR_MEMORY_BUDGET_MIB or 1 GiB)
// is checked against the declared sizes and then against the T and O entries as they are read.
// A model too large for the budget is a FILE:line:col error naming the declaration or statement.
//
// --memory-limit caps what the run holds: the model plus the solver's bounds (alpha vectors,
// plans, belief points and the lower-bound cache). A model larger than the limit is an error;
// otherwise the search stops when its next vector or point would exceed it, keeping valid
// bounds, and the last line says so. --max-trials is a deterministic work budget: the search
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
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/pomdpx_io.h"
#include "krr_core/pomdp/point_based_solver.h"

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: pomdp_solve FILE.pomdp|FILE.pomdpx [--precision e] [--timeout s] "
               "[--policy out.policy] [--seed n] [--memory-budget MiB]\n"
               "  FILE: Cassandra .pomdp or SARSOP PomdpX (.pomdpx, flattened: fully observable\n"
               "  state variables become part of the observation)\n");
}

bool parseNumber(const std::string& s, double* out) {
  char* end = nullptr;
  *out = std::strtod(s.c_str(), &end);
  return !s.empty() && end && *end == '\0' && std::isfinite(*out);
}

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  const krr::Stopwatch wall;  // --timeout covers reading and set-up too
  std::string file, policyOut;
  double precision = 1e-3, timeout = 10.0, seed = 0.0, budgetMiB = 0.0, maxTrials = 0.0;
  double limitMiB = 0.0;
  bool verbose = false;
  krr::pomdp::SolverOptions defaults;
  double gapFactor = defaults.trialGapFactor, weightCutoff = defaults.trialWeightCutoff;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto value = [&](double* out) {
      if (i + 1 >= argc || !parseNumber(argv[i + 1], out)) {
        std::fprintf(stderr, "pomdp_solve: %s needs a numeric value\n", a.c_str());
        usage();
        std::exit(2);
      }
      ++i;
    };
    // A numeric option whose value must satisfy `ok` (exit status 2 naming the rule otherwise).
    auto bounded = [&](double* out, bool (*ok)(double), const char* rule) {
      value(out);
      if (!ok(*out)) {
        std::fprintf(stderr, "pomdp_solve: %s must be %s\n", a.c_str(), rule);
        std::exit(2);
      }
    };
    if (a == "--precision") {
      value(&precision);
    } else if (a == "--timeout") {
      value(&timeout);
    } else if (a == "--seed") {
      value(&seed);
    } else if (a == "--max-trials") {
      bounded(&maxTrials, [](double x) { return x >= 1.0 && x <= 1e15; }, "a positive count");
    } else if (a == "--memory-limit") {
      bounded(&limitMiB, [](double x) { return x > 0.0 && x <= 1e9; },
              "a positive number of MiB");
    } else if (a == "--trial-gap-factor") {
      bounded(&gapFactor, [](double x) { return x > 0.0 && x <= 1.0; }, "in (0, 1]");
    } else if (a == "--trial-weight-cutoff") {
      bounded(&weightCutoff, [](double x) { return x >= 0.0 && x <= 1.0; }, "in [0, 1]");
    } else if (a == "--verbose") {
      verbose = true;
    } else if (a == "--memory-budget") {
      bounded(&budgetMiB, [](double x) { return x > 0.0 && x <= 1e9; },
              "a positive number of MiB");
    } else if (a == "--policy") {
      if (i + 1 >= argc) {
        usage();
        return 2;
      }
      policyOut = argv[++i];
    } else if (a == "-h" || a == "--help") {
      usage();
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "pomdp_solve: unknown option %s\n", a.c_str());
      usage();
      return 2;
    } else if (file.empty()) {
      file = a;
    } else {
      usage();
      return 2;
    }
  }
  if (file.empty()) {
    usage();
    return 2;
  }
  if (!(timeout > 0.0) || !(precision > 0.0)) {
    std::fprintf(stderr, "pomdp_solve: --timeout and --precision must be positive\n");
    return 2;
  }
  // The solver is deterministic; the seed is accepted for interface compatibility with
  // sampling solvers and recorded in the output.
  try {
    krr::pomdp::CassandraLimits limits;
    limits.memory_budget =
        budgetMiB > 0.0 ? static_cast<std::size_t>(budgetMiB * 1048576.0) : krr::memoryBudget();
    limits.timeout = timeout;
    // No S x S work matrices to reserve: the set-up factorises dense matrices only up to
    // PointBasedSolver::kDenseSetupStates (500) states, 4 MB at most; above, it sweeps the
    // sparse successor lists.
    krr::pomdp::CassandraStats stats;
    krr::pomdp::Model model = krr::pomdp::loadPomdpFile(file, limits, &stats);
    const double readSeconds = wall.seconds();
    krr::pomdp::SolverOptions opt;
    opt.precision = precision;
    opt.timeout = timeout;
    opt.maxTrials = static_cast<std::size_t>(maxTrials);
    opt.trialGapFactor = gapFactor;
    opt.trialWeightCutoff = weightCutoff;
    if (limitMiB > 0.0) {
      // The model is held already; the bounds get the rest of the limit.
      const double limitBytes = limitMiB * 1048576.0;
      const double modelBytes = static_cast<double>(model.storageBytes());
      if (modelBytes >= limitBytes)
        throw krr::ConfigError(file + ": the model alone takes " +
                               std::to_string(modelBytes / 1048576.0) +
                               " MiB, more than --memory-limit " + std::to_string(limitMiB) +
                               " MiB");
      opt.memoryLimit = static_cast<std::size_t>(limitBytes - modelBytes);
    }
    // A little time is kept for the last report and writing the policy.
    const double reserve = std::min(0.05 * timeout, 0.5);
    // Half of what is left for the set-up at most, the rest for the search.
    opt.setupTimeLimit = std::max(1e-6, 0.5 * (timeout - reserve - readSeconds));
    krr::pomdp::PointBasedSolver solver(model, model.initialBelief(), opt);
    // Solver time starts with its set-up; it gets what is left of the wall-clock budget.
    const double solveEnd =
        solver.report().time + std::max(0.0, timeout - reserve - wall.seconds());
    std::printf("# %s: %zu states, %zu actions, %zu observations, discount %g, seed %.0f\n",
                file.c_str(), model.getS(), model.getA(), model.getO(), model.getDiscount(), seed);
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
    // Bounds that are not finite (or not ordered) are never printed as bounds: the run stops
    // with an error. The model's reward limit (Model::kMaxAbsReward) rules this out; the check
    // makes sure that no path ever labels such numbers "valid bounds".
    auto print = [&]() {
      auto r = solver.report();
      if (!r.valid())
        throw krr::IncoherentError(file + ": the solver's bounds at the start belief are not "
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
                               ? "memory limit: NOT converged, search stopped at --memory-limit "
                                 "(valid bounds)"
                           : opt.maxTrials > 0 && solver.report().trials >= opt.maxTrials
                               ? "trial budget: NOT converged, --max-trials reached (valid bounds)"
                               : "timeout: NOT converged, gap above precision (valid bounds)");
    std::printf("# time: search %.3f s, total %.3f s of %g s\n",
                solver.report().time - su.seconds(), wall.seconds(), timeout);
    if (verbose) {
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
    if (!policyOut.empty()) {
      solver.policy().writeApplXml(policyOut, file);
      std::printf("# policy (APPL XML) written to %s\n", policyOut.c_str());
    }
    // Freeing a large dense model took 0.1-0.2 s after the budget's last report (3000 states,
    // 0.57 GB): the process ends here and leaves that to the OS.
    std::fflush(stdout);
    std::fflush(stderr);
    std::_Exit(0);
  } catch (const krr::Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("pomdp_solve", mainBody, argc, argv);
}
