// pomdp_solve: solve a Cassandra .pomdp file with the anytime point-based solver.
//
//   pomdp_solve FILE.pomdp [--precision e] [--timeout s] [--policy out.policy] [--seed n]
//               [--memory-budget MiB]
//
// Prints one line per checkpoint (geometric in solver time, and the final state):
//   time_s lower upper gap alphas
// for the bounds at the file's start belief, and writes the policy in APPL/SARSOP XML
// format if --policy is given. Input errors are reported as FILE:line:col: message on stderr
// with exit status 1; bad arguments exit with status 2.
//
// Budgets: --timeout counts from the start of the program. Reading the file stops with an error
// once it is spent; the time left after set-up goes to the solver. Model construction and the
// solver's set-up (one S x S LU per action) cannot be interrupted: they are bounded instead by
// the memory budget (--memory-budget, default $KRR_MEMORY_BUDGET_MIB or 1 GiB), which the
// reader checks against the declared sizes before allocating, and the clock is checked after
// each of them. A model too large for the budget is a FILE:line:col error naming the declaration.
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
#include "krr_core/pomdp/point_based_solver.h"

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: pomdp_solve FILE.pomdp [--precision e] [--timeout s] "
               "[--policy out.policy] [--seed n] [--memory-budget MiB]\n");
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
  double precision = 1e-3, timeout = 10.0, seed = 0.0, budgetMiB = 0.0;
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
    if (a == "--precision") {
      value(&precision);
    } else if (a == "--timeout") {
      value(&timeout);
    } else if (a == "--seed") {
      value(&seed);
    } else if (a == "--memory-budget") {
      value(&budgetMiB);
      if (!(budgetMiB > 0.0 && budgetMiB <= 1e9)) {
        std::fprintf(stderr, "pomdp_solve: --memory-budget must be a positive number of MiB\n");
        return 2;
      }
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
    // The solver's set-up factorises one S x S matrix per action (two dense S x S work
    // matrices at a time): the reader counts them too, so such a file fails at its declaration.
    limits.extra_bytes_per_state_pair = 2 * sizeof(double);
    krr::pomdp::Model model = krr::pomdp::loadCassandra(file, limits);
    if (wall.seconds() > timeout) {
      std::fprintf(stderr, "pomdp_solve: %s: timeout of %g s spent building the model (%.2f s)\n",
                   file.c_str(), timeout, wall.seconds());
      return 1;
    }
    krr::pomdp::SolverOptions opt;
    opt.precision = precision;
    opt.timeout = timeout;
    krr::pomdp::PointBasedSolver solver(model, model.initialBelief(), opt);
    // Solver time starts with its set-up; it gets what is left of the wall-clock budget.
    const double solveEnd = solver.report().time + std::max(0.0, timeout - wall.seconds());
    std::printf("# %s: %zu states, %zu actions, %zu observations, discount %g, seed %.0f\n",
                file.c_str(), model.getS(), model.getA(), model.getO(), model.getDiscount(), seed);
    std::printf("%10s %14s %14s %12s %8s\n", "time_s", "lower", "upper", "gap", "alphas");
    auto print = [&]() {
      auto r = solver.report();
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
      done = solver.runUntil(until) || until >= solveEnd;
      print();
      ck *= 2.0;
    }
    std::printf("# %s\n", solver.converged() ? "converged: gap <= precision"
                                             : "timeout: gap above precision");
    if (!policyOut.empty()) {
      solver.policy().writeApplXml(policyOut, file);
      std::printf("# policy (APPL XML) written to %s\n", policyOut.c_str());
    }
  } catch (const krr::Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("pomdp_solve", mainBody, argc, argv);
}
