// pomdp_solve: solve a Cassandra .pomdp file with the anytime point-based solver.
//
//   pomdp_solve FILE.pomdp [--precision e] [--timeout s] [--policy out.policy] [--seed n]
//
// Prints one line per checkpoint (geometric in solver time, and the final state):
//   time_s lower upper gap alphas
// for the bounds at the file's start belief, and writes the policy in APPL/SARSOP XML
// format if --policy is given. Input errors are reported as FILE:line:col: message on stderr
// with exit status 1; bad arguments exit with status 2.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/point_based_solver.h"

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: pomdp_solve FILE.pomdp [--precision e] [--timeout s] "
               "[--policy out.policy] [--seed n]\n");
}

bool parseNumber(const std::string& s, double* out) {
  char* end = nullptr;
  *out = std::strtod(s.c_str(), &end);
  return !s.empty() && end && *end == '\0';
}

}  // namespace

int main(int argc, char** argv) {
  std::string file, policyOut;
  double precision = 1e-3, timeout = 10.0, seed = 0.0;
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
  // The solver is deterministic; the seed is accepted for interface compatibility with
  // sampling solvers and recorded in the output.
  try {
    krr::pomdp::Model model = krr::pomdp::loadCassandra(file);
    krr::pomdp::SolverOptions opt;
    opt.precision = precision;
    opt.timeout = timeout;
    krr::pomdp::PointBasedSolver solver(model, model.initialBelief(), opt);
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
      if (ck < timeout && ck <= solver.report().time) {  // checkpoint already passed (init)
        ck *= 2.0;
        continue;
      }
      const double until = ck < timeout ? ck : timeout;
      done = solver.runUntil(until) || until >= timeout;
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
