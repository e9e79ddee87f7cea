// Benchmark: anytime bounds and simulated return of the point-based solver on the 30-request
// delivery-dialog POMDP of the KRR-RL paper (3 items x 5 rooms x 2 persons + terminal).
//
// Usage: bench_dialog_pomdp [--out dialog.pomdp] [--episodes 10000] [--seed 1]
//                           [--precision 0.01] [--timeout 10] [--discount 0.99]
//                           [--p-general 0.8] [--p-yesno 0.8] [--trial-gap-factor f]
//                           [--trial-weight-cutoff c] [--no-sawtooth] [--no-witness-pruning]
// Prints one line per checkpoint (0.1, 0.25, 0.5, 1, 2, 5, 10, 20, 60 s of solver time, up
// to --timeout, or until the gap is below --precision): time, lower and upper bound at the
// prior, gap, #alphas, #points, #trials, and the discounted return of the current policy over
// seeded simulated dialogs (mean +- 95% CI; the same seeds at every checkpoint); then the
// first time the gap fell below 4, 2, 1, 0.5, 0.1, and the 0.5 s policy against the final
// one. Writes the exact model as a Cassandra .pomdp file for SARSOP comparisons. For the
// long-run reference policy: --timeout 60 --precision 1e-4.
#include <algorithm>
#include <cmath>
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
  double precision = 0.01, timeout = 10.0;
  DialogSpec spec;
  bool sawtooth = true, witness = true;
  double trialGapFactor = SolverOptions().trialGapFactor;
  double trialWeightCutoff = SolverOptions().trialWeightCutoff;
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
    else if (a == "--trial-weight-cutoff") trialWeightCutoff = std::stod(val());
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
    opt.trialWeightCutoff = trialWeightCutoff;
    Stopwatch wall;
    PointBasedSolver solver(m, m.initialBelief(), opt);
    std::printf("# init (FIB + blind policies): %.4f s\n", solver.report().time);
    std::printf("%8s %10s %10s %8s %7s %7s %8s %10s %8s %7s %7s\n", "time_s", "lower", "upper",
                "gap", "alphas", "points", "trials", "sim_return", "ci95", "fulfil", "questions");
    // The solver runs in small steps so that the first time the gap falls below each
    // threshold is known to 0.02 s; the policy is simulated at the checkpoints only.
    const double checkpoints[] = {0.0, 0.1, 0.25, 0.5, 1, 2, 5, 10, 20, 60, 300};
    const double gapMarks[] = {4.0, 2.0, 1.0, 0.5, 0.1};
    double gapReached[5] = {-1, -1, -1, -1, -1};
    DialogStats at05, last;
    bool have05 = false;
    double t = 0.0;
    std::size_t printedTrials = 0;
    for (double ck : checkpoints) {
      if (ck > timeout) break;
      bool conv = solver.converged();
      while (!conv && t < ck) {
        t = std::min(ck, t + 0.02);
        conv = solver.runUntil(t);
        const auto r = solver.report();
        for (int k = 0; k < 5; ++k)
          if (gapReached[k] < 0 && r.gap() <= gapMarks[k]) gapReached[k] = r.time;
      }
      conv = conv || solver.runUntil(ck);
      auto r = solver.report();
      for (int k = 0; k < 5; ++k)
        if (gapReached[k] < 0 && r.gap() <= gapMarks[k]) gapReached[k] = r.time;
      if (r.trials == printedTrials && ck > 0.0) continue;  // nothing new since the last line
      printedTrials = r.trials;
      DialogStats st = simulateDialogs(dialog, solver.policy(), episodes, seed);
      if (ck <= 0.5) {
        at05 = st;
        have05 = true;
      }
      last = st;
      std::printf("%8.3f %10.4f %10.4f %8.4f %7zu %7zu %8zu %10.4f %8.4f %7.4f %7.3f%s\n", r.time,
                  r.lower, r.upper, r.gap(), r.alphas, r.points, r.trials, st.meanReturn, st.ci95,
                  st.fulfilledRate, st.meanQuestions, conv ? "  (certified)" : "");
      std::fflush(stdout);
      if (conv) break;
    }
    for (int k = 0; k < 5; ++k) {
      if (gapReached[k] >= 0)
        std::printf("# gap <= %.1f first reached at %.3f s of solver time\n", gapMarks[k],
                    gapReached[k]);
      else
        std::printf("# gap <= %.1f not reached\n", gapMarks[k]);
    }
    if (have05) {
      // Same seeds for every checkpoint (common random numbers): equal policies give equal
      // returns; otherwise compare the difference with the confidence intervals.
      std::printf("# policy at <= 0.5 s: return %.4f +- %.4f; final policy (%.3f s): %.4f +- %.4f;"
                  " difference %.4f (%s the final CI)\n",
                  at05.meanReturn, at05.ci95, solver.report().time, last.meanReturn, last.ci95,
                  at05.meanReturn - last.meanReturn,
                  std::abs(at05.meanReturn - last.meanReturn) <= last.ci95 ? "within"
                                                                            : "OUTSIDE");
    }
    std::printf("# wall time including simulations: %.2f s, peak RSS %.1f MiB\n", wall.seconds(),
                peakRssMiB());
  } catch (const krr::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
