// Benchmark: anytime bounds and simulated return of the point-based solver on the 30-request
// delivery-dialog POMDP of the KRR-RL paper (3 items x 5 rooms x 2 persons + terminal).
//
// Usage: bench_dialog_pomdp [--out dialog.pomdp] [--episodes 10000] [--seed 1]
//                           [--precision 1.0] [--timeout 10] [--discount 0.99]
//                           [--p-general 0.8] [--p-yesno 0.8] [--trial-gap-factor f]
//                           [--no-sawtooth] [--no-witness-pruning]
// Prints one line per checkpoint (0.1, 0.25, 0.5, 1, 2, 5, 10 s of solver time): time,
// lower and upper bound at the prior, gap, #alphas, #points, and the discounted return of the
// current policy over seeded simulated dialogs (mean +- 95% CI), and writes the exact model
// as a Cassandra .pomdp file for SARSOP comparisons.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/dialog_pomdp.h"
#include "krr_core/pomdp/point_based_solver.h"

using namespace krr;
using namespace krr::pomdp;

int main(int argc, char** argv) {
  std::string out = "./dialog.pomdp";
  std::size_t episodes = 10000;
  std::uint64_t seed = 1;
  double precision = 1.0, timeout = 10.0;
  DialogSpec spec;
  bool sawtooth = true, witness = true;
  double trialGapFactor = SolverOptions().trialGapFactor;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto val = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--out") out = val();
    else if (a == "--episodes") episodes = std::stoul(val());
    else if (a == "--seed") seed = std::stoull(val());
    else if (a == "--precision") precision = std::stod(val());
    else if (a == "--timeout") timeout = std::stod(val());
    else if (a == "--no-sawtooth") sawtooth = false;
    else if (a == "--no-witness-pruning") witness = false;
    else if (a == "--trial-gap-factor") trialGapFactor = std::stod(val());
    else if (a == "--discount") spec.discount = std::stod(val());
    else if (a == "--p-general") spec.pGeneral = std::stod(val());
    else if (a == "--p-yesno") spec.pYesNo = std::stod(val());
    else {
      std::fprintf(stderr, "unknown argument %s\n", a.c_str());
      return 2;
    }
  }
  try {
    // alice's office is room1, bob's is room2; 0.8 own-office prior (paper, Sec. III-B).
    spec.prior = ownOfficePrior(3, 5, {0, 1}, 0.8);
    Eigen::VectorXd reach(5);
    reach << 0.95, 0.65, 0.75, 0.95, 0.5;
    spec.delivery = deliveryMatrix(3, reach, 2);
    DialogPomdp dialog(spec);
    const Model& m = dialog.model();
    saveCassandra(out, m);
    std::printf("# dialog POMDP: %zu states, %zu actions, %zu observations, discount %.3f, "
                "pGeneral %.2f, pYesNo %.2f; model written to %s\n",
                m.getS(), m.getA(), m.getO(), m.getDiscount(), spec.pGeneral, spec.pYesNo,
                out.c_str());
    SolverOptions opt;
    opt.precision = precision;
    opt.sawtooth = sawtooth;
    opt.witnessPruning = witness;
    opt.trialGapFactor = trialGapFactor;
    Stopwatch wall;
    PointBasedSolver solver(m, m.initialBelief(), opt);
    std::printf("# init (FIB + blind policies): %.4f s\n", solver.report().time);
    std::printf("%8s %10s %10s %8s %7s %7s %8s %10s %8s %7s %7s\n", "time_s", "lower", "upper",
                "gap", "alphas", "points", "trials", "sim_return", "ci95", "fulfil", "questions");
    const double checkpoints[] = {0.0, 0.1, 0.25, 0.5, 1, 2, 5, 10, 20, 60, 300};
    for (double ck : checkpoints) {
      if (ck > timeout) break;
      bool conv = solver.runUntil(ck);
      auto r = solver.report();
      DialogStats st = simulateDialogs(dialog, solver.policy(), episodes, seed);
      std::printf("%8.3f %10.4f %10.4f %8.4f %7zu %7zu %8zu %10.4f %8.4f %7.4f %7.3f%s\n", r.time,
                  r.lower, r.upper, r.gap(), r.alphas, r.points, r.trials, st.meanReturn, st.ci95,
                  st.fulfilledRate, st.meanQuestions, conv ? "  (certified)" : "");
      std::fflush(stdout);
      if (conv) break;
    }
    std::printf("# wall time including simulations: %.2f s, peak RSS %.1f MiB\n", wall.seconds(),
                peakRssMiB());
  } catch (const krr::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
